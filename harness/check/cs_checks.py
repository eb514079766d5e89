"""Co-simulation rules (kind ``cs``), worker side: one function per rule, run in a fresh process.

Each takes the :class:`~.driver.Session` and returns (status, reason) or (status, reason,
severity) when a failure is milder than the rule's own severity (e.g. a step past the stop time
refused with fmi2Discard where the standard says fmi2Error). A :class:`~.driver.CallFailed`
raised by a call the rule needs to work is a FAIL of the rule naming that call.

"Refused" means a status above fmi2Warning. After a refusal with fmi2Fatal no further call is
made on that instance. Outputs are "the same" when numpy.isclose(rtol=1e-9, atol=1e-12,
equal_nan=True) holds for every output at every sample.
"""
from __future__ import annotations

import math
from ctypes import byref, c_double, c_int, c_void_p
from typing import Any

from .driver import (REFUSED, CallFailed, LOGGER_VIOLATIONS, Session, first_difference, perturbed, refusal,
                     status_label)
from .report import FAIL, PASS, SKIP
from .rules import WARNING

VARIABLE_STEP_FACTORS = (1.0, 0.5, 2.0, 0.25, 1.5, 3.0, 0.75, 1.0)
NAN_STEPS = 3
WRONG_GUID = "{00000000-0000-0000-0000-5b0ad5b0ad00}"
MAX_DEFAULT_STEPS = 1_000_000  # cs.default-experiment: beyond this the run is skipped, not cut short
OK_STATUSES = (0, 1)


def check_version(s: Session):
    fmu = s.instance("version").slave   # loaded, not instantiated
    s.trace("fmi2GetVersion")
    version = fmu.fmi2GetVersion()
    s.trace("fmi2GetTypesPlatform")
    types = fmu.fmi2GetTypesPlatform()
    problems = []
    if version != b"2.0":
        problems.append(f'fmi2GetVersion returned {version!r}, not "2.0"')
    if types != b"default":
        problems.append(f'fmi2GetTypesPlatform returned {types!r}, not "default" (an importer built with the '
                        f'standard header passes arguments of other types)')
    if problems:
        return FAIL, "; ".join(problems)
    return PASS, 'fmi2GetVersion "2.0", fmi2GetTypesPlatform "default"'


def check_basic(s: Session):
    a = s.instance("basic")
    a.initialize()
    a.run(s.t0, s.steps)
    a.terminate()
    a.free()
    return PASS, (f"instantiate, setupExperiment, initialization, {s.steps} doSteps of {s.h:g} s, terminate, "
                  f"freeInstance all accepted; {len(s.outputs)} outputs read")


def check_guid(s: Session):
    a = s.instance("wrongGuid", guid=WRONG_GUID)
    if a.instantiate(raise_on_null=False):
        a.free()
        return FAIL, (f"fmi2Instantiate accepted the GUID {WRONG_GUID} (the modelDescription's is {s.md.guid}): "
                      f"a binary and a modelDescription.xml that do not belong together would run")
    msg = a.last_message()
    return PASS, f"fmi2Instantiate with a wrong GUID returned NULL" + (f' ("{msg}")' if msg else "")


def check_logger(s: Session):
    total = 0
    wrong = s.instance("wrongGuid", guid=WRONG_GUID)  # many FMUs log why they refuse
    if wrong.instantiate(raise_on_null=False):
        wrong.free()
    total += len(wrong.messages)
    a = s.instance("logger")
    a.instantiate()
    cats = s.log_categories
    _set_debug_logging(a, True, cats)
    a.initialize(instantiate=False)
    a.run(s.t0, 2)
    st = a.step_status(s.t0 + 2 * s.h, 0.0)  # a zero step: most FMUs say something
    if st != 4:
        a.free()
    total += len(a.messages)
    if LOGGER_VIOLATIONS:
        return FAIL, f"{len(LOGGER_VIOLATIONS)} message(s) with a wrong argument: " + "; ".join(LOGGER_VIOLATIONS[:3])
    if total == 0:
        return SKIP, "the FMU logged nothing (wrong GUID, debug logging on, a zero step): nothing to check"
    return PASS, f"all {total} messages came with the componentEnvironment and instance name given"


def _set_debug_logging(inst, on: bool, categories: list[str]) -> int:
    from fmpy.fmi2 import fmi2String
    arr = (fmi2String * max(1, len(categories)))(*[c.encode() for c in categories]) if categories else None
    label = f"fmi2SetDebugLogging({'on' if on else 'off'}, {len(categories)} categories)"
    return inst.status(label, inst.slave.fmi2SetDebugLogging, inst.slave.component, 1 if on else 0,
                           len(categories), arr)


def check_debug_logging(s: Session):
    a = s.instance("debugLogging")
    a.instantiate()
    calls = [(True, [], "on with no category (all)"), (False, [], "off")]
    if s.log_categories:
        calls.insert(0, (True, s.log_categories, f"on with the {len(s.log_categories)} declared categories"))
    results = []
    for on, cats, what in calls:
        st = _set_debug_logging(a, on, cats)
        results.append((what, st))
        if st == 4:
            break
    bad = [(w, st) for w, st in results if st not in OK_STATUSES]
    if bad:
        msg = a.last_message()
        return FAIL, ("fmi2SetDebugLogging " + "; ".join(f"{w} returned {status_label(st)}" for w, st in bad)
                      + (f' ("{msg}")' if msg else ""))
    a.free()
    return PASS, "fmi2SetDebugLogging accepted: " + ", ".join(w for w, _ in results)


def _initial_readables(s: Session) -> list:
    seen, out = set(), []
    candidates = [u.variable for u in s.md.initialUnknowns if u.variable is not None]
    candidates += [v for v in s.outputs if v.initial in ("exact", "approx") or v.variability == "constant"]
    candidates += [v for v in s.variables if v.causality == "calculatedParameter"]
    for v in candidates:
        if v.name not in seen and v.type in ("Real", "Integer", "Enumeration", "Boolean"):
            seen.add(v.name)
            out.append(v)
    return out


def check_initial_unknowns(s: Session):
    wanted = _initial_readables(s)
    if not wanted:
        return SKIP, "no InitialUnknowns, outputs with a start value or calculated parameters"
    a = s.instance("initialUnknowns")
    a.instantiate()
    if s.start_values:
        a.set_values(s.start_values, " start values")
    a.setup()
    a.call("fmi2EnterInitializationMode", a.slave.enterInitializationMode)
    refused = []
    for v in wanted:
        try:
            a.read([v], v.name)
        except CallFailed as e:
            refused.append(f"{v.name} ({status_label(e.status)})")
            if e.status == 4:
                break
    if refused:
        msg = a.last_message()
        return FAIL, (f"in initialization mode fmi2Get* refused {len(refused)} of {len(wanted)}: "
                      + ", ".join(refused[:6]) + (f' ("{msg}")' if msg else ""))
    a.call("fmi2ExitInitializationMode", a.slave.exitInitializationMode)
    a.terminate()
    a.free()
    return PASS, f"in initialization mode all {len(wanted)} InitialUnknowns / calculated parameters / outputs were read"


def _n_steps(s: Session) -> int:
    return max(1, int(round((s.t_stop - s.t0) / s.h)))


def _terminated(a) -> bool | None:
    """fmi2GetBooleanStatus(fmi2Terminated) after a discarded step: True/False, None if not answered."""
    from fmpy.fmi2 import fmi2Terminated
    value = c_int(0)
    st = a.status("fmi2GetBooleanStatus(fmi2Terminated)", a.slave.fmi2GetBooleanStatus, a.slave.component,
                      fmi2Terminated, byref(value))
    return bool(value.value) if st in OK_STATUSES else None


def _run_default_experiment(s: Session, a):
    """Run the instance from start to stop time. Returns (None, t_end, n) when done, or
    (reason of failure, t, i) / ("discard", t, i) at a discarded step."""
    n = _n_steps(s)
    inputs = s.input_values()
    real = [j for j, v in enumerate(s.outputs) if v.type == "Real"]
    row0 = a.outputs()
    finite0 = [j for j in real if math.isfinite(row0[j])]
    t = s.t0
    for i in range(n):
        if inputs:
            a.set_values(inputs)
        t_next = s.t_stop if i == n - 1 else s.t0 + (i + 1) * s.h
        st = a.step_status(t, t_next - t)
        if st == 2:
            return "discard", t, i
        if st not in OK_STATUSES:
            msg = a.last_message()
            raise CallFailed(f"fmi2DoStep(t={t:.9g}, h={t_next - t:.9g})", a.name, st, msg)
        t = t_next
        row = a.outputs()
        bad = [s.outputs[j].name for j in finite0 if not math.isfinite(row[j])]
        if bad:
            return f"outputs became non-finite at t = {t:g} s: {', '.join(bad[:5])}", t, i + 1
    return None, t, n


def check_default_experiment(s: Session):
    if _n_steps(s) > MAX_DEFAULT_STEPS:
        return SKIP, (f"the DefaultExperiment needs {_n_steps(s)} steps of {s.h:g} s to its stop time {s.t_stop:g} s, "
                      f"more than {MAX_DEFAULT_STEPS}: not run")
    a = s.instance("defaultExperiment")
    a.initialize(stop_time=s.t_stop)
    problem, t, n = _run_default_experiment(s, a)
    if problem == "discard":
        term = _terminated(a)
        if term:
            a.terminate()
            a.free()
            return PASS, (f"{n} doSteps of {s.h:g} s accepted; at t = {t:g} s the FMU ended the simulation "
                          f"(fmi2Discard with fmi2Terminated = true) before the stop time {s.t_stop:g} s")
        return FAIL, (f"fmi2DoStep(t={t:g}, h={s.h:g}) returned fmi2Discard before the stop time "
                      f"{s.t_stop:g} s, and the FMU does not say it terminated (fmi2Terminated "
                      f"{'false' if term is False else 'not answered'})")
    if problem:
        return FAIL, problem
    a.terminate()
    a.free()
    return PASS, f"{n} doSteps of {s.h:g} s from {s.t0:g} to the stop time {s.t_stop:g} s accepted, outputs finite"


def _past_stop(s: Session, name: str):
    """An instance run to a defined stop time t0 + 2h, then asked to step past it.
    Returns (instance, status of that step, its communication point)."""
    stop = s.t0 + 2 * s.h
    a = s.instance(name)
    a.initialize(stop_time=stop)
    a.run(s.t0, 2)
    if s.input_values():
        a.set_values(s.input_values())
    return a, a.step_status(stop, s.h), stop


def check_stop_time(s: Session):
    a, st, stop = _past_stop(s, "stopTime")
    what = f"fmi2DoStep(t={stop:g}, h={s.h:g}) past the defined stop time {stop:g} s"
    msg = a.last_message()
    said = f' ("{msg}")' if msg else ""
    if st in OK_STATUSES:
        return FAIL, f"{what} returned {status_label(st)}{said}: the FMU has to return fmi2Error"
    if st == 2:
        return FAIL, f"{what} refused with fmi2Discard{said}; section 2.1.6 says fmi2Error", WARNING
    return PASS, f"{what} refused with {status_label(st)}{said}"


def _discard_by_nan(s: Session):
    """(instance, status of a doStep with NaN on every Real input), or (None, None) without inputs."""
    if not s.real_inputs:
        return None, None
    a = s.instance("discardNan")
    a.initialize()
    for v in s.real_inputs:
        if a.set_status(v.name, math.nan) not in OK_STATUSES:
            a.free()
            return None, None
    st = a.step_status(s.t0, s.h)
    if st != 2 and st != 4:
        a.free()
    return (a if st == 2 else None), st


def check_status_after_discard(s: Session):
    a, st, stop = _past_stop(s, "discard")
    h = s.h
    if st != 2:
        first = status_label(st)
        if st != 4:
            a.free()
        if _n_steps(s) > MAX_DEFAULT_STEPS:
            return SKIP, (f"no step was discarded (a doStep past the stop time returned {first}); the default "
                          f"experiment ({_n_steps(s)} steps) is too long to look for one")
        a = s.instance("discardInRun")  # does the default experiment discard a step?
        a.initialize(stop_time=s.t_stop)
        try:
            problem, t, _ = _run_default_experiment(s, a)
        except CallFailed as e:
            return SKIP, f"no step was discarded; the default experiment failed ({e}; see cs.default-experiment)"
        if problem == "discard":
            stop, h = t, min(s.h, s.t_stop - t) if s.t_stop > t else s.h
        else:   # a third way: NaN on the Real inputs (an FMU that refuses them may discard the step)
            a.free()
            a, st_nan = _discard_by_nan(s)
            if st_nan != 2:
                return SKIP, (f"no step was discarded (a doStep past the stop time returned {first}, the default "
                              f"experiment none, NaN inputs {status_label(st_nan) if st_nan is not None else 'none'})"
                              ": the status calls are defined after fmi2Discard")
            stop, h = s.t0, s.h
    from fmpy.fmi2 import fmi2DoStepStatus, fmi2LastSuccessfulTime, fmi2Terminated
    c = a.slave.component
    errors, warnings, seen = [], [], []
    term = c_int(-1)
    st_b = a.status("fmi2GetBooleanStatus(fmi2Terminated)", a.slave.fmi2GetBooleanStatus, c, fmi2Terminated, byref(term))
    if st_b in OK_STATUSES:
        if term.value not in (0, 1):
            errors.append(f"fmi2Terminated is {term.value}, not fmi2True/fmi2False")
        seen.append(f"fmi2Terminated = {bool(term.value)}")
    elif st_b == 2:
        warnings.append("fmi2GetBooleanStatus(fmi2Terminated) returned fmi2Discard (the master cannot tell "
                        "whether the slave wants to stop)")
    else:
        errors.append(f"fmi2GetBooleanStatus(fmi2Terminated) returned {status_label(st_b)}")
    if st_b != 4:
        last = c_double(math.nan)
        st_r = a.status("fmi2GetRealStatus(fmi2LastSuccessfulTime)", a.slave.fmi2GetRealStatus, c,
                            fmi2LastSuccessfulTime, byref(last))
        if st_r in OK_STATUSES:
            eps = 1e-9 * max(1.0, abs(stop))
            if not (stop - eps <= last.value <= stop + h + eps):
                errors.append(f"fmi2LastSuccessfulTime is {last.value!r}, outside the refused step "
                              f"[{stop:g}, {stop + h:g}] s")
            seen.append(f"fmi2LastSuccessfulTime = {last.value:g} s")
        elif st_r == 2:
            warnings.append("fmi2GetRealStatus(fmi2LastSuccessfulTime) returned fmi2Discard")
        else:
            errors.append(f"fmi2GetRealStatus(fmi2LastSuccessfulTime) returned {status_label(st_r)}")
        if st_r != 4:
            val = c_int(-1)
            st_s = a.status("fmi2GetStatus(fmi2DoStepStatus)", a.slave.fmi2GetStatus, c, fmi2DoStepStatus, byref(val))
            if st_s == 3:
                warnings.append("fmi2GetStatus(fmi2DoStepStatus) returned fmi2Error (defined after fmi2Pending; "
                                "a status the slave cannot give should be fmi2Discard)")
            elif st_s == 4 or st_s not in range(5):
                errors.append(f"fmi2GetStatus(fmi2DoStepStatus) returned {status_label(st_s)}")
            else:
                seen.append(f"fmi2GetStatus {status_label(st_s)}")
    if errors:
        return FAIL, "after a discarded doStep: " + "; ".join(errors + warnings)
    if warnings:
        return FAIL, "after a discarded doStep: " + "; ".join(warnings), WARNING
    return PASS, "after a discarded doStep: " + ", ".join(seen)


def check_get_after_terminate(s: Session):
    wanted = s.outputs or [v for v in s.variables if v.type == "Real" and v.causality != "independent"]
    if not wanted:
        return SKIP, "no variables to read"
    a = s.instance("terminated")
    a.initialize()
    a.run(s.t0, 2)
    a.terminate()
    a.read(wanted, "after fmi2Terminate")
    a.free()
    return PASS, f"{len(wanted)} variables read after fmi2Terminate"


def check_reset(s: Session):
    if not s.outputs:
        return SKIP, "no outputs to compare"
    a = s.instance("reset")
    a.initialize()
    first, _ = a.run(s.t0, s.steps)
    a.call("fmi2Reset", a.slave.reset)
    a.initialize(instantiate=False)
    second, _ = a.run(s.t0, s.steps)
    a.terminate()
    a.free()
    diff = first_difference(s, second, first)
    if diff:
        return FAIL, f"after fmi2Reset the same run gives different outputs: {diff} (after reset vs first run)"
    return PASS, f"after fmi2Reset the same {s.steps} steps give the same outputs"


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


def check_get_set_state(s: Session):
    if not s.cs.canGetAndSetFMUstate:
        return SKIP, "canGetAndSetFMUstate is not declared"
    if not s.outputs:
        return SKIP, "no outputs to compare"
    k, m = _halves(s)
    a = s.instance("state")
    a.initialize()
    _, t_k = a.run(s.t0, k)
    state = a.call("fmi2GetFMUstate", a.slave.getFMUstate)
    first, _ = a.run(t_k, m)
    a.call("fmi2SetFMUstate", a.slave.setFMUstate, state)
    second, _ = a.run(t_k, m)
    a.call("fmi2FreeFMUstate", a.slave.freeFMUstate, state)
    a.terminate()
    a.free()
    diff = first_difference(s, second, first, "right after the state call")
    if diff:
        return FAIL, (f"after fmi2SetFMUstate to the state saved at t = {t_k:g} s the continuation differs: "
                      f"{diff} (after restore vs first continuation)")
    return PASS, f"fmi2SetFMUstate to the state at t = {t_k:g} s repeats the next {m} steps exactly"


def check_free_state(s: Session):
    if not s.cs.canGetAndSetFMUstate:
        return SKIP, "canGetAndSetFMUstate is not declared"
    if not s.outputs:
        return SKIP, "no outputs to compare"
    k, m = _halves(s)
    a = s.instance("freeState")
    a.initialize()
    _, t_k = a.run(s.t0, k)
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
    if not s.outputs:
        return SKIP, "no outputs to compare"
    k, m = _halves(s)
    a = s.instance("serialize")
    a.initialize()
    _, t_k = a.run(s.t0, k)
    state = a.call("fmi2GetFMUstate", a.slave.getFMUstate)
    blob = a.call("fmi2SerializeFMUstate", a.slave.serializeFMUstate, state)
    a.call("fmi2FreeFMUstate", a.slave.freeFMUstate, state)
    first, _ = a.run(t_k, m)
    a.terminate()
    a.free()
    b = s.instance("deserialize")
    b.initialize()
    restored = b.call("fmi2DeSerializeFMUstate", b.slave.deSerializeFMUstate, blob)
    b.call("fmi2SetFMUstate", b.slave.setFMUstate, restored)
    second, _ = b.run(t_k, m)
    b.call("fmi2FreeFMUstate", b.slave.freeFMUstate, restored)
    b.terminate()
    b.free()
    diff = first_difference(s, second, first, "right after the state call")
    if diff:
        return FAIL, (f"a state serialized at t = {t_k:g} s ({len(blob)} bytes) and restored into a fresh "
                      f"instance continues differently: {diff} (restored vs original)")
    return PASS, (f"a state serialized at t = {t_k:g} s ({len(blob)} bytes) and restored into a fresh instance "
                  f"repeats the next {m} steps exactly")


def check_variable_step(s: Session):
    if not s.cs.canHandleVariableCommunicationStepSize:
        return SKIP, "canHandleVariableCommunicationStepSize is not declared"
    sizes = [f * s.h for f in VARIABLE_STEP_FACTORS]
    a = s.instance("varstep")
    a.initialize()
    rows, _ = a.run(s.t0, sizes)
    a.terminate()
    a.free()
    real = [j for j, v in enumerate(s.outputs) if v.type == "Real"]
    finite0 = [j for j in real if math.isfinite(rows[0][j])]
    for i, row in enumerate(rows[1:], 1):
        bad = [s.outputs[j].name for j in finite0 if not math.isfinite(row[j])]
        if bad:
            return FAIL, f"after step {i} (h = {sizes[i - 1]:g} s) outputs became non-finite: {', '.join(bad)}"
    return PASS, (f"{len(sizes)} steps of {', '.join(f'{f:g}' for f in VARIABLE_STEP_FACTORS)} x {s.h:g} s "
                  f"accepted, outputs stayed finite")


def check_interpolate_inputs(s: Session):
    if not s.cs.canInterpolateInputs:
        return SKIP, "canInterpolateInputs is not declared"
    if not s.real_inputs:
        return SKIP, "no Real inputs"
    a = s.instance("inputDerivatives")
    a.initialize()
    vrs = [v.valueReference for v in s.real_inputs]
    a.call(f"fmi2SetRealInputDerivatives({', '.join(v.name for v in s.real_inputs)}, order 1)",
           a.slave.setRealInputDerivatives, vrs, [1] * len(vrs), [0.0] * len(vrs))
    a.run(s.t0, 1)
    a.terminate()
    a.free()
    return PASS, f"first derivatives of {len(vrs)} Real inputs accepted, the step after them too"


def check_output_derivatives(s: Session):
    order = int(s.cs.maxOutputDerivativeOrder or 0)
    if order < 1:
        return SKIP, "maxOutputDerivativeOrder is 0"
    real_out = [v for v in s.outputs if v.type == "Real"]
    if not real_out:
        return SKIP, "no Real outputs"
    a = s.instance("outputDerivatives")
    a.initialize()
    a.run(s.t0, 1)
    vrs = [v.valueReference for v in real_out]
    values = a.call("fmi2GetRealOutputDerivatives(order 1)", a.slave.getRealOutputDerivatives, vrs, [1] * len(vrs))
    a.terminate()
    a.free()
    bad = [v.name for v, x in zip(real_out, values) if not math.isfinite(x)]
    if bad:
        return FAIL, f"non-finite output derivatives: {', '.join(bad[:5])}"
    return PASS, f"first derivatives of {len(vrs)} Real outputs given, finite"


def check_directional_derivative(s: Session):
    if not s.cs.providesDirectionalDerivative:
        return SKIP, "providesDirectionalDerivative is not declared"
    unknowns = [v for v in s.outputs if v.type == "Real"]
    knowns = s.real_inputs
    a = s.instance("directionalDerivative")
    if unknowns and knowns:  # after initialization: outputs with respect to the inputs
        a.initialize()
        a.run(s.t0, 1)
        what = "after a step"
    else:  # in initialization mode: the InitialUnknowns with respect to their dependencies
        initial = [u for u in s.md.initialUnknowns if u.variable is not None and u.variable.type == "Real"
                   and u.dependencies]
        unknowns = [u.variable for u in initial]
        seen, knowns = set(), []
        for u in initial:
            for d in u.dependencies:
                if d.type == "Real" and d.name not in seen:
                    seen.add(d.name)
                    knowns.append(d)
        if not unknowns or not knowns:
            return SKIP, "no Real inputs, and no InitialUnknowns with Real dependencies"
        a.instantiate()
        if s.start_values:
            a.set_values(s.start_values, " start values")
        a.setup()
        a.call("fmi2EnterInitializationMode", a.slave.enterInitializationMode)
        what = "in initialization mode"
    bad = []
    for k, known in enumerate(knowns):
        seed = [0.0] * len(knowns)
        seed[k] = 1.0
        values = a.call(f"fmi2GetDirectionalDerivative({what}, d/d {known.name})", a.slave.getDirectionalDerivative,
                        [v.valueReference for v in unknowns], [v.valueReference for v in knowns], seed)
        bad += [f"d {v.name}/d {known.name}" for v, x in zip(unknowns, values) if not math.isfinite(x)]
    if bad:
        return FAIL, f"non-finite directional derivatives {what}: {', '.join(bad[:5])}"
    a.free()
    return PASS, (f"{what}: derivatives of {', '.join(v.name for v in unknowns[:4])} with respect to "
                  f"{', '.join(v.name for v in knowns[:4])} given, finite")


def check_step_before_init(s: Session):
    a = s.instance("early")
    a.instantiate()
    if s.start_values:
        a.set_values(s.start_values, " start values")
    a.setup()
    return refusal(a.step_status(s.t0, s.h), a, "fmi2DoStep before initialization")


def check_parameter_after_init(s: Session):
    fixed = [v for v in s.start_vars if v.causality == "parameter" and v.variability == "fixed"]
    target = None
    for v in fixed:
        p = perturbed(v, s.start_values[v.name])
        if p is not None:
            target = (v, p)
            break
    if target is None:
        return SKIP, "no parameter with variability \"fixed\" to set"
    v, p = target
    a = s.instance("late")
    a.initialize()
    return refusal(a.set_status(v.name, p), a, f"setting fixed parameter {v.name} after initialization")


def _bad_step(s: Session, h: float, what: str):
    a = s.instance("badstep")
    a.initialize()
    return refusal(a.step_status(s.t0, h), a, f"fmi2DoStep with {what} (h = {h:g} s)")


def check_zero_step_size(s: Session):
    return _bad_step(s, 0.0, "a zero step size")


def check_negative_step_size(s: Session):
    return _bad_step(s, -s.h, "a negative step size")


def check_nan_inputs(s: Session):
    if not s.real_inputs:
        return SKIP, "no Real inputs"
    names = ", ".join(v.name for v in s.real_inputs)
    a = s.instance("nan")
    a.initialize()
    real = [j for j, v in enumerate(s.outputs) if v.type == "Real"]
    for i in range(NAN_STEPS):
        for v in s.real_inputs:
            st = a.set_status(v.name, math.nan)
            if st in REFUSED:
                return refusal(st, a, f"NaN written to input {v.name}")
        st = a.step_status(s.t0 + i * s.h, s.h)
        if st in REFUSED:
            return refusal(st, a, f"fmi2DoStep with NaN on inputs {names}")
        row = a.outputs()
        bad = [s.outputs[j].name for j in real if not math.isfinite(row[j])]
        if bad:
            return PASS, f"NaN on inputs {names} shows in outputs after step {i + 1}: {', '.join(bad)}"
    if not real:
        return SKIP, f"NaN on inputs {names} was accepted, and there are no Real outputs to observe"
    return FAIL, (f"NaN written to inputs {names} was accepted and {NAN_STEPS} doSteps returned fmi2OK with "
                  f"all Real outputs finite: the NaN was silently ignored")


TASKS = {
    "cs.version": check_version,
    "cs.basic": check_basic,
    "cs.guid": check_guid,
    "cs.logger": check_logger,
    "cs.debug-logging": check_debug_logging,
    "cs.initial-unknowns": check_initial_unknowns,
    "cs.default-experiment": check_default_experiment,
    "cs.stop-time": check_stop_time,
    "cs.status-after-discard": check_status_after_discard,
    "cs.get-after-terminate": check_get_after_terminate,
    "cs.reset": check_reset,
    "cs.two-instances": check_two_instances,
    "cs.get-set-state": check_get_set_state,
    "cs.free-state": check_free_state,
    "cs.serialize-state": check_serialize_state,
    "cs.variable-step": check_variable_step,
    "cs.interpolate-inputs": check_interpolate_inputs,
    "cs.output-derivatives": check_output_derivatives,
    "cs.directional-derivative": check_directional_derivative,
    "cs.step-before-init": check_step_before_init,
    "cs.zero-step-size": check_zero_step_size,
    "cs.negative-step-size": check_negative_step_size,
    "cs.nan-inputs": check_nan_inputs,
    "cs.parameter-after-init": check_parameter_after_init,
}
