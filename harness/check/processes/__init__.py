"""The processes the kit runs an FMU in, and how each one is ended.

* :mod:`.isolation`: one task in a fresh process (:mod:`harness.check.worker`), killed with its whole
  group at the timeout;
* :mod:`.reaper`: the process every FMU runs under (started by :mod:`.isolation` as a script), ending all
  the FMU started;
* :mod:`.native`: the binary outside Python (ELF symbols against DT_NEEDED, a bare C host under the reaper),
  the ``load.*`` rules.

May import: :mod:`harness.check.rules`, :mod:`harness.check.report`, :mod:`harness.check.archive`,
:mod:`harness.check.static`, :mod:`harness.common` and fmpy; the worker only by its command line, never
by import; never :mod:`harness.check.crosscheck`, :mod:`harness.check.lifecycle` or
:mod:`harness.check.runner`. :mod:`.reaper` imports nothing of the project (it runs as a script).
"""
