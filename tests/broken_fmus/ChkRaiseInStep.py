"""ChkRaiseInStep: like ChkGood, but ``do_step`` raises a Python exception.

pythonfmu turns the exception into fmi2Fatal. Expected verdict: lifecycle.basic FAILs (doStep
returned fmi2Fatal) and the other lifecycle checks are skipped; every static check passes once
the test has added units and dependencies to the model description.
"""

from ChkGood import ChkGood


class ChkRaiseInStep(ChkGood):
    description = "Raises in do_step (compliance-checker test FMU)"

    def do_step(self, current_time, step_size):
        raise ZeroDivisionError("deliberate failure in do_step")
