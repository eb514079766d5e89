"""harness/build/runtime_bundle.py and the built FMUs: each carries its own Python runtime, described by
a format-2 python_runtime.cfg with paths relative to resources/, and nothing of the build machine.

The FMUs cannot be instantiated by a host until the loader reads format 2; here the runtime is
run the way the bridge will: the build interpreter's executable with ``-I -S`` and ``sys.path``
only the runtime's entries, the package loaded under its private alias."""
from __future__ import annotations

import hashlib
import io
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from harness.build import elf, runtime_bundle
from harness.build.fmu import FMUS, interface
from harness.build.fmu_contents import RUNTIME_ARCHIVES, unpack_runtime_archives
from harness.common.paths import checkout_root

CFG_KEYS = {"format", "version", "libpython", "home", "path", "preload", "package", "module", "class", "guid",
            "archive"}
REPEATED = {"path", "preload", "archive"}


def parse_cfg(text: str) -> dict[str, list[str]]:
    """The cfg as the C loader reads it: key=value lines and # comments only, known keys, single
    keys once."""
    out: dict[str, list[str]] = {}
    for line in text.splitlines():
        if line.startswith("#"):
            continue
        key, sep, value = line.partition("=")
        assert sep and key in CFG_KEYS, f"not a key=value line of a known key: {line!r}"
        assert key in REPEATED or key not in out, f"{key} twice"
        out.setdefault(key, []).append(value)
    return out


@pytest.fixture(scope="module")
def extracted(fmu_files, tmp_path_factory):
    """Each FMU extracted into a folder whose path has spaces and non-ASCII characters."""
    out = {}
    for name, fmu in fmu_files.items():
        folder = tmp_path_factory.mktemp("extr") / f"an FMU ü {name}"
        with zipfile.ZipFile(fmu) as z:
            z.extractall(folder)
        unpack_runtime_archives(folder / "resources")   # the runtime's files where the loader's paths name them
        out[name] = folder
    return out


def _runtime_names(z: zipfile.ZipFile) -> set[str]:
    """The FMU's member names with its runtime archives' members as resources/<name>."""
    import io

    names = set(z.namelist())
    for member in RUNTIME_ARCHIVES.values():
        if member in names:
            with zipfile.ZipFile(io.BytesIO(z.read(member))) as inner:
                names |= {f"resources/{n}" for n in inner.namelist()}
    return names


def test_cfg_is_format_2_with_relative_paths_that_exist(fmu_files):
    for name, fmu in fmu_files.items():
        with zipfile.ZipFile(fmu) as z:
            names = _runtime_names(z)
            cfg = parse_cfg(z.read("resources/python_runtime.cfg").decode())
            for line in cfg["archive"]:      # each archive's SHA-256, then its path
                digest, rel = line.split(" ")
                assert hashlib.sha256(z.read(f"resources/{rel}")).hexdigest() == digest, rel
            md = z.read("modelDescription.xml").decode()
        assert cfg["format"] == ["2"] and cfg["version"] == [runtime_bundle.VERSION]
        assert cfg["package"] == ["spurdiff"] and cfg["module"] == ["_fmu_entry"] and cfg["class"] == [name]
        assert f'guid="{cfg["guid"][0]}"' in md
        assert 'needsExecutionTool="false"' in md
        assert cfg["home"] == ["python"]
        assert cfg["path"] == list(runtime_bundle.SEARCH_PATH)
        for key in ("libpython", "home", "path", "preload"):
            for p in cfg.get(key, []):
                assert not p.startswith("/") and ".." not in p.split("/") and "\\" not in p, p
                assert f"resources/{p}" in names or any(n.startswith(f"resources/{p}/") for n in names), p
        assert "resources/spurdiff.zip" in names and not any(        # the package as one archive
            n.startswith("resources/spurdiff/") and not n.endswith((".so", ".dll")) for n in names)
        with zipfile.ZipFile(fmu) as z, zipfile.ZipFile(io.BytesIO(z.read("resources/spurdiff.zip"))) as pz:
            inner = pz.namelist()
        assert {"spurdiff/_fmu_entry.py", "spurdiff/_fmu_entry.pyc", "spurdiff/__init__.pyc"} <= set(inner)
        assert not any("__pycache__" in n or n.endswith((".so", ".dll")) for n in inner)
        assert not any(n.startswith("resources/pythonfmu/") for n in names)
        # pythonfmu's win64 wrapper is gone; where mingw-w64 was installed, ours is there instead
        win64 = sorted(n for n in names if n.startswith("binaries/win64/"))
        assert win64 in ([], [f"binaries/win64/{name}.dll", "binaries/win64/fmi2_pybridge.dll"]), win64
        assert f"resources/{name}.py" not in names


def test_no_path_of_the_build_machine_in_any_text_file(fmu_files):
    needles = {str(p) for p in (Path(sys.prefix), Path(sys.base_prefix), Path.home(), checkout_root())
               if p is not None and str(p) not in ("/", "")}
    needles |= {os.path.realpath(n) for n in needles}
    for fmu in fmu_files.values():
        with zipfile.ZipFile(fmu) as z:
            for item in z.infolist():
                data = z.read(item)
                if b"\0" in data:
                    continue
                try:
                    text = data.decode("utf-8")
                except UnicodeDecodeError:
                    continue
                hits = [n for n in needles if n in text]
                assert not hits, f"{fmu.name}:{item.filename} holds {hits}"


def test_no_file_at_all_names_the_checkout_and_only_cpythons_binaries_name_its_prefix(fmu_files):
    """Binaries and pycs included: the checkout's folder nowhere (compiled with a prefix map, pycs
    with relative file names); the build Python's prefix only inside libpython (its compiled-in
    default prefix, unused: the loader sets home) and the stdlib's extension modules (the string
    of the RUNPATH removed, assert messages)."""
    root = checkout_root()
    prefixes = {os.path.realpath(sys.base_prefix), sys.base_prefix}
    for fmu in fmu_files.values():
        with zipfile.ZipFile(fmu) as z:
            for item in z.infolist():
                data = z.read(item)
                if root is not None:
                    assert str(root).encode() not in data, f"{fmu.name}:{item.filename}"
                if any(p.encode() in data for p in prefixes):
                    assert (item.filename.endswith(f"/{runtime_bundle.libpython().name}")
                            or "/lib-dynload/" in item.filename), f"{fmu.name}:{item.filename}"


def test_runtime_elf_files_need_only_the_system_preloads_or_their_neighbours(extracted):
    """Every DT_NEEDED of every ELF file in the runtime is glibc's/libgcc's, a preloaded library
    of the cfg, or a library inside the runtime; none has an absolute RPATH/RUNPATH."""
    res = extracted["WheelLoad"] / "resources"
    cfg = parse_cfg((res / "python_runtime.cfg").read_text())
    preloaded = {Path(p).name for p in cfg.get("preload", [])}
    files = [p for p in (res / "python").rglob("*") if p.is_file() and elf.is_elf(p)]
    inside = {p.name for p in files} | {elf.dynamic(p).soname for p in files}
    assert preloaded <= inside
    assert "libffi.so.8" in preloaded          # _ctypes is carried (the kernels' bindings)
    for p in files:
        info = elf.dynamic(p)
        for soname in info.needed:
            assert soname in runtime_bundle.SYSTEM_LIBRARIES or soname in inside, f"{p.name} needs {soname}"
        for entry in info.rpath + info.runpath:
            assert entry.startswith("$ORIGIN"), f"{p.name}: {entry}"


def test_elf_reader_agrees_with_readelf():
    lib = runtime_bundle.libpython()
    if lib is None or shutil.which("readelf") is None:
        pytest.skip("no shared libpython or no readelf here")
    out = subprocess.run(["readelf", "-d", str(lib)], capture_output=True, text=True, check=True).stdout
    needed = [line.split("[")[1].rstrip("]") for line in out.splitlines() if "(NEEDED)" in line]
    info = elf.dynamic(lib)
    assert info.needed == needed and needed
    assert info.soname == lib.name


def test_the_stdlib_is_the_imported_part_only_sourceless_and_zipped(extracted):
    res = extracted["Vehicle"] / "resources"
    pylib = res / runtime_bundle.PYLIB
    assert {p.name for p in pylib.iterdir()} <= {"lib-dynload", "LICENSE.txt"}     # no site-packages
    with zipfile.ZipFile(res / runtime_bundle.STDLIB_ZIP) as z:
        names = z.namelist()
        assert all(i.compress_type == zipfile.ZIP_STORED for i in z.infolist())   # zipimport needs no zlib
        os_pyc = z.read("os.pyc")
    top = {n.split("/")[0] for n in names}
    for need in ("encodings", "importlib", "json", "ctypes", "os.pyc", "site.pyc"):
        assert need in top
    for denied in ("test", "idlelib", "tkinter", "lib2to3", "distutils", "venv", "ensurepip"):
        assert denied not in top and f"{denied}.pyc" not in top
    assert not any(n.startswith(("config-", "_sysconfigdata")) for n in top)
    assert not any(n.endswith(".py") or "__pycache__" in n for n in names)      # sourceless, legacy layout
    flags = int.from_bytes(os_pyc[4:8], "little")
    assert flags == 0b01          # hash-based, not checked (there is no source to check against)


def test_the_runtime_runs_each_model_as_the_build_python_does(extracted, fmu_files):
    """The FMU's own module path only (nothing of the build's stdlib after start-up): the package
    loads under its alias, the model runs 20 steps with its state got, serialized and set back, and
    gives the values the build's Python gives on its own standard library."""
    startup = runtime_bundle.startup_modules()
    for name, folder in extracted.items():
        res = folder / "resources"
        experiment = interface(name).DEFAULT_EXPERIMENT
        out = runtime_bundle.run_in_runtime(res, [name], experiment)
        outside = [(n, f) for n, f in out["modules"].items()
                   if f not in (None, "frozen", "built-in") and n not in startup and not f.startswith(str(res))]
        assert outside == [], outside
        assert not any(n.split(".")[0] in ("spurdiff", "pythonfmu", "scipy") for n in out["modules"])
        # the same package run on the build interpreter's stdlib
        ref = runtime_bundle._run_probe(runtime_bundle.probe_spec(
            {name: (res / "spurdiff", experiment)}, [str(runtime_bundle.STDLIB), str(runtime_bundle.DYNLOAD)]))
        assert out["results"][name] == ref["results"][name]
        assert any(v != 0.0 for v in out["results"][name])


@pytest.fixture(scope="module")
def fmu3_files(fmu_files):
    from harness.build.fmu3 import build

    return dict(zip(fmu_files, build(list(fmu_files), quiet=True)))


def _member_names(data: bytes, where: str) -> list[str]:
    """Every member name of the zip archive ``data`` and, recursively, of each archive inside it
    (``*.zip`` members), as ``where/name``, ``where/name.zip/inner``..."""
    out = []
    with zipfile.ZipFile(io.BytesIO(data)) as z:
        for n in z.namelist():
            out.append(f"{where}/{n}")
            if n.endswith(".zip"):
                out += _member_names(z.read(n), f"{where}/{n}")
    return out


def test_no_fmu_carries_numpy_anywhere(fmu_files, fmu3_files):
    """The package imports no numpy (tests/physics/test_numpy_free.py), so no FMU carries it: no member
    of an FMI 2.0 or 3.0 FMU, nor of the archives inside it (the runtimes' resources/runtime/*.zip and
    the standard library's zip in them, the package's resources/spurdiff.zip), has "numpy" in its path,
    and no runtime description puts a site-packages folder on the module path."""
    assert set(fmu_files) == set(fmu3_files) == set(FMUS)
    for fmu in [*fmu_files.values(), *fmu3_files.values()]:
        names = _member_names(fmu.read_bytes(), fmu.name)
        for archive in (RUNTIME_ARCHIVES["common"], RUNTIME_ARCHIVES["linux64"], "resources/spurdiff.zip"):
            assert any(n.startswith(f"{fmu.name}/{archive}/") for n in names), f"{fmu.name}: {archive} not opened"
        assert any(f"/{runtime_bundle.STDLIB_ZIP}/" in n for n in names), f"{fmu.name}: the stdlib zip not opened"
        hits = [n for n in names if "numpy" in n.lower()]
        assert hits == [], hits
        with zipfile.ZipFile(fmu) as z:
            for cfg in ("resources/python_runtime.cfg", "resources/python_runtime_win64.cfg"):
                if cfg in z.namelist():
                    text = z.read(cfg).decode()
                    assert "numpy" not in text and "site-packages" not in text, f"{fmu.name}:{cfg}"


def test_each_fmu_is_at_most_40_mb_zipped(fmu_files):
    for fmu in fmu_files.values():
        assert fmu.stat().st_size <= 40e6, f"{fmu.name}: {fmu.stat().st_size / 1e6:.1f} MB"


def test_one_runtime_for_all_fmus(fmu_files):
    cfgs = set()
    for fmu in fmu_files.values():
        with zipfile.ZipFile(fmu) as z:
            cfg = parse_cfg(z.read("resources/python_runtime.cfg").decode())
            cfgs.add((tuple(cfg["libpython"]), tuple(cfg.get("preload", []))))
    assert len(cfgs) == 1 and set(FMUS) == set(fmu_files)


def test_prune_keeps_the_newest_runtimes_and_drops_dead_work_folders(tmp_path):
    for i, name in enumerate(["runtime-a", "runtime-b", "runtime-c", "runtime-d"]):
        (tmp_path / name).mkdir()
        os.utime(tmp_path / name, (1000 + i, 1000 + i))
    (tmp_path / ".runtime-e-123").mkdir()
    runtime_bundle._prune(tmp_path, keep=tmp_path / "runtime-a")
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == ["runtime-a", "runtime-d"]     # the one in use and the newest other


def _section_names(path: Path) -> set[str]:
    """The section names of the ELF file ``path`` (64-bit little-endian), from its section headers."""
    import struct
    data = path.read_bytes()
    assert data[:4] == b"\x7fELF" and data[4] == 2 and data[5] == 1, path
    shoff, = struct.unpack_from("<Q", data, 0x28)
    shentsize, shnum, shstrndx = struct.unpack_from("<HHH", data, 0x3A)
    headers = [struct.unpack_from("<IIQQQQ", data, shoff + i * shentsize) for i in range(shnum)]
    strtab = headers[shstrndx][4]
    return {data[strtab + h[0]:data.index(b"\0", strtab + h[0])].decode() for h in headers}


@pytest.mark.skipif(shutil.which("strip") is None, reason="no strip (binutils): the build keeps the symbol tables")
def test_the_runtime_binaries_carry_no_symbol_table(extracted):
    """libpython and the extension modules lose .symtab (strip --strip-unneeded: fewer bytes for every
    host's unzip) and keep their dynamic symbols, which the loader binds."""
    res = extracted["SpurDifferential"] / "resources"
    lib = res / "python" / "lib"
    binaries = [next(lib.glob("libpython3*.so*")), *sorted((lib / f"python{sys.version_info[0]}.{sys.version_info[1]}"
                                                           / "lib-dynload").glob("*.so"))[:5]]
    for path in binaries:
        names = _section_names(path)
        assert ".symtab" not in names and ".dynsym" in names, path
