"""Parameter sweeps over a scene: one command from a laptop to a Dask cluster, nothing lost.

A sweep file (``harness/sweeps/*.toml``, read with :mod:`tomllib`; unknown keys are rejected)
names a scene, the parameters to vary and the metrics to collect::

    name, description          text (name defaults to the file name)
    scene                      a scene name (``spurdiff scenes``) or a path to a scene file
    duration, step, mesh, algorithm   scene overrides, as for ``spurdiff run``
    fixed                      {"inst.param" = value}: set in every run
    timeout                    s of wall time per run (checked between steps); default none
    [sample]                   method = "grid" (default) | "list" | "random" | "lhs"; n, seed (random, lhs)
    [[parameters]]             name = "inst.param"; values = [...] (grid, list) or range = [lo, hi]
                               (grid with n; random, lhs); scale = "linear" | "log"; integer = true
    [[metrics]]                name plus one of:
                                 var = quantity, stat = mean|max|min|final|absmax|span, window = [t0, t1]
                                 expr = arithmetic over earlier columns, e.g. "{a} / abs({b})"
                                 theory = "locking_coefficient" | "torque_bias_ratio" (instance = "diff")
    [[plots]]                  x, y = [...], theory = [...] (dashed), group, title, file

Runs go to a Dask cluster: by default a local one of worker processes (pythonfmu FMUs run in
their host's interpreter, so parallelism comes from processes), ``scheduler`` = an existing
cluster, ``workers = 0`` = in this process. Every finished run is appended to one CSV table at
once (a row per run: run, status, reason, wall_time_s, worker, parameters, metrics); a failed run
is a row with its reason; ``resume`` reruns only the runs missing from the table.

The package, one module per job: :mod:`.spec` (the file's schema), :mod:`.sampling` (the runs),
:mod:`.plan` (scene, FMUs and names checked), :mod:`.jobs` (what travels to the workers),
:mod:`.theory` (closed-form metrics), :mod:`.table` (the CSV table, resume, the folder lock),
:mod:`.run` (all of it together), :mod:`.plots`, :mod:`.bench`; how the runs are carried out is
the subpackage :mod:`.execution` (executors: this process or Dask; the worker; the instance pool;
the FMU snapshots; the progress bar); the command line is :mod:`harness.cli.sweep`.

May import: :mod:`harness.run`, :mod:`harness.build`, :mod:`harness.fmi`, :mod:`harness.scene`,
:mod:`harness.common` and :mod:`spurdiff`; not :mod:`harness.measure` nor :mod:`harness.check`.
"""
from __future__ import annotations

from harness.sweep.jobs import STATUSES, FmuRef, Job, Metric, Task
from harness.sweep.plan import Plan, plan_sweep
from harness.sweep.execution.progress import ProgressBar
from harness.sweep.run import Outcome, run_sweep
from harness.sweep.sampling import expand, unit_samples
from harness.sweep.spec import SWEEP_DIR, Param, Plot, Sweep, SweepError, available, load_sweep, parse_sweep, sweep_path
from harness.sweep.table import FolderLock, TableWriter, fmt, read_table, table_path, write_table



__all__ = ["STATUSES", "FmuRef", "Job", "Metric", "Task", "Plan", "plan_sweep", "ProgressBar", "Outcome", "run_sweep",
           "expand", "unit_samples", "SWEEP_DIR", "Param", "Plot", "Sweep", "SweepError", "available", "load_sweep",
           "parse_sweep", "sweep_path", "FolderLock", "TableWriter", "fmt", "read_table", "table_path", "write_table",
           "main"]
