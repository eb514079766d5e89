"""How a sweep's runs are carried out: :mod:`.executors` (this process or a Dask cluster),
:mod:`.worker` (one run, inside a worker), :mod:`.pool` (FMU instances reused per process),
:mod:`.fmu_files` (the FMU snapshots the workers load), :mod:`.progress` (the progress bar).

May import: :mod:`harness.sweep.jobs` (what travels to the workers), :mod:`harness.sweep.theory`
(the closed-form metrics a worker evaluates), :mod:`harness.run`, :mod:`harness.build`,
:mod:`harness.fmi`, :mod:`harness.scene`, :mod:`harness.common` and :mod:`spurdiff`; not the
sweep's planning, table or plots (they import this package, not the other way round).
"""
