"""ChkResetKeepsState: like ChkGood, but its integrator state survives fmi2Reset.

The state x lives in a module-level dict keyed by the instance name. pythonfmu implements
fmi2Reset by running the constructor again, which finds the old entry and keeps it, so a run
after reset continues from where the first run ended. Instances with different names stay
independent, and get/set/serialize state go through x, so only lifecycle.reset should FAIL.
Built with --handle-state --serialize-state.
"""

from ChkGood import ChkGood

_STATE = {}  # instance name -> x: deliberately outlives the instance (and fmi2Reset)


class ChkResetKeepsState(ChkGood):
    description = "Integrator whose state is not cleared by fmi2Reset (compliance-checker test FMU)"

    def init_state(self):
        _STATE.setdefault(self.instance_name, 0.0)  # deliberately: an old entry is kept

    @property
    def x(self):
        return _STATE[self.instance_name]

    @x.setter
    def x(self, value):
        _STATE[self.instance_name] = value
