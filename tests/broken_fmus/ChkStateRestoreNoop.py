"""ChkStateRestoreNoop: like ChkGood, but fmi2SetFMUstate restores nothing.

It declares canGetAndSetFMUstate (built with --handle-state, not --serialize-state) and
overrides ``_set_fmu_state`` with a no-op, so after a rollback the next steps continue from the
latest state. Only lifecycle.get-set-state should FAIL (lifecycle.serialize-state is skipped:
not declared).
"""
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.default_experiment import DefaultExperiment


class ChkStateRestoreNoop(Fmi2Slave):
    description = "Integrator whose state restore does nothing (compliance-checker test FMU)"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=0.1, step_size=0.01)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.u = 1.0
        self.k = 2.0
        self.x = 0.0
        self.y = 2.0
        self.phase = 0.0
        self.register_variable(Real("u", causality=Fmi2Causality.input,
                                    variability=Fmi2Variability.continuous, description="input signal"))
        self.register_variable(Real("k", causality=Fmi2Causality.parameter,
                                    variability=Fmi2Variability.fixed, description="gain",
                                    setter=self._set_k))
        self.register_variable(Real("x", causality=Fmi2Causality.output,
                                    variability=Fmi2Variability.continuous, description="integral of k u"))
        self.register_variable(Real("y", causality=Fmi2Causality.output,
                                    variability=Fmi2Variability.continuous, description="k u"))

    def _set_k(self, value):
        if self.phase >= 2:
            raise RuntimeError("k is a fixed parameter: it cannot be set after initialization")
        self.k = value

    def _set_fmu_state(self, state):
        pass  # deliberately restores nothing

    def enter_initialization_mode(self):
        self.phase = 1.0

    def exit_initialization_mode(self):
        self.y = self.k * self.u
        self.phase = 2.0

    def do_step(self, current_time, step_size):
        if self.phase < 2 or not step_size > 0:
            return False
        self.y = self.k * self.u
        self.x += self.y * step_size
        return True
