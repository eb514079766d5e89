"""`spurdiff bench` (= `python -m harness bench`): measured cost ratios, printed, never asserted.

The measurements and the report live in :mod:`harness.bench.core`; this package re-exports what
the command line and other modules use. Benchmarks of their own subject go beside it as modules
of this package.
"""
from harness.bench.core import (EFFECT_SETS, fidelity_cost, fmi_overhead, main, realtime_factors,
                                step_control_comparison, step_cost_breakdown)

__all__ = ["EFFECT_SETS", "fidelity_cost", "fmi_overhead", "main", "realtime_factors",
           "step_control_comparison", "step_cost_breakdown"]
