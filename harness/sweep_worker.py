"""What runs inside a sweep worker (a Dask worker process, or the driver itself with ``--workers 0``).

One call of :func:`run_one` runs one sample of a sweep and returns its table row. It never
raises for a failed run: an FMU that refuses a call, a run over its time limit or any other
exception becomes a row with ``status`` and a one-line ``reason``.

FMU instances are reused. pythonfmu FMUs run inside the worker's own interpreter, so every
worker process keeps a pool of fmpy ``FMU2Slave`` instances keyed by (FMU file, instance name):
a run checks an instance out, calls ``fmi2Reset`` (pythonfmu re-runs the model's constructor, so
every parameter is back at its start value), sets the run's parameters, initializes and steps,
then ``fmi2Terminate`` and checks it back in. An instance whose reset fails is freed and replaced.
Instances are checked out, not shared between concurrent runs (threads would give no speed-up
with pythonfmu anyway: every call holds the GIL).

A job (:class:`Job`) carries the scene, the metrics and the FMU files; on a cluster it is sent to
each worker once. The driver runs from a snapshot of each FMU named by its sha256
(:func:`snapshot`); a worker uses that file when it sees it with the same hash (same machine),
else it writes the bytes the job carries to a snapshot of its own.
"""
from __future__ import annotations

import copy
import hashlib
import math
import os
import socket
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from harness.fmi.instance import Instance
from harness.master import Interrupted, Master, RunFailure
from harness.scene import Scene, SceneError

STATUSES = ("ok", "failed", "timeout", "error", "crashed")


# ---------------------------------------------------------------------------------------- job data
@dataclass(frozen=True)
class FmuRef:
    """An FMU file as the driver sees it: name, sha256 of the bytes, path, and (for clusters) the bytes."""

    name: str
    digest: str
    path: str
    data: bytes | None = None


@dataclass(frozen=True)
class Metric:
    """One result column.

    kind ``stat``: ``harness.report.stat(result, var, stat, window)`` of a recorded quantity;
    kind ``expr``: arithmetic over earlier columns (``{name}`` or ``{inst.param}``);
    kind ``theory``: a closed-form value (:data:`THEORIES`) from the run's parameters of ``instance``.
    """

    name: str
    kind: str
    var: str = ""
    stat: str = "mean"
    window: tuple[float, float] | None = None
    expr: str = ""
    theory: str = ""
    instance: str = ""


@dataclass
class Job:
    """Everything a worker needs for every run of one sweep."""

    scene: Scene                      # with overrides and fixed parameters applied, metric vars recorded
    fmus: dict[str, FmuRef]           # FMU name -> file
    metrics: list[Metric]
    timeout: float | None = None      # s of wall time per run (checked between steps)


@dataclass(frozen=True)
class Task:
    """One run: its number in the sweep and the parameter values it sets ('inst.param' -> value)."""

    run: int
    params: dict[str, Any] = field(default_factory=dict)


# ------------------------------------------------------------------------------- closed-form values
def _differential(params: dict[str, Any]):
    """Parameters and geometry of a SpurDifferential from its FMU start values plus ``params``."""
    from spurdiff.differential_fmu import VARIABLES, differential_params

    values = {v.name: v.start for v in VARIABLES}
    unknown = sorted(set(params) - set(values))
    if unknown:
        raise SceneError(f"closed form: unknown SpurDifferential parameter(s) {', '.join(unknown)}")
    values.update(params)
    p = differential_params(values)
    return p, p.validate()


def locking_coefficient(params: dict[str, Any]) -> float:
    """K = (mu r_d / n)(1/(r_a + r_1) + 1/(r_b + r_2)) from spurdiff.statics, dimensionless."""
    from spurdiff.statics import locking_coefficient as k

    p, g = _differential(params)
    return k(p.mu_pin, p.r_collar, p.table.nPairs, g.r_a, g.r_1, g.r_b, g.r_2)


def torque_bias_ratio(params: dict[str, Any]) -> float:
    """(1 + K) / (1 - K) from spurdiff.statics, dimensionless."""
    from spurdiff.statics import torque_bias_ratio as tbr

    return tbr(locking_coefficient(params))


# name -> (function of the instance's parameter values, FMU it applies to)
THEORIES = {
    "locking_coefficient": (locking_coefficient, "SpurDifferential"),
    "torque_bias_ratio": (torque_bias_ratio, "SpurDifferential"),
}


# ---------------------------------------------------------------------------------- FMU file cache
_FILES: dict[str, Path] = {}
_FILES_LOCK = threading.Lock()


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def snapshot(name: str, data: bytes, digest: str | None = None) -> Path:
    """The FMU ``data`` as a file named by its sha256 in a local cache directory (written once, atomically).

    A sweep runs from such snapshots, never from ``build/fmus``: a rebuild during a sweep cannot
    change or truncate the file its runs load."""
    digest = digest or hashlib.sha256(data).hexdigest()
    d = Path(tempfile.gettempdir()) / "spurdiff-sweep-fmus" / digest
    p = d / f"{name}.fmu"
    if not (p.is_file() and p.stat().st_size == len(data)):
        d.mkdir(parents=True, exist_ok=True)
        tmp = d / f".{name}.{os.getpid()}.{threading.get_ident()}.tmp"
        tmp.write_bytes(data)
        os.replace(tmp, p)
    return p


def local_fmu(ref: FmuRef) -> Path:
    """A path on this machine holding exactly the FMU ``ref`` names (checked once per process)."""
    with _FILES_LOCK:
        if ref.digest in _FILES:
            return _FILES[ref.digest]
        p = Path(ref.path)
        if not (p.is_file() and _sha256(p) == ref.digest):
            if ref.data is None:
                raise SceneError(f"{ref.name}: {ref.path} is missing or differs from the driver's FMU on "
                                 f"{socket.gethostname()}, and the job carries no FMU bytes")
            p = snapshot(ref.name, ref.data, ref.digest)
            if _sha256(p) != ref.digest:
                raise SceneError(f"{ref.name}: the copy written to {p} does not match the driver's FMU")
        _FILES[ref.digest] = p
        return p


# ---------------------------------------------------------------------------------- instance pool
class InstancePool:
    """Per-process pool of FMU instances, checked out for one run and back in after it."""

    def __init__(self):
        self._free: dict[tuple[str, str], list[Instance]] = {}
        self._builds: dict[str, str] = {}     # FMU name -> digest loaded in this process
        self._lock = threading.Lock()
        self.created = 0
        self.reused = 0

    def check_build(self, ref: FmuRef) -> None:
        """pythonfmu FMUs share one sys.modules per process: two builds of one FMU cannot coexist."""
        with self._lock:
            seen = self._builds.setdefault(ref.name, ref.digest)
        if seen != ref.digest:
            raise SceneError(f"this worker process (pid {os.getpid()}) already loaded another build of {ref.name}; "
                             "restart the workers after rebuilding an FMU (Client.restart())")

    def acquire(self, name: str, path: Path) -> Instance:
        key = (str(path), name)
        while True:
            with self._lock:
                inst = self._free.get(key, []).pop() if self._free.get(key) else None
            if inst is None:
                self.created += 1
                inst = Instance(name, path)  # its own log callback: messages reach this instance only
                self._free_at_exit()
                return inst
            inst.messages.clear()          # the logger callback appends to this very list
            try:
                inst.slave.reset()
            except Exception:
                inst.close()               # cannot be reused: drop it, try the next one
                continue
            self.reused += 1
            return inst

    def _free_at_exit(self) -> None:
        # free the pooled instances before the interpreter finalizes: processes that exited with
        # pythonfmu instances alive aborted at exit ("corrupted double-linked list") in about 6 % of
        # trials here, about 1 % with this (registered after harness.master's cache clean-up, so it
        # runs before it)
        if not getattr(self, "_atexit", False):
            import atexit
            atexit.register(self.clear)
            self._atexit = True

    def release(self, name: str, path: Path, inst: Instance) -> None:
        try:
            inst.slave.terminate()
        except Exception:
            pass  # terminate is refused in some error states; reset on the next checkout decides
        with self._lock:
            self._free.setdefault((str(path), name), []).append(inst)

    def clear(self) -> None:
        with self._lock:
            insts = [i for lst in self._free.values() for i in lst]
            self._free.clear()
        for inst in insts:
            inst.close()


POOL = InstancePool()


class RunTimeout(RunFailure):
    """The run exceeded the sweep's wall-time limit."""


class ReusingMaster(Master):
    """:class:`harness.master.Master` taking its FMU instances from the process pool."""

    def __init__(self, scene: Scene, fmu_files: dict[str, Path], pool: InstancePool = POOL,
                 timeout: float | None = None):
        self.pool = pool
        self._t0 = time.perf_counter()
        self._timeout = timeout
        super().__init__(scene, fmu_files, self._check_time if timeout else None)

    def _check_time(self, frac: float) -> None:  # Master calls this every 200 steps
        if frac < 1.0 and time.perf_counter() - self._t0 > self._timeout:
            t = frac * self.scene.duration
            raise RunTimeout("sweep", t, f"timeout: over {self._timeout:g} s of wall time at t = {t:.6g} s")

    def _instantiate(self) -> None:
        for spec in self.scene.instances:
            if spec.fmu not in self.fmu_files:
                raise SceneError(f"{spec.name}: unknown FMU {spec.fmu!r}; allowed: {', '.join(sorted(self.fmu_files))}")
            self.instances[spec.name] = self.pool.acquire(spec.name, self.fmu_files[spec.fmu])

    def _free(self) -> None:
        for spec in self.scene.instances:
            inst = self.instances.get(spec.name)
            if inst is not None:
                self.pool.release(spec.name, self.fmu_files[spec.fmu], inst)


# ------------------------------------------------------------------------------------- one run
def scene_for(job: Job, task: Task) -> Scene:
    """The job's scene with the task's parameters set."""
    scene = copy.deepcopy(job.scene)
    for key, value in task.params.items():
        inst, param = key.split(".", 1)
        scene.instance(inst).parameters[param] = value
    return scene


def instance_params(scene: Scene, instance: str) -> dict[str, Any]:
    """Parameter values an instance gets (the differential's scene effects under its parameters)."""
    return scene.parameters_of(instance)


def _worker_name() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def _one_line(text: str) -> str:
    return " ".join(str(text).split())[:500]


def run_one(task: Task, job: Job, pool: InstancePool = POOL) -> dict[str, Any]:
    """Run one sample; return its row: run, status, reason, wall_time_s, worker, parameters, metrics."""
    t0 = time.perf_counter()
    status, reason, result, scene = "ok", "", None, None
    try:
        scene = scene_for(job, task)
        for ref in job.fmus.values():
            pool.check_build(ref)
        files = {name: local_fmu(ref) for name, ref in job.fmus.items()}
        result = ReusingMaster(scene, files, pool, job.timeout).run()
        if isinstance(result.failure, Interrupted):
            raise result.failure   # Ctrl-C: no row for an interrupted run, the sweep stops
        if result.failure is not None:
            status = "timeout" if isinstance(result.failure, RunTimeout) else "failed"
            reason = str(result.failure)
    except Exception as e:  # a bad parameter name or value type, a missing file: keep the sweep going
        status, reason = "error", f"{type(e).__name__}: {e}"
    values = evaluate_metrics(job.metrics, task.params, result if status == "ok" else None, scene)
    row = {"run": task.run, "status": status, "reason": _one_line(reason),
           "wall_time_s": time.perf_counter() - t0, "worker": _worker_name()}
    row.update(task.params)
    row.update(values)
    return row


def evaluate_metrics(metrics: list[Metric], params: dict[str, Any], result, scene: Scene | None) -> dict[str, float]:
    """Metric values in order; measured ones are NaN without a successful ``result``."""
    from harness.report import stat

    env: dict[str, Any] = dict(params)
    out: dict[str, float] = {}
    for m in metrics:
        v = math.nan
        try:
            if m.kind == "stat":
                if result is not None:
                    v = stat(result, m.var, m.stat, m.window)
            elif m.kind == "expr":
                v = eval_expr(m.expr, env)
            elif m.kind == "theory" and scene is not None:
                v = THEORIES[m.theory][0](instance_params(scene, m.instance))
        except Exception:
            v = math.nan  # an invalid parameter set has no closed form; a bad division has no value
        out[m.name] = float(v)
        env[m.name] = out[m.name]
    return out


# ------------------------------------------------------------------------ metric expressions
def compile_expr(expr: str, names, where: str = "expr"):
    """Check a metric expression over ``{name}`` references (earlier columns and parameters);
    return the checked :class:`harness.expressions.Expression`. Raises a one-line SceneError."""
    from harness.expressions import compile_expression

    return compile_expression(expr, where, names)


def eval_expr(expr: str, env: dict[str, Any]) -> float:
    """The value of a metric expression over the run's parameters and earlier columns."""
    return float(compile_expr(expr, list(env))(env))
