"""`spurdiff bench` (= `python -m harness bench`): measured cost ratios, printed, never asserted.

The measurements live in :mod:`harness.bench.core`, the report printed from them (its targets
table, ``--write``) in :mod:`harness.bench.report`; this package re-exports what the command line
and other modules use. Benchmarks of their own subject go beside it as modules
of this package.
"""
from harness.bench.core import (EFFECT_SETS, fidelity_cost, fmi_overhead, realtime_factors,
                                step_control_comparison, step_cost_breakdown)

__all__ = ["EFFECT_SETS", "fidelity_cost", "fmi_overhead", "realtime_factors",
           "step_control_comparison", "step_cost_breakdown"]
