"""ChkSharedGlobal: like ChkGood, but its integrator state is one module-level variable.

All instances in a process share it (pythonfmu runs every FMU in one interpreter), and fmi2Reset
(which re-runs the constructor) does not clear it. Expected verdict: lifecycle.two-instances and
lifecycle.reset FAIL; every other check passes. Built with --handle-state --serialize-state.
"""

from ChkGood import ChkGood

_X = [0.0]  # deliberately shared by every instance in the process


class ChkSharedGlobal(ChkGood):
    description = "Integrator whose state is shared by all instances (compliance-checker test FMU)"

    def init_state(self):
        pass  # deliberately: the shared value is neither created nor cleared per instance

    @property
    def x(self):
        return _X[0]

    @x.setter
    def x(self, value):
        _X[0] = value
