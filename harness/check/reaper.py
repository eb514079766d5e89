"""The process every FMU of ``spurdiff check`` runs under: a child subreaper that ends all it started.

``python -I -S reaper.py DONE-FILE PROGRAM ARGS...`` marks itself a child subreaper
(``prctl(PR_SET_CHILD_SUBREAPER)``, Linux 3.4+), starts PROGRAM (the check worker, or the bare C
host) as its child with its own environment, waits for it, then SIGKILLs every process below it and
reaps them until none is left; it writes DONE-FILE and leaves with the child's status (re-raising
its signal). Whatever a process below does (double fork, ``setsid``, a new process group, ``exec``
with an empty environment), an orphan is re-parented to the nearest living subreaper, this one, so
it stays findable through ``/proc/<pid>/task/<tid>/children``. The checker kills the same tree with
:func:`kill_tree` at a timeout (this process still alive, nothing can have escaped it).

Why a subreaper rather than a PID namespace or a cgroup: it needs no privilege and no kernel or
container policy (unprivileged user namespaces are refused by Docker's default seccomp profile and
by Ubuntu's AppArmor; a cgroup needs a delegated, writable cgroup v2 tree), and it follows every
process by ancestry, which an FMU cannot change. What it cannot survive is the FMU killing this
process itself: then DONE-FILE is missing and the checker says so (and sweeps what it still can).

Standard library only, nothing imported from the package: it runs with ``-I -S`` and, for the C
host, an empty environment.
"""
from __future__ import annotations

import os
import signal
import sys
import time

PR_SET_CHILD_SUBREAPER = 36


def children(pid: int) -> list[int]:
    """Direct children of ``pid`` (every thread's), [] when it is gone."""
    out: list[int] = []
    try:
        tids = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return out
    for tid in tids:
        try:
            with open(f"/proc/{pid}/task/{tid}/children") as f:
                out += [int(x) for x in f.read().split()]
        except (OSError, ValueError):
            pass
    return out


def descendants(pid: int) -> list[int]:
    """Every process below ``pid`` (breadth first)."""
    seen: list[int] = []
    queue = children(pid)
    while queue:
        p = queue.pop(0)
        if p in seen or p == pid:
            continue
        seen.append(p)
        queue += children(p)
    return seen


def _reap() -> None:
    while True:
        try:
            pid, _ = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return


def kill_tree(root: int, include_root: bool = False, limit_s: float = 10.0, reap: bool = False) -> int:
    """SIGKILL every process below ``root`` until none is left (stopped first, so none forks while
    the others die), then ``root`` itself if ``include_root``. The number of processes killed."""
    killed: set[int] = set()
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        below = descendants(root)
        if not below:
            break
        for sig in (signal.SIGSTOP, signal.SIGKILL):
            for p in below:
                try:
                    os.kill(p, sig)
                    killed.add(p)
                except OSError:
                    pass
        if reap:
            _reap()
        time.sleep(0.005)
    if include_root:
        try:
            os.kill(root, signal.SIGKILL)
        except OSError:
            pass
    return len(killed)


def main(argv: list[str]) -> None:
    done, program = argv[0], argv[1:]
    try:
        import resource
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))   # nothing below leaves a core file
    except Exception:
        pass
    try:
        import ctypes
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) != 0:
            raise OSError(ctypes.get_errno(), "prctl(PR_SET_CHILD_SUBREAPER) failed")
    except (OSError, AttributeError) as e:
        os.write(2, f"spurdiff check: cannot become a child subreaper: {e}\n".encode())
        os._exit(125)
    pid = os.fork()
    if pid == 0:
        try:
            os.execv(program[0], program)
        except OSError as e:
            os.write(2, f"spurdiff check: cannot start {program[0]}: {e}\n".encode())
        os._exit(127)
    signal.signal(signal.SIGTERM, lambda *_: (kill_tree(os.getpid(), reap=True), os._exit(143)))
    while True:
        try:
            _, status = os.waitpid(pid, 0)
            break
        except InterruptedError:
            continue
    n = kill_tree(os.getpid(), reap=True)
    _reap()
    fd = os.open(done, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | getattr(os, "O_NOFOLLOW", 0), 0o600)
    os.write(fd, f"{n}\n".encode())
    os.close(fd)
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        signal.signal(sig, signal.SIG_DFL)
        os.kill(os.getpid(), sig)
        time.sleep(1.0)
    os._exit(os.WEXITSTATUS(status) if os.WIFEXITED(status) else 1)


if __name__ == "__main__":
    main(sys.argv[1:])
