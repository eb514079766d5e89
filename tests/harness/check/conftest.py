"""Every test of the compliance kit, on every test FMU (the broken, hostile and reference corpus),
ends with no process left behind (issue 45 item 3): the test process is made a child subreaper, so
a process an FMU started that escaped the kit's reaper is re-parented here instead of to init, and a
test after which one is found fails, naming it (it is killed)."""
from __future__ import annotations

import ctypes
import os
import signal
import time
from pathlib import Path

import pytest

from harness.check.processes.reaper import PR_SET_CHILD_SUBREAPER, children


def _live_children() -> dict[int, str]:
    out = {}
    for pid in children(os.getpid()):
        try:
            stat = Path(f"/proc/{pid}/stat").read_text()
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace").strip()
        except OSError:
            continue
        if stat.rsplit(")", 1)[1].split()[0] != "Z":
            out[pid] = cmd[:160]
    return out


@pytest.fixture(scope="session")
def _subreaper():
    if not Path("/proc/self/task").is_dir():
        return False
    try:
        return ctypes.CDLL(None, use_errno=True).prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


@pytest.fixture(autouse=True)
def _no_process_left(_subreaper):
    before = set(_live_children()) if _subreaper else set()
    yield
    if not _subreaper:
        return
    left = {}
    for _ in range(30):   # a process killed at the end of the test may take a moment to go
        left = {p: c for p, c in _live_children().items() if p not in before}
        if not left:
            break
        time.sleep(0.1)
    for pid in left:   # killed and reaped (they were re-parented here)
        try:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
        except OSError:
            pass
    assert not left, f"{len(left)} process(es) outlived the test: {left}"
