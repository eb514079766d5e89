"""numpy as one archive unpacked once per user (spurdiff.numpy_archive, harness/build/fmu.py: issue 44
item 1): the SpurDifferential FMU's Linux runtime carries numpy as resources/python/numpy.zip
(stored) with its SHA-256; a Python without numpy (the FMU's own, here a -S interpreter) imports
it from the user's cache, unpacked once, private (0700), verified, shared by a second process; a
planted, foreign or altered cache folder and an altered archive are refused with one line."""
from __future__ import annotations

import os
import subprocess
import sys
import time
import zipfile

import pytest

from spurdiff import numpy_archive as na

RUN = r"""
import os, sys
sys.path.insert(0, sys.argv[1] + '/spurdiff.zip')   # the FMU's package archive (zipimport)
assert not any('site-packages' in p for p in sys.path)
import spurdiff._fmu_entry                      # installs the finder
import numpy
print('NUMPY', numpy.__file__)
from spurdiff.fmi import differential_fmu
values = {v.name: v.start for v in differential_fmu.VARIABLES}
values['meshModel'] = 'contact'
m = differential_fmu.build_model(values)
m.do_step(0.0, 1e-3)
print('CONTACT STEPPED')
"""


@pytest.fixture(scope="module")
def resources(differential_fmu, tmp_path_factory):
    d = tmp_path_factory.mktemp("fmu")
    with zipfile.ZipFile(differential_fmu) as z:
        info = z.getinfo("resources/python/numpy.zip")
        assert info.compress_type == zipfile.ZIP_STORED
        assert not any(n.startswith("resources/python/lib/python3.11/site-packages/numpy") for n in z.namelist())
        z.extractall(d)
    return d / "resources"


def _run(resources, cache):
    return subprocess.run([sys.executable, "-S", "-c", RUN, str(resources)], capture_output=True, text=True,
                          timeout=300, env={"PATH": "/usr/bin:/bin", "XDG_CACHE_HOME": str(cache)})


def test_numpy_is_unpacked_once_into_a_private_cache_and_shared(resources, tmp_path):
    cache = tmp_path / "cache"
    r = _run(resources, cache)
    assert r.returncode == 0, r.stderr[-3000:]
    digest = (resources / "python" / "numpy.zip.sha256").read_text().split()[0]
    folder = cache / "spurdiff" / f"numpy-{digest[:16]}"
    assert f"NUMPY {folder}/numpy/__init__.py" in r.stdout and "CONTACT STEPPED" in r.stdout, r.stdout
    assert (os.stat(folder).st_mode & 0o777) == 0o700 and (os.stat(cache / "spurdiff").st_mode & 0o777) == 0o700
    before = os.stat(folder).st_mtime_ns
    r2 = _run(resources, cache)                  # a second process: the same folder, not unpacked again
    assert r2.returncode == 0 and f"NUMPY {folder}/numpy/__init__.py" in r2.stdout, r2.stderr[-2000:]
    assert os.stat(folder).st_mtime_ns == before
    assert not [p for p in (cache / "spurdiff").iterdir() if p.name.startswith(".numpy-")]   # no leftovers


def test_planted_foreign_and_altered_caches_are_refused(resources, tmp_path):
    archive = resources / "python" / "numpy.zip"
    digest = (resources / "python" / "numpy.zip.sha256").read_text().split()[0]
    root = tmp_path / "c"
    root.mkdir(mode=0o700)
    target = root / f"numpy-{digest[:16]}"
    target.mkdir(mode=0o777)
    os.chmod(target, 0o777)                      # world-writable: planted or careless
    with pytest.raises(OSError, match="0700 expected"):
        na.unpacked(archive, digest, root)
    os.chmod(target, 0o700)
    with pytest.raises(OSError, match="does not hold this numpy"):   # no marker
        na.unpacked(archive, digest, root)
    (target / na.MARKER).write_text("0" * 64)
    with pytest.raises(OSError, match="does not hold this numpy"):
        na.unpacked(archive, digest, root)
    (target / na.MARKER).unlink()
    target.rmdir()
    target.symlink_to(tmp_path)                  # a link planted in its place
    with pytest.raises(OSError, match="not a folder"):
        na.unpacked(archive, digest, root)
    target.unlink()
    if os.getuid() == 0:                         # a folder of another user
        target.mkdir(mode=0o700)
        os.chown(target, 65534, 65534)
        with pytest.raises(OSError, match="belongs to uid 65534"):
            na.unpacked(archive, digest, root)
        os.rmdir(target)
    with pytest.raises(OSError, match="is not the"):        # an altered archive
        na.unpacked(archive, "f" * 64, root)
    shared = tmp_path / "shared"                 # a folder above that others may write: refused
    shared.mkdir()
    shared.chmod(0o777)
    try:
        with pytest.raises(OSError, match=f"the folder above it, {shared}, is writable by others"):
            na.unpacked(archive, digest, shared / "mine")
    finally:
        shared.chmod(0o700)
    assert na.unpacked(archive, digest, root) == target      # and the real one unpacks


def test_an_unsafe_user_cache_falls_back_to_the_private_temporary_folder(resources, tmp_path, monkeypatch):
    """The user cache under a folder others may write (a HOME of mode 777, as a host run as nobody may
    have): $TMPDIR/spurdiff-<uid> instead, as the loader's runtime folder; both refused: one line naming both."""
    archive = resources / "python" / "numpy.zip"
    digest = (resources / "python" / "numpy.zip.sha256").read_text().split()[0]
    home = tmp_path / "home"
    home.mkdir()
    home.chmod(0o777)
    (tmp_path / "tmp").mkdir()
    monkeypatch.setenv("XDG_CACHE_HOME", str(home / ".cache"))
    monkeypatch.setenv("TMPDIR", str(tmp_path / "tmp"))
    try:
        target = na.unpacked(archive, digest)
        assert target.parent == tmp_path / "tmp" / f"spurdiff-{os.getuid()}" and (target / "numpy").is_dir()
        target.parent.chmod(0o755)
        with pytest.raises(OSError, match=r"writable by others .*; .* has mode 755"):
            na.unpacked(archive, digest)
    finally:
        home.chmod(0o700)


def test_another_numpys_folder_unused_for_30_days_goes_at_the_next_unpack(resources, tmp_path):
    archive = resources / "python" / "numpy.zip"
    digest = (resources / "python" / "numpy.zip.sha256").read_text().split()[0]
    root = tmp_path / "c"
    root.mkdir(mode=0o700)
    folders = {}
    for days in (40, 10):
        d = root / f"numpy-{days:016x}"
        d.mkdir(mode=0o700)
        (d / na.MARKER).write_text(f"{days:064x}")
        os.utime(d / na.MARKER, (time.time() - days * 86400,) * 2)
        folders[days] = d
    (root / "numpy-not-ours").mkdir()
    target = na.unpacked(archive, digest, root)
    assert not folders[40].exists() and folders[10].is_dir() and (root / "numpy-not-ours").is_dir()
    os.utime(target / na.MARKER, (1e9, 1e9))
    assert na.unpacked(archive, digest, root) == target and (target / na.MARKER).stat().st_mtime > 1e9 + 1


LAZY = r"""
import sys
sys.path.insert(0, sys.argv[1] + '/spurdiff.zip')   # the FMU's package archive (zipimport)
import spurdiff._fmu_entry                      # the finder installed, numpy not wanted
print('LOADED', sorted(m for m in ('zipfile', 'tempfile', 'shutil', 'importlib.abc', 'importlib.resources', 'lzma',
                                   'bz2', 'numpy') if m in sys.modules))
"""


def test_the_finder_costs_the_start_up_no_unpacking_machinery(resources, tmp_path):
    """At every FMU start the entry installs the finder: without numpy wanted, nothing of the
    unpacking (zipfile, tempfile, shutil, the importlib ABCs) is imported (issue 44 item 2)."""
    r = subprocess.run([sys.executable, "-I", "-S", "-c", LAZY, str(resources)], capture_output=True, text=True,
                       timeout=120, env={"PATH": "/usr/bin:/bin", "XDG_CACHE_HOME": str(tmp_path)})
    assert r.returncode == 0, r.stderr[-3000:]
    assert "LOADED []" in r.stdout, r.stdout
    assert not (tmp_path / "spurdiff").exists()      # nothing unpacked
