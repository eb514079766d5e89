"""Measurements, printed and written to docs/, never asserted as timings: :mod:`.bench` (cost
ratios, ``spurdiff bench``), :mod:`.accuracy` (accuracy against wall time, ``spurdiff accuracy``),
:mod:`.fmi3_features` (what FMI 3.0's features change), :mod:`.fmi_versions` (a scene with the FMI
2.0 and the FMI 3.0 FMUs, compared) and :mod:`.info` (derived geometry and the paper's theory table).

May import: :mod:`harness.run`, :mod:`harness.build`, :mod:`harness.fmi`, :mod:`harness.scene`,
:mod:`harness.common` and :mod:`spurdiff`; not :mod:`harness.sweep` nor :mod:`harness.check`.
"""
