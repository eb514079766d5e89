"""Co-simulation rules (kind ``cs``), worker side: independence of instances and the FMU state
(two instances, get/set, free and serialize state), one function per rule.

Conventions (what a rule returns, "refused", "the same") as in :mod:`.cs_lifecycle`.
"""
from __future__ import annotations

from ctypes import byref, c_void_p
from typing import Any

from .driver import CallFailed, Session, first_difference, perturbed
from .report import FAIL, PASS, SKIP


def _variations(s: Session) -> list[tuple[str, dict[str, Any]]]:
    """Candidate (description, overrides): all inputs changed together, then single parameters."""
    out = []
    ins = {}
    for v in s.inputs:
        if v.name in s.start_values:
            p = perturbed(v, s.start_values[v.name])
            if p is not None:
                ins[v.name] = p
    if ins:
        out.append(("inputs " + ", ".join(ins), ins))
    for v in s.start_vars:
        if v.causality == "parameter" and v.type != "String":
            p = perturbed(v, s.start_values[v.name])
            if p is not None:
                out.append((f"parameter {v.name}", {v.name: p}))
        if len(out) >= 9:
            break
    return out


def _solo(s: Session, name: str, overrides: dict[str, Any]) -> list[list[float]]:
    inst = s.instance(name)
    inst.initialize(overrides)
    inputs = s.input_values()
    inputs.update({k: x for k, x in overrides.items() if s.by_name[k].causality == "input"})
    rows, _ = inst.run(s.t0, s.steps, inputs)
    inst.terminate()
    inst.free()
    return rows


def check_two_instances(s: Session):
    if s.cs.canBeInstantiatedOnlyOncePerProcess:
        return SKIP, "canBeInstantiatedOnlyOncePerProcess is true"
    if not s.outputs:
        return SKIP, "no outputs to compare"
    ref_a = _solo(s, "A1", {})
    chosen = None
    for k, (what, overrides) in enumerate(_variations(s)):
        try:
            ref_b = _solo(s, f"B1_{k}", overrides)
        except CallFailed as e:
            if e.status == 4:
                return SKIP, f"changing {what} made the FMU fail ({e}); no other variation tried"
            continue
        if first_difference(s, ref_b, ref_a):
            chosen = (what, overrides, ref_b)
            break
    if chosen is None:
        return SKIP, "no input or parameter variation changed the outputs: independence not observable"
    what, overrides, ref_b = chosen
    a, b = s.instance("A2"), s.instance("B2")
    a.instantiate()
    b.instantiate()
    for inst, ov in ((a, {}), (b, overrides)):
        values = dict(s.start_values)
        values.update(ov)
        inst.set_values(values, " start values")
    for inst in (a, b):
        inst.setup()
    for inst in (a, b):
        inst.call("fmi2EnterInitializationMode", inst.slave.enterInitializationMode)
    for inst in (a, b):
        inst.call("fmi2ExitInitializationMode", inst.slave.exitInitializationMode)
    in_a = s.input_values()
    in_b = dict(in_a)
    in_b.update({k: x for k, x in overrides.items() if s.by_name[k].causality == "input"})
    rows_a, rows_b = [a.outputs()], [b.outputs()]
    for i in range(s.steps):
        t = s.t0 + i * s.h
        for inst, ins, rows in ((a, in_a, rows_a), (b, in_b, rows_b)):
            if ins:
                inst.set_values(ins)
            inst.do_step(t, (s.t0 + (i + 1) * s.h) - t)
            rows.append(inst.outputs())
    for inst in (a, b):
        inst.terminate()
    for inst in (a, b):
        inst.free()
    da = first_difference(s, rows_a, ref_a)
    db = first_difference(s, rows_b, ref_b)
    if da or db:
        parts = []
        if da:
            parts.append(f"the first instance (start values) changed when a second one ran beside it: {da} (beside vs alone)")
        if db:
            parts.append(f"the second instance ({what} changed) differs from running alone: {db} (beside vs alone)")
        return FAIL, "; ".join(parts)
    return PASS, f"two instances at once (the second with {what} changed) each give their solo outputs"


def _halves(s: Session) -> tuple[int, int]:
    k = max(1, s.steps // 2)
    return k, max(1, s.steps - k)


def _not_observable(s: Session) -> tuple[str, str] | None:
    """Why the state rules cannot run (SKIP, reason), or None."""
    if not s.cs.canGetAndSetFMUstate:
        return SKIP, "canGetAndSetFMUstate is not declared"
    if not s.outputs:
        return SKIP, "no outputs to compare"
    return None


def _first_half(s: Session, name: str):
    """A new instance initialized and run for the first half of the steps: (it, the steps left, t)."""
    k, m = _halves(s)
    a = s.instance(name)
    a.initialize()
    _, t_k = a.run(s.t0, k)
    return a, m, t_k


def _continue_from(a, state, t: float, m: int) -> list[list[float]]:
    """fmi2SetFMUstate(``state``), ``m`` steps from ``t``, the state freed and the instance ended:
    the output rows."""
    a.call("fmi2SetFMUstate", a.slave.setFMUstate, state)
    rows, _ = a.run(t, m)
    a.call("fmi2FreeFMUstate", a.slave.freeFMUstate, state)
    a.terminate()
    a.free()
    return rows


def check_get_set_state(s: Session):
    if _not_observable(s):
        return _not_observable(s)
    a, m, t_k = _first_half(s, "state")
    state = a.call("fmi2GetFMUstate", a.slave.getFMUstate)
    first, _ = a.run(t_k, m)
    second = _continue_from(a, state, t_k, m)
    diff = first_difference(s, second, first, "right after the state call")
    if diff:
        return FAIL, (f"after fmi2SetFMUstate to the state saved at t = {t_k:g} s the continuation differs: "
                      f"{diff} (after restore vs first continuation)")
    return PASS, f"fmi2SetFMUstate to the state at t = {t_k:g} s repeats the next {m} steps exactly"


def check_free_state(s: Session):
    if _not_observable(s):
        return _not_observable(s)
    a, m, t_k = _first_half(s, "freeState")
    c = a.slave.component
    state = c_void_p()
    a.call("fmi2GetFMUstate", a.slave.fmi2GetFMUstate, c, byref(state))
    first, t_end = a.run(t_k, m)
    runs = []
    for _ in range(2):
        a.call("fmi2SetFMUstate", a.slave.fmi2SetFMUstate, c, state)
        rows, _ = a.run(t_k, m)
        runs.append(rows)
    for i, rows in enumerate(runs, 1):
        diff = first_difference(s, rows, first, "right after the state call")
        if diff:
            return FAIL, (f"the state saved at t = {t_k:g} s, set for the {('first', 'second')[i - 1]} time, "
                          f"continues differently: {diff} (restored vs first continuation)")
    # fmi2GetFMUstate with a state given: it is overwritten with the current state
    a.call("fmi2GetFMUstate (overwriting a saved state)", a.slave.fmi2GetFMUstate, c, byref(state))
    again, _ = a.run(t_end, m)
    a.call("fmi2SetFMUstate", a.slave.fmi2SetFMUstate, c, state)
    back, _ = a.run(t_end, m)
    diff = first_difference(s, back, again, "right after the state call")
    if diff:
        return FAIL, (f"fmi2GetFMUstate into an existing state did not overwrite it with the state at "
                      f"t = {t_end:g} s: {diff} (restored vs continuation)")
    a.call("fmi2FreeFMUstate", a.slave.fmi2FreeFMUstate, c, byref(state))
    if state.value is not None:
        return FAIL, f"fmi2FreeFMUstate left the state pointer at {state.value:#x}, not NULL"
    null = c_void_p()
    a.call("fmi2FreeFMUstate(NULL)", a.slave.fmi2FreeFMUstate, c, byref(null))
    a.terminate()
    a.free()
    return PASS, (f"a state set twice repeats the continuation twice; fmi2GetFMUstate overwrote a given state; "
                  f"fmi2FreeFMUstate set the pointer to NULL; freeing NULL was ignored")


def check_serialize_state(s: Session):
    if not s.cs.canSerializeFMUstate:
        return SKIP, "canSerializeFMUstate is not declared"
    if not s.cs.canGetAndSetFMUstate:
        return FAIL, "canSerializeFMUstate is declared without canGetAndSetFMUstate (FMI 2.0 requires both)"
    if _not_observable(s):
        return _not_observable(s)
    a, m, t_k = _first_half(s, "serialize")
    state = a.call("fmi2GetFMUstate", a.slave.getFMUstate)
    blob = a.call("fmi2SerializeFMUstate", a.slave.serializeFMUstate, state)
    a.call("fmi2FreeFMUstate", a.slave.freeFMUstate, state)
    first, _ = a.run(t_k, m)
    a.terminate()
    a.free()
    b = s.instance("deserialize")
    b.initialize()
    second = _continue_from(b, b.call("fmi2DeSerializeFMUstate", b.slave.deSerializeFMUstate, blob), t_k, m)
    diff = first_difference(s, second, first, "right after the state call")
    if diff:
        return FAIL, (f"a state serialized at t = {t_k:g} s ({len(blob)} bytes) and restored into a fresh "
                      f"instance continues differently: {diff} (restored vs original)")
    return PASS, (f"a state serialized at t = {t_k:g} s ({len(blob)} bytes) and restored into a fresh instance "
                  f"repeats the next {m} steps exactly")
