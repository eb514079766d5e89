"""Running a scene: :mod:`.runner` turns a scene name and overrides into a runnable scene and its FMU
files; :mod:`.master` (FMI 2.0, fixed step) and :mod:`.master3` (the FMI 3.0 features) run it
through FMI, :mod:`.stepcontrol` with variable steps, :mod:`.direct` with the physics called without
FMI; :mod:`.result` is what any of them returns, :mod:`.report` the statistics, checks, table and
CSV, :mod:`.plots` the figures, :mod:`.metrics` the errors of a run against a reference.

May import: :mod:`harness.build`, :mod:`harness.fmi`, :mod:`harness.scene`, :mod:`harness.common`
and :mod:`spurdiff`.
"""
