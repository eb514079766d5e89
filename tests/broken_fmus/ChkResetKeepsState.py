"""ChkResetKeepsState: like ChkGood, but its integrator state survives fmi2Reset.

The state x lives in a module-level dict keyed by the instance name. pythonfmu implements
fmi2Reset by running the constructor again, which finds the old entry and keeps it, so a run
after reset continues from where the first run ended. Instances with different names stay
independent, and get/set/serialize state go through the registered getter/setter of x, so only
lifecycle.reset should FAIL. Built with --handle-state --serialize-state.
"""

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.default_experiment import DefaultExperiment

_STATE = {}  # instance name -> x: deliberately outlives the instance (and fmi2Reset)


class ChkResetKeepsState(Fmi2Slave):
    description = "Integrator whose state is not cleared by fmi2Reset (compliance-checker test FMU)"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=0.1, step_size=0.01)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        _STATE.setdefault(self.instance_name, 0.0)
        self.u = 1.0
        self.k = 2.0
        self.y = 2.0
        self.phase = 0.0
        self.register_variable(Real("u", causality=Fmi2Causality.input,
                                    variability=Fmi2Variability.continuous, description="input signal"))
        self.register_variable(Real("k", causality=Fmi2Causality.parameter,
                                    variability=Fmi2Variability.fixed, description="gain",
                                    setter=self._set_k))
        self.register_variable(Real("x", causality=Fmi2Causality.output,
                                    variability=Fmi2Variability.continuous, description="integral of k u",
                                    getter=self._get_x, setter=self._put_x))
        self.register_variable(Real("y", causality=Fmi2Causality.output,
                                    variability=Fmi2Variability.continuous, description="k u"))

    def _get_x(self):
        return _STATE[self.instance_name]

    def _put_x(self, value):
        _STATE[self.instance_name] = value

    def _set_k(self, value):
        if self.phase >= 2:
            raise RuntimeError("k is a fixed parameter: it cannot be set after initialization")
        self.k = value

    def _set_fmu_state(self, state):
        self._put_x(state["x"])
        for name in ("u", "k", "y"):
            setattr(self, name, state[name])

    def enter_initialization_mode(self):
        self.phase = 1.0

    def exit_initialization_mode(self):
        self.y = self.k * self.u
        self.phase = 2.0

    def do_step(self, current_time, step_size):
        if self.phase < 2 or not step_size > 0:
            return False
        self.y = self.k * self.u
        _STATE[self.instance_name] += self.y * step_size
        return True
