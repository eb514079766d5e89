"""Every task a check process runs (:mod:`harness.check.worker`), by id: the co-simulation rules (``cs.*``,
``cs3.*``), the model-exchange rules (``me.*``, ``me3.*``) and the reference simulation ("reference"). A rule
that means the same in FMI 2.0 and 3.0 is one function under both ids; what each rule checks, its section and
severity are data in :mod:`harness.check.rules`."""
from __future__ import annotations

from . import cs3, cs_lifecycle, cs_state, cs_steps, me

# the rules both versions share: FMI 2.0 id -> (FMI 3.0 id or None, function)
SHARED = {
    "cs.basic": ("cs3.basic", cs_lifecycle.check_basic),
    "cs.guid": ("cs3.instantiation-token", cs_lifecycle.check_guid),
    "cs.logger": ("cs3.logger", cs_lifecycle.check_logger),
    "cs.debug-logging": ("cs3.debug-logging", cs_lifecycle.check_debug_logging),
    "cs.initial-unknowns": ("cs3.initial-unknowns", cs_lifecycle.check_initial_unknowns),
    "cs.default-experiment": ("cs3.default-experiment", cs_lifecycle.check_default_experiment),
    "cs.stop-time": ("cs3.stop-time", cs_lifecycle.check_stop_time),
    "cs.get-after-terminate": ("cs3.get-after-terminate", cs_lifecycle.check_get_after_terminate),
    "cs.reset": ("cs3.reset", cs_lifecycle.check_reset),
    "cs.two-instances": ("cs3.two-instances", cs_state.check_two_instances),
    "cs.get-set-state": ("cs3.get-set-state", cs_state.check_get_set_state),
    "cs.free-state": ("cs3.free-state", cs_state.check_free_state),
    "cs.serialize-state": ("cs3.serialize-state", cs_state.check_serialize_state),
    "cs.variable-step": ("cs3.variable-step", cs_steps.check_variable_step),
    "cs.clock": ("cs3.clock", cs_steps.check_clock),
    "cs.directional-derivative": ("cs3.directional-derivative", cs_steps.check_directional_derivative),
    "me.basic": ("me3.basic", me.check_me_basic),
    "me.guid": ("me3.instantiation-token", cs_lifecycle.check_guid),
    "me.directional-derivative": ("me3.directional-derivative", me.check_me_directional_derivative),
    "me.stale-outputs": ("me3.stale-outputs", me.check_me_stale_outputs),
}
# the rules of one version only
ONLY = {
    "cs.version": cs_lifecycle.check_version,
    "cs.status-after-discard": cs_lifecycle.check_status_after_discard,
    "cs.feedthrough": cs_steps.check_feedthrough,
    "cs.interpolate-inputs": cs_steps.check_interpolate_inputs,
    "cs.output-derivatives": cs_steps.check_output_derivatives,
    "cs.step-before-init": cs_steps.check_step_before_init,
    "cs.zero-step-size": cs_steps.check_zero_step_size,
    "cs.negative-step-size": cs_steps.check_negative_step_size,
    "cs.nan-inputs": cs_steps.check_nan_inputs,
    "cs.parameter-after-init": cs_steps.check_parameter_after_init,
    **cs3.TASKS,
}
TASKS = {**ONLY, **{k: f for k, (_, f) in SHARED.items()}, **{k3: f for k3, f in SHARED.values() if k3}}
CS_TASKS = {k: f for k, f in TASKS.items() if k.startswith("cs.")}


def run_task(task: str, payload: dict, tracer) -> tuple:
    """(status, reason[, severity]) of ``task``: a rule id (``cs.*``, ``me.*``, ``cs3.*``, ``me3.*``) or
    "reference"."""
    if task == "reference":
        from ..crosscheck.reference_task import simulate_reference_task
        return simulate_reference_task(payload, tracer)
    kind = task.split(".", 1)[0]
    if kind not in ("cs", "me", "cs3", "me3") or task not in TASKS:
        raise ValueError(f"unknown task {task!r}")
    if kind.endswith("3"):
        from .fmi3 import Session3
        session = Session3(payload, tracer, kind)
    else:
        from .fmi2 import Session
        session = Session(payload, tracer, kind)
    if task == "me.basic" and payload.get("out_csv"):
        return TASKS[task](session, payload["out_csv"])
    return TASKS[task](session)
