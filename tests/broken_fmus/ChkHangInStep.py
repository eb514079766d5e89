"""ChkHangInStep: its first ``do_step`` never returns (sleeps for an hour).

Used to show the per-check timeout: lifecycle.basic must FAIL with "timed out ... in fmi2DoStep".
"""
import time

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.default_experiment import DefaultExperiment


class ChkHangInStep(Fmi2Slave):
    description = "Hangs in do_step (compliance-checker test FMU)"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=0.1, step_size=0.01)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.y = 0.0
        self.register_variable(Real("y", causality=Fmi2Causality.output,
                                    variability=Fmi2Variability.continuous, description="constant zero"))

    def do_step(self, current_time, step_size):
        time.sleep(3600.0)
        return True
