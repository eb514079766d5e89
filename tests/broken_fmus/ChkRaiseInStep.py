"""ChkRaiseInStep: like ChkGood, but ``do_step`` raises a Python exception.

pythonfmu turns the exception into fmi2Fatal. Expected verdict: lifecycle.basic FAILs (doStep
returned fmi2Fatal) and the other lifecycle checks are skipped; every static check passes once
the test has added units and dependencies to the model description.
"""
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.default_experiment import DefaultExperiment


class ChkRaiseInStep(Fmi2Slave):
    description = "Raises in do_step (compliance-checker test FMU)"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=0.1, step_size=0.01)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.u = 1.0
        self.k = 2.0
        self.x = 0.0
        self.y = 2.0
        self.register_variable(Real("u", causality=Fmi2Causality.input,
                                    variability=Fmi2Variability.continuous, description="input signal"))
        self.register_variable(Real("k", causality=Fmi2Causality.parameter,
                                    variability=Fmi2Variability.fixed, description="gain"))
        self.register_variable(Real("x", causality=Fmi2Causality.output,
                                    variability=Fmi2Variability.continuous, description="integral of k u"))
        self.register_variable(Real("y", causality=Fmi2Causality.output,
                                    variability=Fmi2Variability.continuous, description="k u"))

    def do_step(self, current_time, step_size):
        raise ZeroDivisionError("deliberate failure in do_step")
