"""The process-wide FMU cache (harness/fmi/instance.py: FmuCache) of a process killed before its exit
handler ran is removed by the next process that makes one: only real folders of this user whose
process no longer runs."""
from __future__ import annotations

import os
import subprocess
import sys

from harness.fmi.instance import CACHE_PREFIX, FmuCache, remove_stale_caches


def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_only_the_caches_of_dead_processes_go(tmp_path):
    dead, live = _dead_pid(), os.getpid()
    stale = tmp_path / f"{CACHE_PREFIX}{dead}_abc"
    (stale / "SpurDifferential_0" / "resources").mkdir(parents=True)
    mine = tmp_path / f"{CACHE_PREFIX}{live}_xyz"
    mine.mkdir()
    odd = tmp_path / f"{CACHE_PREFIX}notapid_q"
    odd.mkdir()
    target = tmp_path / "elsewhere"
    (target / "keep").mkdir(parents=True)
    link = tmp_path / f"{CACHE_PREFIX}{dead}_link"
    link.symlink_to(target, target_is_directory=True)
    plain = tmp_path / f"{CACHE_PREFIX}{dead}_file"
    plain.write_text("not a folder")
    assert remove_stale_caches(tmp_path) == [stale]
    assert not stale.exists()
    assert mine.is_dir() and odd.is_dir() and link.is_symlink() and (target / "keep").is_dir() and plain.is_file()


def test_a_new_cache_is_named_by_its_process_and_sweeps_the_stale_ones(tmp_path, monkeypatch):
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    stale = tmp_path / f"{CACHE_PREFIX}{_dead_pid()}_old"
    stale.mkdir()
    cache = FmuCache()
    try:
        assert not stale.exists()
        assert cache._tmp.parent == tmp_path and cache._tmp.name.startswith(f"{CACHE_PREFIX}{os.getpid()}_")
    finally:
        cache.cleanup()
