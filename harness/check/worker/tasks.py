"""Every task a check process runs (:mod:`.worker`), by id: the co-simulation rules (``cs.*``), the
model-exchange rules (``me.*``, :mod:`.me_checks`) and the reference simulation ("reference"). What
each rule checks, its section and severity are data in :mod:`.rules`."""
from __future__ import annotations

from . import cs_lifecycle, cs_state, cs_steps

CS_TASKS = {
    "cs.version": cs_lifecycle.check_version,
    "cs.basic": cs_lifecycle.check_basic,
    "cs.guid": cs_lifecycle.check_guid,
    "cs.logger": cs_lifecycle.check_logger,
    "cs.debug-logging": cs_lifecycle.check_debug_logging,
    "cs.initial-unknowns": cs_lifecycle.check_initial_unknowns,
    "cs.default-experiment": cs_lifecycle.check_default_experiment,
    "cs.stop-time": cs_lifecycle.check_stop_time,
    "cs.status-after-discard": cs_lifecycle.check_status_after_discard,
    "cs.get-after-terminate": cs_lifecycle.check_get_after_terminate,
    "cs.reset": cs_lifecycle.check_reset,
    "cs.two-instances": cs_state.check_two_instances,
    "cs.get-set-state": cs_state.check_get_set_state,
    "cs.free-state": cs_state.check_free_state,
    "cs.serialize-state": cs_state.check_serialize_state,
    "cs.variable-step": cs_steps.check_variable_step,
    "cs.clock": cs_steps.check_clock,
    "cs.feedthrough": cs_steps.check_feedthrough,
    "cs.interpolate-inputs": cs_steps.check_interpolate_inputs,
    "cs.output-derivatives": cs_steps.check_output_derivatives,
    "cs.directional-derivative": cs_steps.check_directional_derivative,
    "cs.step-before-init": cs_steps.check_step_before_init,
    "cs.zero-step-size": cs_steps.check_zero_step_size,
    "cs.negative-step-size": cs_steps.check_negative_step_size,
    "cs.nan-inputs": cs_steps.check_nan_inputs,
    "cs.parameter-after-init": cs_steps.check_parameter_after_init,
}


def run_task(task: str, payload: dict, tracer) -> tuple:
    """(status, reason[, severity]) of ``task``: a rule id (``cs.*``, ``me.*``) or "reference"."""
    from .fmi2 import Session
    if task == "reference":
        from ..reference_task import simulate_reference_task
        return simulate_reference_task(payload, tracer)
    kind = task.split(".", 1)[0]
    if kind in ("cs3", "me3"):   # FMI 3.0
        from . import cs3, me3
        from .fmi3 import Session3
        return {**cs3.TASKS, **me3.TASKS}[task](Session3(payload, tracer, kind))
    if kind == "cs":
        return CS_TASKS[task](Session(payload, tracer, "cs"))
    if kind == "me":
        from .me import TASKS
        session = Session(payload, tracer, "me")
        if task == "me.basic" and payload.get("out_csv"):
            return TASKS[task](session, payload["out_csv"])
        return TASKS[task](session)
    raise ValueError(f"unknown task {task!r}")
