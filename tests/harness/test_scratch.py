"""Scratch folders of processes (harness/common/scratch.py, the FMU cache of harness/fmi/instance.py):
a killed process's folder is removed by the next process that makes one; a live one's never, nor
anything that is not such a folder of this user."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from harness.common import scratch
from harness.fmi.instance import FmuCache

pytestmark = pytest.mark.skipif(scratch.fcntl is None, reason="no fcntl (Windows): no lock, no sweep")

CHILD = textwrap.dedent("""
    import os, sys, time
    from harness.common import scratch
    from harness.fmi.instance import fmu_cache
    if sys.argv[2] == "fmus":
        c = fmu_cache()
        folder = c._tmp
    else:
        folder = scratch.process_folder(sys.argv[2]).path
    (folder / "extracted.bin").write_bytes(b"x" * 1000)
    kid = os.fork() if sys.argv[1] == "fork" else -1
    if kid == 0:
        time.sleep(60)
        os._exit(0)
    print(folder, kid, flush=True)
    time.sleep(60)
""")


def _child(tmp_path, mode="plain", prefix="fmus"):
    env = {**os.environ, "TMPDIR": str(tmp_path)}
    p = subprocess.Popen([sys.executable, "-c", CHILD, mode, prefix], stdout=subprocess.PIPE, text=True, env=env)
    folder, kid = p.stdout.readline().split()
    return p, Path(folder), int(kid)


def test_a_killed_processs_cache_is_removed_by_the_next_one(tmp_path):
    p, folder, _ = _child(tmp_path)
    try:
        assert (folder / "extracted.bin").is_file() and folder.parent == tmp_path
        FmuCache(tmp_path).cleanup()               # while it lives: kept
        assert (folder / "extracted.bin").is_file()
    finally:
        p.send_signal(signal.SIGKILL)
        p.wait()
    assert folder.is_dir()                          # no exit handler ran
    mine = FmuCache(tmp_path)
    try:
        assert not folder.exists()
        assert mine._tmp.is_dir()
    finally:
        mine.cleanup()
    assert list(tmp_path.iterdir()) == []


def test_a_forked_child_keeps_the_folder_alive(tmp_path):
    p, folder, kid = _child(tmp_path, "fork")
    p.send_signal(signal.SIGKILL)
    p.wait()
    assert scratch.sweep(FmuCache.PREFIX, tmp_path) == []      # the forked child holds the lock
    assert (folder / "extracted.bin").is_file()
    os.kill(kid, signal.SIGKILL)                    # not our child: gone once init reaps it
    for _ in range(200):
        if scratch.sweep(FmuCache.PREFIX, tmp_path):
            break
        time.sleep(0.05)
    assert not folder.exists()


def test_only_this_users_unlocked_real_folders_are_removed(tmp_path):
    prefix = "spurdiff_test_"
    bare = tmp_path / f"{prefix}bare"               # no lock file: being made, or an older layout
    bare.mkdir()
    target = tmp_path / "elsewhere"
    target.mkdir()
    (target / scratch.LOCK).write_text("")
    (tmp_path / f"{prefix}link").symlink_to(target)  # a link to an unlocked folder
    linked_lock = tmp_path / f"{prefix}linked_lock"
    linked_lock.mkdir()
    (linked_lock / scratch.LOCK).symlink_to(target / scratch.LOCK)
    fifo = tmp_path / f"{prefix}fifo"
    fifo.mkdir()
    os.mkfifo(fifo / scratch.LOCK)
    dead = tmp_path / f"{prefix}dead"
    dead.mkdir()
    (dead / scratch.LOCK).write_text("")
    other = None
    if os.geteuid() == 0:                            # a folder of another user, as root can make it
        other = tmp_path / f"{prefix}other"
        other.mkdir()
        (other / scratch.LOCK).write_text("")
        os.chown(other, 65534, 65534)
    assert scratch.sweep(prefix, tmp_path) == [dead]
    assert bare.is_dir() and target.is_dir() and (target / scratch.LOCK).exists()
    assert linked_lock.is_dir() and fifo.is_dir()
    assert other is None or other.is_dir()


def test_a_made_folder_is_private_and_locked(tmp_path):
    s = scratch.make("spurdiff_test_", tmp_path)
    try:
        assert (s.path.stat().st_mode & 0o777) == 0o700
        assert [p.name for p in s.path.iterdir()] == [scratch.LOCK]
        assert scratch.sweep("spurdiff_test_", tmp_path) == []
    finally:
        s.remove()
    assert not s.path.exists()


def test_the_builds_scratch_folders_are_swept_too(tmp_path):
    """The build's compiled binaries and staged package (harness/build/fmu.py) live in process
    folders of the same kind: a killed build's are removed by the next build's."""
    import harness.build.fmu as build

    src = Path(build.__file__).read_text()
    for prefix in ("spurdiff_native_", "spurdiff_package_"):
        assert f'scratch.process_folder("{prefix}")' in src
        p, folder, _ = _child(tmp_path, prefix=prefix)
        p.send_signal(signal.SIGKILL)
        p.wait()
        assert folder.is_dir()
        mine = scratch.process_folder(prefix, tmp_path)
        assert not folder.exists() and mine.path.is_dir()
        mine.remove()
