"""Results against references: the FMI cross-check suite's files, its rule, and the cross-check mode.

* :mod:`.formats`: the suite's file formats (result/input CSV, ``_ref.opt``), read and written within limits;
* :mod:`.band`: the suite's rule for a result against a reference (the band, the sample share, events at a
  sample, the reference's rounding); :mod:`.compare`: ``spurdiff check --compare``, per column, by that rule;
* :mod:`.reference`: ``--reference-results`` (the parent side), its run in :mod:`.reference_task`
  (inside a check process);
* :mod:`.xcheck`: ``--cross-check DIR``: every FMU of a suite's folder in every host, verdicts filed in the
  suite's results layout; its runs in :mod:`.xcheck_host` (inside a check process).

May import: :mod:`harness.check.rules`, :mod:`harness.check.report`, :mod:`harness.check.archive`,
:mod:`harness.check.static`, :mod:`harness.check.processes`, :mod:`harness.fmi` (in
:mod:`.xcheck_host` only), fmpy and numpy; never :mod:`harness.check.lifecycle` or :mod:`harness.check.runner`.
:mod:`.reference_task` and :mod:`.xcheck_host` run inside a check process (imported by
:mod:`harness.check.worker`) and import only :mod:`.formats`, :mod:`harness.check.report` and
:mod:`harness.fmi`. Nothing is imported here, so that a check process loads only what it runs.
"""
