"""Running one task on an FMU in a fresh Python process, so that a crash, exit or hang of the FMU's
binary cannot take the checker down.

The worker (:func:`harness.check.worker.worker_main`) writes the FMI call it is about to make to a
trace file, and its result as JSON to a result file. Its stdout and stderr go to files, never
pipes: an FMU that leaves a daemon behind holding them open cannot make the checker wait.

Every process the FMU starts ends with the task: the worker runs under :mod:`.reaper` (a PID
namespace where allowed, and a child subreaper that kills every process below it when the worker
ends, whatever it did to its session, group or environment; ``SPURDIFF_CHECK_PID_NAMESPACE=0``
leaves out the namespace); at the timeout the checker kills that tree itself
(:func:`.reaper.kill_tree`). Behind that, as before, the worker's process group and
every process still carrying the run's marker in its environment are killed (Linux).
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import uuid
from dataclasses import dataclass, field
from pathlib import Path

from ..report import FAIL

_PACKAGE_ROOT = Path(__file__).resolve().parents[3]  # the directory holding the ``harness`` package
MARKER = "SPURDIFF_CHECK_RUN"


def _last_line(path: Path) -> str:
    try:
        lines = [ln for ln in path.read_text(errors="replace").splitlines() if ln.strip()]
    except OSError:
        return ""
    return lines[-1] if lines else ""


def _tail(path: Path, n: int = 2, max_bytes: int = 4096) -> str:
    try:
        with open(path, "rb") as f:
            f.seek(0, os.SEEK_END)
            size = f.tell()
            f.seek(max(0, size - max_bytes))
            text = f.read().decode(errors="replace")
    except OSError:
        return ""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    return " / ".join(lines[-n:])


def _marked_pids(token: str) -> list[int]:
    """Processes of this user whose environment holds ``MARKER=token`` (Linux /proc; else [])."""
    needle = f"{MARKER}={token}".encode()
    pids = []
    proc = Path("/proc")
    if not proc.is_dir():
        return pids
    for d in proc.iterdir():
        if not d.name.isdigit() or int(d.name) == os.getpid():
            continue
        try:
            env = (d / "environ").read_bytes()
        except OSError:
            continue
        if needle in env.split(b"\0"):
            pids.append(int(d.name))
    return pids


REAPER = Path(__file__).resolve().with_name("reaper.py")


def reaped(cmd: list[str], work: Path) -> tuple[list[str], Path]:
    """``cmd`` run under the subreaper (:mod:`.reaper`), and the file it writes when it has ended
    everything below it."""
    done = work / "reaped.txt"
    flag = ["--no-pid-namespace"] if os.environ.get("SPURDIFF_CHECK_PID_NAMESPACE") == "0" else []
    return [sys.executable, "-I", "-S", str(REAPER), *flag, str(done), *cmd], done


def end_reaped(proc: subprocess.Popen, done: Path | None = None) -> str:
    """After a reaped process (``proc``) ended or at its timeout: every process below it and the
    process killed and reaped; "" or the one line saying that its subreaper was killed before it
    could end what the FMU started (``done`` missing)."""
    from .reaper import kill_tree
    if proc.poll() is None:
        kill_tree(proc.pid, include_root=True)
    proc.wait()
    if done is not None and not done.exists():
        return "the kit's process reaper was killed before it ended what the FMU started"
    return ""


def kill_run(pgid: int, token: str) -> None:
    """SIGKILL the worker's process group and every process carrying the run's marker."""
    try:
        os.killpg(pgid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError, OSError):
        pass
    for pid in _marked_pids(token):
        try:
            os.kill(pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError, OSError):
            pass


@dataclass
class Outcome:
    """What a check process gave: status, reason, severity (None: the rule's own), the facts the rule
    recorded for the rules that depend on it, and, when the process crashed, hung or exited without a
    result, ``abort`` = {"kind": "crash" / "timeout" / "exit", "call": the FMI call that was running}."""

    status: str
    reason: str
    severity: str | None = None
    facts: dict = field(default_factory=dict)
    abort: dict | None = None


def _call_of(trace_line: str) -> str:
    """The FMI call of a trace line without its instance: 'fmi2DoStep(t=0, h=0.01)'."""
    return trace_line.split(" [instance ", 1)[0].strip()


def run_isolated(task: str, payload: dict, timeout: float) -> tuple[str, str, str | None]:
    """(status, reason, severity or None) of :func:`run_isolated_outcome`."""
    o = run_isolated_outcome(task, payload, timeout)
    return o.status, o.reason, o.severity


def run_isolated_outcome(task: str, payload: dict, timeout: float) -> Outcome:
    """Run ``task`` (a rule id, or "reference") in a fresh Python process.

    A signal (segfault), a non-zero exit without a result, or the timeout gives FAIL naming the FMI
    call that was running (and ``abort``).
    """
    work = Path(tempfile.mkdtemp(prefix="spurdiff-check-"))
    trace, result = work / "trace.txt", work / "result.json"
    out_path, err_path = work / "stdout.txt", work / "stderr.txt"
    token = uuid.uuid4().hex
    env = dict(os.environ, **{MARKER: token})
    cmd, done = reaped([sys.executable, "-c",
                        "import sys; sys.path.insert(0, sys.argv[1]); "
                        "from harness.check.worker import worker_main; worker_main(sys.argv[2:])",
                        str(_PACKAGE_ROOT), task, json.dumps(payload), str(trace), str(result)], work)
    try:
        with open(out_path, "wb") as out, open(err_path, "wb") as err:
            proc = subprocess.Popen(cmd, cwd=work, stdin=subprocess.DEVNULL, stdout=out, stderr=err,
                                    start_new_session=True, env=env)
        try:
            rc = proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            end_reaped(proc)
            kill_run(proc.pid, token)
            where = _last_line(trace)
            return Outcome(FAIL, f"timed out after {timeout:g} s" + (f" in {where}" if where else ""),
                           abort={"kind": "timeout", "call": _call_of(where)})
        finally:
            escaped = end_reaped(proc, done) if proc.returncode is not None else ""
            kill_run(proc.pid, token)  # whatever the FMU left behind
        if escaped:
            where = _last_line(trace)
            return Outcome(FAIL, escaped + (f" (in {where})" if where else ""),
                           abort={"kind": "crash", "call": _call_of(where)})
        data = None
        if result.exists():
            try:
                data = json.loads(result.read_text(encoding="utf-8"))
            except ValueError:
                data = None
        if rc < 0:
            try:
                sig = signal.Signals(-rc).name
            except ValueError:
                sig = f"signal {-rc}"
            where = _last_line(trace)
            if data is not None:
                return Outcome(FAIL, f"{data['status']} ({data['reason']}), but the process then crashed ({sig}) at exit",
                               abort={"kind": "crash", "call": "exit"})
            return Outcome(FAIL, f"crashed ({sig})" + (f" in {where}" if where else ""),
                           abort={"kind": "crash", "call": _call_of(where)})
        if data is None:
            where = _last_line(trace)
            tail = _tail(err_path) or _tail(out_path)
            return Outcome(FAIL, (f"process exited with status {rc} without a result" + (f" in {where}" if where else "")
                                  + (f"; output: {tail}" if tail else "")),
                           abort={"kind": "exit", "call": _call_of(where)})
        return Outcome(data["status"], data["reason"], data.get("severity"), data.get("facts") or {})
    finally:
        shutil.rmtree(work, ignore_errors=True)
