"""`spurdiff bench` (= `python -m harness bench`): measured cost ratios, printed, never asserted.

The measurements live in :mod:`harness.measure.bench.core`, the report printed from them (its targets
table, ``--write``) in :mod:`harness.measure.bench.report`; this package re-exports what the command line
and other modules use. Benchmarks of their own subject go beside it as modules
of this package.

May import: :mod:`harness.measure.accuracy` (the stored accuracy data), :mod:`harness.run`,
:mod:`harness.build`, :mod:`harness.fmi`, :mod:`harness.scene`, :mod:`harness.common` and :mod:`spurdiff`.
"""
from harness.measure.bench.core import (EFFECT_SETS, fidelity_cost, fmi_overhead, realtime_factors,
                                        step_control_comparison, step_cost_breakdown)

__all__ = ["EFFECT_SETS", "fidelity_cost", "fmi_overhead", "realtime_factors",
           "step_control_comparison", "step_cost_breakdown"]
