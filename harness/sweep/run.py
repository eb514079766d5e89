"""Running a sweep: plan, results table, executor, progress, one row per finished run."""
from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from harness.sweep.execution.executors import Runner, dask_rows, local_cluster, serial_rows
from harness.sweep.plan import Plan, plan_sweep
from harness.sweep.execution.progress import ProgressBar
from harness.sweep.spec import Sweep, SweepError
from harness.sweep.table import FolderLock, TableWriter, prepare_table, read_table, table_path, write_table
from harness.sweep.execution.worker import run_one

@dataclass
class Outcome:
    table: Path
    total: int
    ran: int                  # runs done by this call
    rows: list[dict]          # the whole table, by run (strings, as read back)
    wall: float               # s, this call (cluster start included when it started one)
    where: str

    @property
    def not_ok(self) -> list[dict]:
        return [r for r in self.rows if r["status"] != "ok"]


def run_sweep(sweep: Sweep, out_dir: Path | None = None, *, workers: int | None = None, scheduler: str | None = None,
              client=None, resume: bool = False, overwrite: bool = False, retry_failed: bool = False,
              duration: float | None = None, timeout: float | None = None, progress: bool = True,
              runner: Runner = run_one, on_row: Callable[[dict], None] | None = None, plan: Plan | None = None,
              max_steps: int | None = None) -> Outcome:
    """Run (or complete, with ``resume``) a sweep; every finished run is in the table at once.

    Where: ``client`` (a dask.distributed Client), else ``scheduler`` (address of a running
    cluster), else ``workers`` = 0 (this process) or N (a local cluster of N worker processes;
    default: one per CPU). ``on_row`` is called after each row is written."""
    t0 = time.perf_counter()
    if workers is not None and (workers < 0 or int(workers) != workers):
        raise SweepError(f"--workers = {workers!r}: allowed an integer >= 0 (0 = in this process)")
    if scheduler and workers is not None:
        raise SweepError("--workers and --scheduler: allowed one of them (the cluster at ADDRESS has its own workers)")
    if resume and overwrite:
        raise SweepError("--resume and --overwrite: allowed one of them")
    plan = plan or plan_sweep(sweep, duration=duration, timeout=timeout, max_steps=max_steps)
    path = table_path(sweep, out_dir)
    with FolderLock(path.parent, sweep.name):
        return _run_locked(sweep, plan, path, t0, workers=workers, scheduler=scheduler, client=client,
                           resume=resume, overwrite=overwrite, retry_failed=retry_failed, progress=progress,
                           runner=runner, on_row=on_row)


def _run_locked(sweep: Sweep, plan: Plan, path: Path, t0: float, *, workers, scheduler, client, resume, overwrite,
                retry_failed, progress, runner, on_row) -> Outcome:
    done = prepare_table(sweep, plan.tasks, path, resume, overwrite, retry_failed)
    todo = [t for t in plan.tasks if t.run not in done]
    bar = ProgressBar(len(plan.tasks), len(done), sum(r["status"] != "ok" for r in done.values()), enabled=progress)
    own_client = own_cluster = None
    if client is not None:
        where = "the given Dask client"
    elif scheduler:
        where = f"Dask scheduler {scheduler}"
    elif workers == 0:
        where = "this process"
    else:
        workers = workers or os.cpu_count() or 1
        where = f"a local Dask cluster of {workers} worker processes"
    writer = TableWriter(path, sweep.columns)
    ran = 0
    try:
        if todo:
            if client is None and scheduler:
                from dask.distributed import Client
                client = own_client = Client(scheduler, timeout="30s")
            elif client is None and workers != 0:
                client, own_cluster = local_cluster(workers)
                own_client = client
            rows = serial_rows(plan.job, todo, runner) if client is None else dask_rows(plan.job, todo, runner, client)
            for row in rows:
                writer.append(row)
                ran += 1
                bar.update(row)
                if on_row is not None:
                    on_row(row)
    finally:
        writer.close()
        if own_client is not None:
            own_client.close()
        if own_cluster is not None:
            own_cluster.close()
    header, rows = read_table(path)
    ordered = [rows[r] for r in sorted(rows)]
    write_table(path, sweep.columns, ordered)  # final table: one row per run, in run order
    return Outcome(path, len(plan.tasks), ran, ordered, time.perf_counter() - t0, where)
