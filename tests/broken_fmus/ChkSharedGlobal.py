"""ChkSharedGlobal: like ChkGood, but its integrator state is one module-level variable.

All instances in a process share it (pythonfmu runs every FMU in one interpreter), and fmi2Reset
(which re-runs the constructor) does not clear it. Expected verdict: lifecycle.two-instances and
lifecycle.reset FAIL; every other check passes. Built with --handle-state --serialize-state.
"""
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.default_experiment import DefaultExperiment

_X = [0.0]  # deliberately shared by every instance in the process


class ChkSharedGlobal(Fmi2Slave):
    description = "Integrator whose state is shared by all instances (compliance-checker test FMU)"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=0.1, step_size=0.01)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
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

    @staticmethod
    def _get_x():
        return _X[0]

    @staticmethod
    def _put_x(value):
        _X[0] = value

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
        _X[0] += self.y * step_size
        return True
