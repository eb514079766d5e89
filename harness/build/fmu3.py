"""Build the FMI 3.0 co-simulation FMUs beside the FMI 2.0 ones: ``build/fmus/<name>-fmi3.fmu``.

One declaration, two FMUs: the FMI 3.0 FMU of ``name`` is made from its FMI 2.0 FMU
(:mod:`harness.build.fmu`, built first when it is not current) and holds the same model: the same
package copy ``resources/spurdiff/``, the same Python runtime ``resources/python/`` and its
description ``resources/python_runtime.cfg`` (the GUID is the instantiation token), the same
bridge and server. What differs:

* ``modelDescription.xml`` is FMI 3.0, written from the same variable list
  (:func:`harness.build.modeldescription3.fmi3_description`);
* the binaries sit in ``binaries/x86_64-linux/`` and the model's binary is the FMI 3.0 loader:
  ``fmu_src/native/fmi/fmi3_loader.c`` linked with the FMI 2.0 loader it maps every call onto
  (:data:`LOADER3_SOURCES`), so the model runs in this process or its own exactly as in the FMI 2.0
  FMU, with the same refusals;
* the Windows side, where the FMI 2.0 FMU has one (mingw-w64 installed, :mod:`harness.build.runtime_win64`):
  ``binaries/x86_64-windows/`` holds the FMI 2.0 FMU's ``binaries/win64/`` files with the model's
  DLL replaced by the FMI 3.0 loader cross-built from the same sources (``loader3.dll`` of the win64
  runtime), beside the same ``resources/python-win64/`` runtime and its description. Without it
  (:data:`WIN64_ONLY` left out) the FMI 3.0 FMU is linux64-only, as its FMI 2.0 twin.

The archive starts from the runtime's compressed entries (as the FMI 2.0 build does), so making
an FMI 3.0 FMU costs about a second. A build is skipped when its stamp (the FMI 2.0 FMU's source
digest, this module's, and the SHA-256 of the very FMI 2.0 FMU it was made from) is current: a
rebuilt FMI 2.0 FMU (a new GUID) makes its FMI 3.0 twin stale, whatever the sources.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
import atexit
import zipfile
from pathlib import Path

from harness.build import fmu as build2
from harness.build import fmu_checksum
from harness.common import progress
from harness.build import modeldescription3
from harness.build.modeldescription3 import PLATFORM, fmi3_description
from harness.common.paths import fmu_cache_dir

SUFFIX = "-fmi3"
LOADER3_SOURCES: tuple = ("fmi3_loader.c", *build2.LOADER_SOURCES)
FMI_VERSIONS = (2, 3)


# the FMI 2.0 FMU's Windows side: under binaries/x86_64-windows/ with the FMI 3.0 loader as the model's DLL
WIN64_ONLY = ("binaries/win64/", "resources/python-win64/", "resources/python_runtime_win64.cfg",
              "resources/runtime/win64.zip")
WINDOWS_PLATFORM = "x86_64-windows"     # the FMI 3.0 platform tuple of 64-bit Windows


def fmu_path(name: str, dest: Path | None = None) -> Path:
    return Path(dest or fmu_cache_dir()) / f"{name}{SUFFIX}.fmu"


def source_digest(name: str, made_from: str) -> str:
    """The stamp of the FMI 3.0 FMU of ``name``: the FMI 2.0 FMU's source digest, this module's and
    modeldescription3's code, and ``made_from``, the SHA-256 of the FMI 2.0 FMU it is made from (its
    GUID is drawn anew at each FMI 2.0 build, so the sources alone do not say the pair agrees)."""
    h = hashlib.sha256(build2.source_digest(name).encode())
    for p in (Path(__file__), Path(modeldescription3.__file__)):
        h.update(p.read_bytes())
    h.update(made_from.encode())
    return h.hexdigest()


def is_current(name: str, dest: Path | None = None) -> bool:
    """The FMI 3.0 FMU of ``name`` is current: its FMI 2.0 FMU is, and it was made from that very file."""
    return build2.is_current(name, dest) and fmu_checksum.is_current(
        fmu_path(name, dest), source_digest(name, fmu_checksum.file_sha256(build2.fmu_path(name, dest))))


_LOADER3: dict[str, Path] = {}


def compile_loader3() -> Path:
    """The FMI 3.0 loader (``-Wl,-Bsymbolic``: its calls into the FMI 2.0 loader stay inside the
    binary, whatever other FMU the host loaded globally), compiled once per process and sources."""
    h = hashlib.sha256(repr((LOADER3_SOURCES, os.environ.get("CC"))).encode())
    for p in sorted(build2.NATIVE_FMI.glob("*.[ch]")):
        h.update(p.name.encode() + b"\0" + p.read_bytes())
    key = h.hexdigest()
    if key not in _LOADER3:
        tmp = Path(tempfile.mkdtemp(prefix="spurdiff_native3_"))
        atexit.register(shutil.rmtree, tmp, True)
        out = tmp / "loader3.so"
        cmd = [build2.c_compiler(), "-shared", "-fPIC", "-O2", "-Wall", "-Werror=implicit-function-declaration",
               f"-I{build2._fmi2_headers()}", f"-I{build2.NATIVE_FMI}", *build2._prefix_map(),
               *(str(build2.NATIVE_FMI / f) for f in LOADER3_SOURCES), "-o", str(out), "-ldl", "-lpthread",
               "-Wl,-Bsymbolic"]
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            raise build2.BuildError(f"compiling {', '.join(LOADER3_SOURCES)} failed:\n{r.stderr.strip()}")
        _LOADER3[key] = out
    return _LOADER3[key]


def build_one(name: str, dest: Path | None = None, quiet: bool = False) -> Path:
    """The FMI 3.0 FMU of ``name`` from its FMI 2.0 FMU in ``dest`` (which must be current)."""
    dest = Path(dest) if dest else fmu_cache_dir()
    # one file read, whatever another build renames over its path meanwhile; the stamp taken first
    # (sources changed during the build leave the FMU stale)
    with open(build2.fmu_path(name, dest), "rb") as f, zipfile.ZipFile(f) as fmu2:
        stamp = source_digest(name, fmu_checksum.stream_sha256(f))
        out = _make(name, dest, fmu2)
    fmu_checksum.write(out, stamp)   # <name>.sha256: the FMU's own digest
    if not quiet:
        print(f"built {out} (FMI 3.0, from {build2.fmu_path(name, dest).name})")
    return out


def _make(name: str, dest: Path, zin: zipfile.ZipFile) -> Path:
    """The FMI 3.0 FMU of ``name`` in ``dest`` from ``zin``, its FMI 2.0 FMU."""
    from harness.build import runtime_bundle

    iface = build2.interface(name)
    loader = compile_loader3()
    runtime = runtime_bundle.ensure_runtime(build2.declarations(), quiet=True)
    names = zin.namelist()
    if "resources/" + build2.RUNTIME_CFG not in names:
        raise build2.BuildError(f"{name}: {name}.fmu carries no runtime (built without a C compiler?); "
                                "an FMI 3.0 FMU needs the native loader")
    has_win64 = f"binaries/win64/{name}.dll" in names
    win64 = build2._win64_parts() if has_win64 else None    # None: linux64 only, as the FMI 2.0 FMU
    if has_win64 and win64 is None:     # the pair would disagree on its platforms
        why = (build2._WIN64.get("why") if "win64" in build2.platforms()
               else f"platforms {','.join(build2.platforms())}")
        raise build2.BuildError(f"{name}: {name}.fmu carries win64 binaries, which this build does not make ({why}); "
                                f"build again (with --force if {name}.fmu is current)")
    start = build2._base_archive(runtime, win64)            # the runtimes' entries, compressed once
    out = fmu_path(name, dest)
    part = dest / f".{name}{SUFFIX}.{os.getpid()}.fmu"
    try:
        with zipfile.ZipFile(start) as z:
            in_runtime = set(z.namelist())
        shutil.copyfile(start, part)
        with zipfile.ZipFile(part, "a", zipfile.ZIP_DEFLATED) as zout:
            for item in zin.infolist():
                if item.filename in in_runtime or (win64 is None and item.filename.startswith(WIN64_ONLY)):
                    continue
                data = zin.read(item.filename)
                target = item.filename
                if item.filename == "modelDescription.xml":
                    data = fmi3_description(data.decode("utf-8"), iface.VARIABLES, iface.DEFAULT_EXPERIMENT,
                                            getattr(iface, "MAX_OUTPUT_DERIVATIVE_ORDER", 0),
                                            getattr(iface, "MIGHT_RETURN_EARLY", False)).encode("utf-8")
                elif item.filename.startswith("binaries/linux64/"):
                    base = item.filename.rsplit("/", 1)[1]
                    target = f"binaries/{PLATFORM}/{base}"
                    if base == f"{name}.so":
                        data = loader.read_bytes()
                elif item.filename.startswith("binaries/win64/"):
                    base = item.filename.rsplit("/", 1)[1]
                    target = f"binaries/{WINDOWS_PLATFORM}/{base}"
                    if base == f"{name}.dll":
                        data = win64.loader3.read_bytes()
                info = zipfile.ZipInfo(target, date_time=item.date_time)
                info.external_attr = item.external_attr
                info.compress_type = item.compress_type   # as in the FMI 2.0 FMU
                zout.writestr(info, data)
        os.replace(part, out)
    finally:
        part.unlink(missing_ok=True)
    return out


def build(names: list[str] | None = None, dest: Path | None = None, force: bool = False,
          quiet: bool = False, force2: bool | None = None) -> list[Path]:
    """Build the FMI 3.0 FMUs of ``names`` (default: all), their FMI 2.0 FMUs first when needed
    (rebuilt too with ``force`` unless ``force2`` is False)."""
    dest = Path(dest) if dest else fmu_cache_dir()
    names = names or list(build2.FMUS)
    for n in names:
        if n not in build2.FMUS:
            raise build2.BuildError(f"unknown FMU {n!r}: allowed {', '.join(build2.FMUS)}")
    build2.build(names, dest, force=force if force2 is None else force2, quiet=True)
    paths = []
    for name in names:
        def make(name=name):
            with progress.stage(f"building {name}{SUFFIX}.fmu (FMI 3.0)", expected=15):
                return build_one(name, dest, quiet=quiet)
        paths.append(build2.build_locked(dest / f".{name}{SUFFIX}.lock", fmu_path(name, dest),
                                         lambda: not force and is_current(name, dest), make, quiet))
    return paths


def build_versions(names: list[str] | None, dest: Path | None = None, force: bool = False, quiet: bool = False,
                   versions: tuple[int, ...] = FMI_VERSIONS) -> list[Path]:
    """The FMUs of ``names`` for each FMI version in ``versions`` (2, 3), the 2.0 ones first."""
    bad = [v for v in versions if v not in FMI_VERSIONS]
    if bad:
        raise build2.BuildError(f"FMI version {bad[0]}: allowed 2 or 3")
    paths = []
    if 2 in versions:
        paths += build2.build(names, dest, force=force, quiet=quiet)
    if 3 in versions:
        paths += build(names, dest, force=force, quiet=quiet, force2=False if 2 in versions else None)
    return paths
