"""ChkConsumesState: ChkGood whose fmi2SetFMUstate consumes the saved state: setting it a second time
restores nothing (FMI 2.0 section 2.1.8 lets a state be set any number of times; cs.free-state must
catch it, cs.get-set-state, which sets it once, passes). Otherwise as ChkGood.
Built with --handle-state --serialize-state."""

from ChkGood import ChkGood


class ChkConsumesState(ChkGood):
    def _set_fmu_state(self, state):
        super()._set_fmu_state(state)
        state.clear()  # deliberately: the saved state is used up
