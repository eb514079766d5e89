"""ChkStateRestoreNoop: like ChkGood, but fmi2SetFMUstate restores nothing.

It declares canGetAndSetFMUstate (built with --handle-state, not --serialize-state) and
overrides ``_set_fmu_state`` with a no-op, so after a rollback the next steps continue from the
latest state. Only lifecycle.get-set-state should FAIL (lifecycle.serialize-state is skipped:
not declared).
"""

from ChkGood import ChkGood


class ChkStateRestoreNoop(ChkGood):
    description = "Integrator whose state restore does nothing (compliance-checker test FMU)"

    def _set_fmu_state(self, state):
        pass  # deliberately restores nothing
