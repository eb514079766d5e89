"""ChkIgnoresStopTime: ChkGood without the stop-time refusal: a doStep past the stop time given to
fmi2SetupExperiment is accepted, which FMI 2.0 section 2.1.6 forbids (cs.stop-time must catch it).
Otherwise as ChkGood."""

from ChkGood import ChkGood


class ChkIgnoresStopTime(ChkGood):
    def past_stop(self, current_time, step_size) -> bool:
        return False  # deliberately: steps past the stop time are accepted
