"""ChkCrashInStep: ChkGood whose third ``do_step`` dereferences a NULL pointer (the process gets
SIGSEGV).

Used to show that a crashing FMU cannot take the checker down: lifecycle.basic must FAIL with
"crashed (SIGSEGV) in fmi2DoStep(...)".
"""
import ctypes

from ChkGood import ChkGood


class ChkCrashInStep(ChkGood):
    description = "Segfaults in its third do_step (compliance-checker test FMU)"
    steps = 0

    def do_step(self, current_time, step_size):
        self.steps += 1
        if self.steps == 3:
            ctypes.string_at(0)  # read address 0: SIGSEGV
        return super().do_step(current_time, step_size)
