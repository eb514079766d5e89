"""What runs inside a sweep worker (a Dask worker process, or the driver itself with ``--workers 0``).

One call of :func:`run_one` runs one sample of a sweep and returns its table row. It never
raises for a failed run: an FMU that refuses a call, a run over its time limit or any other
exception becomes a row with ``status`` and a one-line ``reason``. FMU instances come from the
process's pool (:mod:`harness.sweep.execution.pool`), FMU files from snapshots (:mod:`harness.sweep.execution.fmu_files`).
"""
from __future__ import annotations

import copy
import math
import os
import socket
import time
from typing import Any

from harness.scene.expressions import compile_expression
from harness.run.master import Interrupted
from harness.scene.spec import Scene
from harness.sweep.execution.fmu_files import local_fmu
from harness.sweep.jobs import Job, Metric, Task
from harness.sweep.execution.pool import POOL, InstancePool, ReusingMaster, RunTimeout
from harness.sweep.theory import THEORIES

def scene_for(job: Job, task: Task) -> Scene:
    """The job's scene with the task's parameters set."""
    scene = copy.deepcopy(job.scene)
    for key, value in task.params.items():
        inst, param = key.split(".", 1)
        scene.instance(inst).parameters[param] = value
    return scene


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
    from harness.run.report import stat

    env: dict[str, Any] = dict(params)
    out: dict[str, float] = {}
    for m in metrics:
        v = math.nan
        try:
            if m.kind == "stat":
                if result is not None:
                    v = stat(result, m.var, m.stat, m.window)
            elif m.kind == "expr":
                v = float(compile_expression(m.expr, "expr", list(env))(env))
            elif m.kind == "theory" and scene is not None:
                v = THEORIES[m.theory][0](scene.parameters_of(m.instance))
        except Exception:
            v = math.nan  # an invalid parameter set has no closed form; a bad division has no value
        out[m.name] = float(v)
        env[m.name] = out[m.name]
    return out
