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


def _settle(tag: str) -> list[int]:
    for _ in range(40):   # SIGKILL is asynchronous: give the kernel a moment
        left = alive(tag)
        if not left:
            return []
        time.sleep(0.1)
    return left


def _check(tmp_path, cases: str) -> tuple[int, list[int], str]:
    """``spurdiff check`` (cs.basic, load.bare-process) on the daemon FMU: (exit code, survivors,
    what it printed)."""
    import contextlib
    import io
    import random

    from harness.cli import main
    tag = f"{random.randrange(10 ** 6):06d}"
    pids = tmp_path / "pids"
    pids.mkdir()
    fmu = daemon_fmu(tmp_path, pids, cases, tag)
    out = io.StringIO()
    try:
        with contextlib.redirect_stdout(out):
            rc = main(["check", str(fmu), "--select", "cs.basic,load.bare-process", "--timeout", "30"])
        assert list(pids.iterdir()), "the hostile FMU started no daemon: the test would prove nothing"
        return rc, _settle(tag), out.getvalue()
    finally:
        for pid in alive(tag):
            os.kill(pid, signal.SIGKILL)


@needs_gcc
@linux
@pytest.mark.parametrize("layer", ["namespace", "subreaper"])
@pytest.mark.parametrize("cases", ["1", "2", "3", "4", "1234"])
def test_no_daemon_outlives_check(tmp_path, monkeypatch, cases, layer):
    """Both layers of the reaper, each on its own (the namespace where the kernel allows it)."""
    if layer == "subreaper":
        monkeypatch.setenv("SPURDIFF_CHECK_PID_NAMESPACE", "0")
    rc, left, said = _check(tmp_path, cases)
    assert rc == 0, said
    assert left == [], f"{len(left)} daemons outlived spurdiff check"


@needs_gcc
@linux
def test_an_fmu_that_kills_the_reaper_is_contained_or_reported(tmp_path, monkeypatch):
    """Case 5: SIGKILL to its parent, then a daemon. In a PID namespace the parent is the namespace's
    first process, which ignores it: nothing is left and the rules pass. With the subreaper alone the
    reaper dies: the rules fail saying so (the daemon may survive: that layer's known limit)."""
    rc, left, said = _check(tmp_path, "5")
    if _namespaces_allowed():
        assert rc == 0 and left == [], said
    monkeypatch.setenv("SPURDIFF_CHECK_PID_NAMESPACE", "0")
    again = tmp_path / "again"
    again.mkdir()
    rc, left, said = _check(again, "5")
    assert rc == 1 and said.count("the kit's process reaper was killed") == 2, said


def _namespaces_allowed() -> bool:
    import subprocess
    import sys

    from harness.check.processes.isolation import REAPER
    probe = ("import ctypes, sys; sys.path.insert(0, sys.argv[1]); import reaper; "
             "sys.exit(0 if reaper._pid_namespace(ctypes.CDLL(None, use_errno=True)) else 1)")
    return subprocess.run([sys.executable, "-I", "-S", "-c", probe, str(REAPER.parent)]).returncode == 0


@linux
@pytest.mark.parametrize("flag", [[], ["--no-pid-namespace"]])
def test_reaper_ends_an_escaped_tree_and_keeps_the_status(tmp_path, flag):
    """The reaper on its own (either layer): a shell that starts a sleep in a new session with an
    empty environment, then exits 3: the reaper leaves with 3, the sleep is gone, the done file
    written."""
    import random
    import subprocess
    import sys

    from harness.check.processes.isolation import REAPER
    tag = f"{random.randrange(10 ** 6):06d}"
    started = tmp_path / "started"
    script = f"setsid sh -c 'touch {started}; exec env -i sleep 299.{tag}' & " \
             f"while [ ! -e {started} ]; do sleep 0.01; done; sleep 0.2; exit 3"
    done = tmp_path / "done"
    try:
        rc = subprocess.run([sys.executable, "-I", "-S", str(REAPER), *flag, str(done), "/bin/sh", "-c", script],
                            timeout=60).returncode
        assert rc == 3 and done.exists() and started.exists()
        assert _settle(tag) == []
    finally:
        for pid in alive(tag):
            os.kill(pid, signal.SIGKILL)


@linux
def test_reaper_reraises_the_signal_of_its_child(tmp_path):
    import subprocess

    from harness.check.processes.isolation import reaped
    cmd, done = reaped(["/bin/sh", "-c", "kill -SEGV $$"], tmp_path)
    assert subprocess.run(cmd, timeout=60).returncode == -signal.SIGSEGV
    assert done.exists()


@linux
def test_a_killed_reaper_ends_its_namespace(tmp_path):
    """SIGKILL to the reaper alone (the checker's group kill, an OOM kill): the namespace's first
    process dies with it (PR_SET_PDEATHSIG), and the kernel ends every process in the namespace."""
    import random
    import subprocess
    import sys

    from harness.check.processes.isolation import REAPER
    if not _namespaces_allowed():
        pytest.skip("no PID namespace allowed here")
    tag = f"{random.randrange(10 ** 6):06d}"
    started = tmp_path / "started"
    proc = subprocess.Popen([sys.executable, "-I", "-S", str(REAPER), str(tmp_path / "done"), "/bin/sh", "-c",
                             f"setsid sh -c 'touch {started}; exec env -i sleep 299.{tag}' & sleep 300"])
    try:
        for _ in range(300):
            if started.exists() and alive(tag):
                break
            time.sleep(0.05)
        assert alive(tag), "the sleep never started"
        proc.kill()
        proc.wait()
        assert _settle(tag) == []
    finally:
        proc.kill()
        for pid in alive(tag):
            os.kill(pid, signal.SIGKILL)
