"""Issue 45 item 3: nothing an FMU starts outlives ``spurdiff check``, whatever it does to its session,
process group or environment (tests/broken_fmus/chk_daemons.c: double fork and setsid, a new
process group, a daemon that is itself a subreaper, a spawner; each execs ``sleep`` with an empty
environment, so the run's environment marker is gone). The daemons start when the binary is loaded,
so they start both in the kit's Python worker (cs.basic) and in the bare C host (load.bare-process).
"""
from __future__ import annotations

import os
import shutil
import signal
import time
from pathlib import Path

import pytest

from daemon_fmu import alive, daemon_fmu

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler (gcc) to build the FMU")
linux = pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="Linux /proc needed")


def _settle(pid_dir: Path) -> list[int]:
    for _ in range(40):   # SIGKILL is asynchronous: give the kernel a moment
        left = alive(pid_dir)
        if not left:
            return []
        time.sleep(0.1)
    return left


@needs_gcc
@linux
@pytest.mark.parametrize("cases", ["1", "2", "3", "4", "1234"])
def test_no_daemon_outlives_check(tmp_path, cases):
    from harness.cli import main
    pids = tmp_path / "pids"
    pids.mkdir()
    fmu = daemon_fmu(tmp_path, pids, cases)
    try:
        assert main(["check", str(fmu), "--select", "cs.basic,load.bare-process", "--timeout", "30"]) == 0
        started = list(pids.iterdir())
        assert started, "the hostile FMU started no daemon: the test would prove nothing"
        left = _settle(pids)
        assert left == [], f"{len(left)} of {len(started)} daemons outlived spurdiff check"
    finally:
        for pid in alive(pids):
            os.kill(pid, signal.SIGKILL)


@linux
def test_reaper_ends_an_escaped_tree_and_keeps_the_status(tmp_path):
    """The subreaper on its own: a shell that double-forks and setsid's a sleep with an empty
    environment, then exits 3: the reaper leaves with 3, the sleep is gone, the done file written."""
    import subprocess
    import sys

    from harness.check.isolation import reaped
    pid_file = tmp_path / "pid"
    script = (f"setsid sh -c 'echo $$ > {pid_file}; exec env -i sleep 300' & "
              f"while [ ! -s {pid_file} ]; do sleep 0.01; done; exit 3")
    cmd, done = reaped(["/bin/sh", "-c", script], tmp_path)
    rc = subprocess.run(cmd, timeout=60).returncode
    assert rc == 3 and done.exists()
    pid = int(pid_file.read_text())
    assert not Path(f"/proc/{pid}").exists() or \
        Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"


@linux
def test_reaper_reraises_the_signal_of_its_child(tmp_path):
    import subprocess

    from harness.check.isolation import reaped
    cmd, done = reaped(["/bin/sh", "-c", "kill -SEGV $$"], tmp_path)
    assert subprocess.run(cmd, timeout=60).returncode == -signal.SIGSEGV
    assert done.exists()
