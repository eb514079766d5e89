"""The win64 runtime's numpy as one archive (issue 44 item 1; spurdiff.numpy_archive): the FMU carries
resources/python-win64/numpy.zip (stored) and its SHA-256 instead of some 200 numpy files; under
wine, a Windows CPython of the runtime's 3.X that has no numpy on its path imports the FMU's
package from a folder with a space and a non-ASCII character, runs the contact mesh level (which
imports numpy) and gets numpy from %LOCALAPPDATA%\\spurdiff\\numpy-<digest>, unpacked once: a second
process uses the same folder without unpacking it again.

Skipped with the reason where wine or mingw-w64 is missing or the FMU has no win64 side (the
fixtures are tests/harness/test_win64.py's)."""
from __future__ import annotations

import shutil
import sys
import zipfile
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_numpy_archive import RUN as LINUX_RUN  # noqa: E402
from test_win64 import MINGW, ODD, _run, _wine_path, wine, windows_python  # noqa: E402,F401 (fixtures)

pytestmark = [
    pytest.mark.skipif(shutil.which("wine") is None, reason="wine is not installed (Debian: apt-get install wine64)"),
    pytest.mark.skipif(shutil.which(MINGW) is None,
                       reason=f"{MINGW} is not installed (Debian: apt-get install gcc-mingw-w64-x86-64)"),
]

# the Linux test's run (tests/harness/test_numpy_archive.py: install the finder, import numpy, step the
# contact level), after pointing %LOCALAPPDATA% at this test's folder and hiding this Python's own numpy
RUN = ("import os, sys\n"
       "os.environ['LOCALAPPDATA'] = sys.argv[2]\n"
       "sys.path[:] = [p for p in sys.path if 'site-packages' not in p]\n" + LINUX_RUN)


def test_the_win64_numpy_archive_is_unpacked_once_into_localappdata(wine, windows_python, differential_fmu, tmp_path):
    env, prefix = wine
    with zipfile.ZipFile(differential_fmu) as z:
        names = z.namelist()
        if "binaries/win64/SpurDifferential.dll" not in names:
            pytest.skip("SpurDifferential.fmu has no binaries/win64 (built where mingw-w64 was missing)")
        assert z.getinfo("resources/python-win64/numpy.zip").compress_type == zipfile.ZIP_STORED
        assert not any(n.startswith("resources/python-win64/Lib/site-packages/numpy") for n in names)
        with zipfile.ZipFile(z.open("resources/python-win64/numpy.zip")) as inner:   # no MSVC import library
            assert not [n for n in inner.namelist() if n.endswith(".lib")]
        folder = prefix / "drive_c" / f"{ODD} numpy"
        shutil.rmtree(folder, ignore_errors=True)
        z.extractall(folder)
    try:
        script = tmp_path / "run.py"
        script.write_text(RUN)
        cache = tmp_path / "local app data"
        cache.mkdir()
        digest = (folder / "resources" / "python-win64" / "numpy.zip.sha256").read_text().split()[0]
        unpacked = cache / "spurdiff" / f"numpy-{digest[:16]}"
        cmd = ["wine", str(windows_python), "-I", _wine_path(script),
               "C:\\" + ODD + " numpy\\resources", _wine_path(cache)]
        r = _run(cmd, env=env)
        assert r.returncode == 0 and "CONTACT STEPPED" in r.stdout, r.stdout[-3000:]
        line = next(ln for ln in r.stdout.splitlines() if ln.startswith("NUMPY "))
        assert f"spurdiff\\numpy-{digest[:16]}\\numpy\\__init__.py" in line, line
        assert (unpacked / "numpy" / "__init__.pyc").is_file()                # sourceless
        before = unpacked.stat().st_mtime_ns
        r2 = _run(cmd, env=env)                 # a second process: the same folder, not unpacked again
        assert r2.returncode == 0 and "CONTACT STEPPED" in r2.stdout, r2.stdout[-3000:]
        assert unpacked.stat().st_mtime_ns == before
        assert not [p for p in (cache / "spurdiff").iterdir() if p.name.startswith(".numpy-")]   # no leftovers
    finally:
        shutil.rmtree(folder, ignore_errors=True)
