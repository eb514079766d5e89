"""Co-simulation rules (kinds ``cs`` and ``cs3``), worker side: independence of instances and the FMU state
(two instances, get/set, free and serialize state), one function per rule on either version's session.

Conventions (what a rule returns, "refused", "the same") as in :mod:`.cs_lifecycle`.
"""
from __future__ import annotations

from ctypes import byref, c_void_p
from typing import Any

from .common import first_difference, perturbed
from .fmi2 import CallFailed, Session
from ..report import FAIL, PASS, SKIP
from ..rules import WARNING


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
        if v.causality == "parameter" and v.type != "String" and not isinstance(s.start_values[v.name], list):
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
    late = {}
    for inst, ov in ((a, {}), (b, overrides)):
        values = dict(s.start_values)
        values.update(ov)
        late[inst.name] = {k: x for k, x in values.items() if s.by_name[k].causality == "input"}
        early = {k: x for k, x in values.items() if k not in late[inst.name]}   # inputs: in Initialization Mode
        if early:
            inst.set_values(early, " start values")
    for inst in (a, b):
        inst.setup()
    for inst in (a, b):
        inst.enter_init()
        if late[inst.name]:
            inst.set_values(late[inst.name], " inputs")
    for inst in (a, b):
        inst.exit_init()
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


HISTORY_FACTOR = 10.0   # a continuation within 10 x the FMU's tolerance of the original: integrator history


def classify_restore(s: Session, original: list[list[float]], restored: list[list[float]],
                     again: list[list[float]] | None = None) -> tuple[str, str]:
    """How a continuation after a restore compares with the ``original`` one: ("same", ""),
    ("history", what) when the outputs right after the restore are the saved ones and every output of
    the continuation (and of a second restore's, ``again``) stays within HISTORY_FACTOR x the FMU's
    tolerance of the original (relative to the output's largest magnitude in the original run) -- the
    state leaves out integrator history -- or ("wrong", what): time, states or outputs were not
    restored."""
    import numpy as np
    diff = first_difference(s, restored, original, "right after the state call")
    if diff is None:
        return "same", ""
    B = np.asarray(original, dtype=float)
    runs = [np.asarray(restored, dtype=float)] + ([np.asarray(again, dtype=float)] if again is not None else [])
    if any(A.shape != B.shape for A in runs):
        return "wrong", diff
    for k, A in enumerate(runs):
        ok0 = np.isclose(A[0], B[0], rtol=1e-9, atol=1e-12, equal_nan=True)
        if not ok0.all():
            j = int(np.argmin(ok0))
            return "wrong", (f"the outputs right after {'a second ' if k else ''}{s.fmi}SetFMUstate are not the saved "
                             f"ones: {s.columns[j]} {float(A[0, j])!r} vs {float(B[0, j])!r}")
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.nanmax(np.abs(B), axis=0)
        bound = HISTORY_FACTOR * s.tolerance * scale
        worst = []
        for A in runs:
            err = np.nanmax(np.abs(A - B), axis=0)
            if ((err > bound) | ((np.isnan(A) != np.isnan(B)).any(axis=0)) | ~np.isfinite(err)).any():
                return "wrong", diff + ("" if A is runs[0] else " (a second restore differs more)")
            worst.append(np.where(scale > 0, err / np.where(scale > 0, scale, 1.0), 0.0))
    rel = worst[0]
    j = int(np.argmax(rel))
    err_j = rel[j] * scale[j]
    second = ""
    if len(runs) > 1:
        d12 = float(np.nanmax(np.abs(runs[1] - runs[0]) / np.where(scale > 0, scale, 1.0)))
        second = f"; a second restore continues within {d12:.2g} of the first"
    return "history", (f"differs by up to {rel[j]:.2g} of its largest magnitude ({s.columns[j]}: "
                       f"{err_j:.3g} of {scale[j]:.3g}), within {HISTORY_FACTOR:g} x the tolerance "
                       f"{s.tolerance:g}{second}")


def check_get_set_state(s: Session):
    if _not_observable(s):
        return _not_observable(s)
    a, m, t_k = _first_half(s, "state")
    state = a.get_state()
    first, _ = a.run(t_k, m)
    a.set_state(state)
    second, _ = a.run(t_k, m)
    kind, what = classify_restore(s, first, second)
    if kind != "same" or s.fmi == "fmi3":   # a second restore tells lost history (it agrees) from a state not
        a.set_state(state, " (again)")      # restored; FMI 3.0 2.2.7.4: the state allows "multiple calls"
        third, _ = a.run(t_k, m)
        kind, what = classify_restore(s, first, second, third)
    a.free_state(state)
    a.terminate()
    a.free()
    facts = {"restores": kind != "wrong"}
    f = s.fmi
    if kind == "history":
        return FAIL, (f"after {f}SetFMUstate to the state saved at t = {t_k:g} s the outputs are the saved ones, "
                      f"but the continuation {what}: the state leaves out integrator history (after restore vs "
                      f"first continuation)"), WARNING, facts
    if kind == "wrong":
        return FAIL, (f"after {f}SetFMUstate to the state saved at t = {t_k:g} s the continuation differs: "
                      f"{what} (after restore vs first continuation)"), None, facts
    return PASS, f"{f}SetFMUstate to the state at t = {t_k:g} s repeats the next {m} steps exactly", facts


def check_free_state(s: Session):
    if _not_observable(s):
        return _not_observable(s)
    a, m, t_k = _first_half(s, "freeState")
    c, f = a.slave.component, s.fmi
    get, put, free = a.fn("GetFMUstate"), a.fn("SetFMUstate"), a.fn("FreeFMUstate")
    state = c_void_p()
    a.call(f"{f}GetFMUstate", get, c, byref(state))
    _, t_end = a.run(t_k, m)
    runs = []
    for _ in range(2):
        a.call(f"{f}SetFMUstate", put, c, state)
        rows, _ = a.run(t_k, m)
        runs.append(rows)
    kind, what = classify_restore(s, runs[0], runs[1])   # restore against restore
    if kind == "wrong":
        return FAIL, (f"the state saved at t = {t_k:g} s, set for the second time, continues differently: "
                      f"{what} (second vs first restore)")
    rule = "cs.get-set-state" if f == "fmi2" else "cs3.get-set-state"
    note = (f" (the second continuation {what}: integrator history, {rule})" if kind == "history" else "")
    # GetFMUstate with a state given: it is overwritten with the current state (at t_end)
    now = a.outputs()
    a.call(f"{f}GetFMUstate (overwriting a saved state)", get, c, byref(state))
    a.run(t_end, m)
    a.call(f"{f}SetFMUstate", put, c, state)
    back = a.outputs()
    diff = first_difference(s, [back], [now], "right after the state call")
    if diff:
        return FAIL, (f"{f}GetFMUstate into an existing state did not overwrite it with the state at "
                      f"t = {t_end:g} s: {diff} (restored vs saved)")
    a.run(t_end, 1)   # the restored state continues from t_end (an FMU that checks the time refuses otherwise)
    a.call(f"{f}FreeFMUstate", free, c, byref(state))
    if state.value is not None:
        return FAIL, f"{f}FreeFMUstate left the state pointer at {state.value:#x}, not NULL"
    null = c_void_p()
    a.call(f"{f}FreeFMUstate(NULL)", free, c, byref(null))
    a.terminate()
    a.free()
    return PASS, (f"a state set twice gives the same continuation twice{note}; {f}GetFMUstate overwrote a given "
                  f"state; {f}FreeFMUstate set the pointer to NULL; freeing NULL was ignored")


def check_serialize_state(s: Session):
    if not s.cs.canSerializeFMUstate:
        return SKIP, "canSerializeFMUstate is not declared"
    if not s.cs.canGetAndSetFMUstate:
        return FAIL, (f"canSerializeFMUstate is declared without canGetAndSetFMUstate (FMI {s.fmi[-1]}.0 requires "
                      f"both)")
    if _not_observable(s):
        return _not_observable(s)
    a, m, t_k = _first_half(s, "serialize")
    state = a.get_state()
    blob = a.serialize_state(state)
    a.run(t_k, m)
    a.set_state(state)
    restored, _ = a.run(t_k, m)   # the same state restored in its own instance: what the fresh one must give
    a.free_state(state)
    a.terminate()
    a.free()
    b = s.instance("deserialize")
    b.initialize()
    copy = b.deserialize_state(blob)
    b.set_state(copy)
    second, _ = b.run(t_k, m)
    b.free_state(copy)
    b.terminate()
    b.free()
    kind, what = classify_restore(s, restored, second)
    if kind == "wrong":
        return FAIL, (f"a state serialized at t = {t_k:g} s ({len(blob)} bytes) and restored into a fresh "
                      f"instance continues differently from the same state set with {s.fmi}SetFMUstate: {what} "
                      f"(deserialized vs set)")
    note = (f"; it {what} of the continuation after {s.fmi}SetFMUstate in the first instance (integrator history: "
            f"{'cs' if s.fmi == 'fmi2' else 'cs3'}.get-set-state)") if kind == "history" else ""
    return PASS, (f"a state serialized at t = {t_k:g} s ({len(blob)} bytes) and restored into a fresh instance "
                  f"continues as the same state set with {s.fmi}SetFMUstate{note}")
