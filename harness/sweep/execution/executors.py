"""Where a sweep's runs execute: in this process, or on a Dask cluster (local or remote), the rows
yielded as the runs finish."""
from __future__ import annotations

import logging
import uuid
import warnings
from dataclasses import replace
from pathlib import Path
from typing import Callable, Iterator

from harness.sweep.jobs import FmuRef, Job, Task
from harness.sweep.execution.worker import evaluate_metrics, scene_for

Runner = Callable[[Task, Job], dict]


def serial_rows(job: Job, tasks: list[Task], runner: Runner) -> Iterator[dict]:
    """Runs in this process, one after the other. Ctrl-C stops the running run at its next step
    (:func:`harness.run.master.stop_on_sigint`): it gives no row, and KeyboardInterrupt ends the sweep."""
    from harness.run.master import STOP, stop_on_sigint

    with stop_on_sigint():
        for t in tasks:
            if STOP.is_set():
                raise KeyboardInterrupt
            row = runner(t, job)
            yield row


def _broken_row(task: Task, job: Job, exc: BaseException) -> dict:
    """Row for a run whose worker died (or whose task Dask could not run)."""
    status = "crashed" if type(exc).__name__ == "KilledWorker" else "error"
    try:
        scene = scene_for(job, task)
    except Exception:
        scene = None
    row = {"run": task.run, "status": status, "reason": " ".join(f"{type(exc).__name__}: {exc}".split())[:500],
           "wall_time_s": float("nan"), "worker": ""}
    row.update(task.params)
    row.update(evaluate_metrics(job.metrics, task.params, None, scene))
    return row


def local_cluster(workers: int):
    """A local Dask cluster of ``workers`` single-threaded worker processes, and its client."""
    from dask.distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=workers, processes=True, threads_per_worker=1, dashboard_address=None,
                           silence_logs=logging.ERROR)
    return Client(cluster), cluster


def dask_rows(job: Job, tasks: list[Task], runner: Runner, client, in_flight: int = 1000) -> Iterator[dict]:
    """Runs on a Dask cluster, yielded as they finish; at most ``in_flight`` submitted at a time."""
    from dask.distributed import as_completed

    job = replace(job, fmus={n: _with_bytes(r) for n, r in job.fmus.items()})
    tag = uuid.uuid4().hex[:8]
    # The job (scene, metrics, FMU bytes) is a task of its own rather than scattered data: the
    # scheduler keeps its definition, so it is recomputed if every worker holding it dies. Dask
    # warns of a large graph (the FMUs, tens of MB) and advises futures: this is the one future
    # every run takes, sent once per sweep, so the warning is not passed on.
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Sending large graph", category=UserWarning)
        job_f = client.submit(_identity, job, key=f"sweep-job-{tag}", pure=False)
    pending = iter(tasks)
    futures: dict = {}
    ac = as_completed()

    def submit_next() -> None:
        t = next(pending, None)
        if t is not None:
            f = client.submit(runner, t, job_f, key=f"sweep-run{t.run}-{tag}", pure=False)
            futures[f] = t
            ac.add(f)

    try:
        for _ in range(in_flight):
            submit_next()
        for fut in ac:
            t = futures[fut]
            status = fut.status
            if status == "finished":
                try:
                    row = fut.result()
                except Exception as e:  # the result could not come back
                    row = _broken_row(t, job, e)
            elif status == "error":
                row = _broken_row(t, job, fut.exception())
            elif status == "cancelled":
                row = _broken_row(t, job, RuntimeError("the cluster cancelled the task"))
            else:  # finished, but its worker died before the result was fetched: Dask computes it again
                ac.add(fut)
                continue
            del futures[fut]
            fut.release()
            submit_next()
            yield row
    finally:
        if futures:
            client.cancel(list(futures))
        job_f.release()


def _identity(x):
    return x


def _with_bytes(ref: FmuRef) -> FmuRef:
    return ref if ref.data is not None else replace(ref, data=Path(ref.path).read_bytes())
