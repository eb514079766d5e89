"""ChkCrashInStep: its third ``do_step`` dereferences a NULL pointer (the process gets SIGSEGV).

Used to show that a crashing FMU cannot take the checker down: lifecycle.basic must FAIL with
"crashed (SIGSEGV) in fmi2DoStep(...)".
"""
import ctypes

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.default_experiment import DefaultExperiment


class ChkCrashInStep(Fmi2Slave):
    description = "Segfaults in its third do_step (compliance-checker test FMU)"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=0.1, step_size=0.01)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.y = 0.0
        self.steps = 0
        self.register_variable(Real("y", causality=Fmi2Causality.output,
                                    variability=Fmi2Variability.continuous, description="step count"))

    def do_step(self, current_time, step_size):
        self.steps += 1
        if self.steps == 3:
            ctypes.string_at(0)  # read address 0: SIGSEGV
        self.y = float(self.steps)
        return True
