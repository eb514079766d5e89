"""The process every FMU of ``spurdiff check`` runs under: it ends everything the FMU started.

``python -I -S reaper.py [--no-pid-namespace] DONE-FILE PROGRAM ARGS...`` starts PROGRAM (the check
worker, or the bare C host) with its own environment, waits for it, makes sure that no process it
started is left, writes DONE-FILE and leaves with PROGRAM's status (re-raising its signal). Two
layers, whatever a process below does (double fork, ``setsid``, a new process group, ``exec`` with
an empty environment):

1. **A PID namespace**, where the kernel allows one (as root, or through an unprivileged user
   namespace mapping only this user's ids): PROGRAM runs under a small first process of a new PID
   namespace; when that process ends the kernel kills every process left in the namespace. Nothing
   inside can see, signal or outlive it (a namespace's first process ignores signals from inside,
   even SIGKILL), nor signal this reaper outside.
2. **A child subreaper** (``prctl(PR_SET_CHILD_SUBREAPER)``, Linux 3.4+, no privilege): an orphan
   is re-parented to the nearest living subreaper, this process, so every process below stays
   findable through ``/proc/<pid>/task/<tid>/children``; after PROGRAM ends, everything below is
   SIGSTOPped, SIGKILLed and reaped until none is left (:func:`kill_tree`). The checker does the
   same from outside at a timeout. This is the only layer where namespaces are refused (Docker's
   default seccomp profile, Ubuntu's AppArmor restriction of user namespaces); there a process
   below can still kill this reaper first, and the missing DONE-FILE says so.

Not a cgroup: that needs a delegated, writable cgroup v2 tree, which a CI job rarely has.

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


CLONE_NEWUSER, CLONE_NEWPID = 0x10000000, 0x20000000
PR_SET_PDEATHSIG = 1


def _pid_namespace(libc) -> bool:
    """Make the next child the first process of a new PID namespace (as root directly, else inside a
    user namespace mapping only this user's ids onto themselves); False where neither is allowed."""
    if libc.unshare(CLONE_NEWPID) == 0:
        return True
    uid, gid = os.getuid(), os.getgid()
    if libc.unshare(CLONE_NEWUSER | CLONE_NEWPID) != 0:
        return False
    try:
        for name, text in (("setgroups", "deny"), ("uid_map", f"{uid} {uid} 1"), ("gid_map", f"{gid} {gid} 1")):
            with open(f"/proc/self/{name}", "w") as f:
                f.write(text)
    except OSError as e:
        os.write(2, f"spurdiff check: cannot map the user into the PID namespace: {e}\n".encode())
        os._exit(125)
    return True


def _run(program: list[str]) -> int:
    """Start ``program`` as a child and wait for it; its wait status."""
    pid = os.fork()
    if pid == 0:
        try:
            os.execv(program[0], program)
        except OSError as e:
            os.write(2, f"spurdiff check: cannot start {program[0]}: {e}\n".encode())
        os._exit(127)
    while True:
        try:
            return os.waitpid(pid, 0)[1]
        except InterruptedError:
            continue


def _in_namespace(libc, program: list[str]) -> int:
    """Run ``program`` under a child that is process 1 of the new PID namespace; its wait status.
    When that first process ends, the kernel kills every process left in the namespace; no process
    inside can signal it or anything outside."""
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(r)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)   # this reaper killed: the namespace ends
        status = _run(program)
        os.write(w, f"{status}".encode())
        os._exit(0)
    os.close(w)
    while True:
        try:
            _, own = os.waitpid(pid, 0)
            break
        except InterruptedError:
            continue
    with os.fdopen(r, "rb") as f:
        text = f.read().decode()
    return int(text) if text.isdigit() else own


def main(argv: list[str]) -> None:
    namespace = argv[0] != "--no-pid-namespace"
    done, program = argv[0 if namespace else 1], argv[1 if namespace else 2:]
    try:
        import resource
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))   # nothing below leaves a core file
    except Exception:
        pass
    libc = None
    try:
        import ctypes
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) != 0:
            raise OSError(ctypes.get_errno(), "prctl(PR_SET_CHILD_SUBREAPER) failed")
    except (OSError, AttributeError) as e:   # not Linux: only the checker's group and marker kills remain
        libc = None
        os.write(2, f"spurdiff check: no child subreaper here ({e}); processes an FMU leaves may survive\n".encode())
    signal.signal(signal.SIGTERM, lambda *_: (kill_tree(os.getpid(), reap=True), os._exit(143)))
    if namespace and libc is not None and _pid_namespace(libc):
        status = _in_namespace(libc, program)
    else:
        status = _run(program)
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
