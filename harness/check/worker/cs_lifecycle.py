"""Co-simulation rules (kinds ``cs`` and ``cs3``), worker side: the life of an instance (version, basic run,
GUID / instantiation token, logger, debug logging, initial unknowns, default experiment, stop time, status
after a discard, get after terminate, reset), one function per rule, run in a fresh process; a rule that
means the same in FMI 2.0 and 3.0 is one function on either session (:class:`.fmi2.Session`,
:class:`.fmi3.Session3`), its labels naming the version's calls (``s.fmi``).

Each takes the session and returns (status, reason) or (status, reason,
severity) when a failure is milder than the rule's own severity (e.g. a step past the stop time
refused with fmi2Discard where the standard says fmi2Error). A :class:`~harness.fmi.instance.CallFailed`
raised by a call the rule needs to work is a FAIL of the rule naming that call.

"Refused" means a status above fmi2Warning. After a refusal with fmi2Fatal no further call is
made on that instance. Outputs are "the same" when numpy.isclose(rtol=1e-9, atol=1e-12,
equal_nan=True) holds for every output at every sample.
"""
from __future__ import annotations

import math
import time
from ctypes import byref, c_double, c_int

from .common import LOGGER_VIOLATIONS, first_difference
from .fmi2 import WRONG_GUID, CallFailed, Session, status_label
from ..report import FAIL, PASS, SKIP
from ..rules import WARNING
from .fmi3 import NUMERIC

MAX_DEFAULT_STEPS = 1_000_000  # cs.default-experiment: the run stops here (and says it checked only part)
BUDGET_FRACTION = 0.5          # of the rule's timeout: cs.default-experiment's wall-time budget
OK_STATUSES = (0, 1)


def check_version(s: Session):
    fmu = s.instance("version").slave   # loaded, not instantiated
    s.trace("fmi2GetVersion")
    version = fmu.fmi2GetVersion()
    s.trace("fmi2GetTypesPlatform")
    types = fmu.fmi2GetTypesPlatform()
    problems, recommended = [], []
    if version != b"2.0":
        problems.append(f'fmi2GetVersion returned {version!r}, not "2.0"')
    if types != b"default":   # 2.1.2: "It is recommended to use this "default" definition for all binary FMUs."
        recommended.append(f'fmi2GetTypesPlatform returned {types!r}, not "default" (an importer built with the '
                           f'standard header passes arguments of other types; "default" is recommended, 2.1.2)')
    if problems:
        return FAIL, "; ".join(problems + recommended)
    if recommended:
        return FAIL, "; ".join(recommended), WARNING
    return PASS, 'fmi2GetVersion "2.0", fmi2GetTypesPlatform "default"'


def check_basic(s: Session):
    a = s.instance("basic")
    a.initialize()
    a.run(s.t0, s.steps)
    a.terminate()
    a.free()
    if s.fmi == "fmi3":
        return PASS, (f"instantiate, start values, initialization, {s.steps} doSteps of {s.h:g} s, terminate, "
                      f"freeInstance all accepted; {len(s.outputs)} outputs ({len(s.columns)} values) read")
    return PASS, (f"instantiate, setupExperiment, initialization, {s.steps} doSteps of {s.h:g} s, terminate, "
                  f"freeInstance all accepted; {len(s.outputs)} outputs read")


def check_guid(s: Session):
    """cs.guid, cs3.instantiation-token, me.guid, me3.instantiation-token."""
    what = "GUID" if s.fmi == "fmi2" else "instantiationToken"
    call = f"{s.fmi}Instantiate" + ("" if s.kind.startswith("cs") else
                                    "(fmi2ModelExchange)" if s.fmi == "fmi2" else "ModelExchange")
    a = s.instance("wrongGuid", guid=WRONG_GUID)
    if a.instantiate(raise_on_null=False):
        a.free()
        return FAIL, (f"{call} accepted the {what} {WRONG_GUID} (the modelDescription's is {s.md.guid})"
                      + (": a binary and a modelDescription.xml that do not belong together would run"
                         if s.kind.startswith("cs") else ""))
    msg = a.last_message()
    return PASS, f"{call} with a wrong {what} returned NULL" + (f' ("{msg}")' if msg else "")


def check_logger(s: Session):
    total = 0
    wrong = s.instance("wrongGuid", guid=WRONG_GUID)  # many FMUs log why they refuse
    if wrong.instantiate(raise_on_null=False):
        wrong.free()
    total += len(wrong.messages)
    a = s.instance("logger")
    a.instantiate()
    cats = s.log_categories
    a.set_debug_logging(True, cats)
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
    given = "componentEnvironment and instance name" if s.fmi == "fmi2" else "instanceEnvironment"
    return PASS, f"all {total} messages came with the {given} given"


def check_debug_logging(s: Session):
    a = s.instance("debugLogging")
    a.instantiate()
    calls = [(True, [], "on with no category (all)"), (False, [], "off")]
    if s.log_categories:
        calls.insert(0, (True, s.log_categories, f"on with the {len(s.log_categories)} declared categories"))
    results = []
    for on, cats, what in calls:
        st = a.set_debug_logging(on, cats)
        results.append((what, st))
        if st == 4:
            break
    bad = [(w, st) for w, st in results if st not in OK_STATUSES]
    if bad:
        msg = a.last_message()
        return FAIL, (f"{s.fmi}SetDebugLogging " + "; ".join(f"{w} returned {s.status_label(st)}" for w, st in bad)
                      + (f' ("{msg}")' if msg else ""))
    a.free()
    return PASS, f"{s.fmi}SetDebugLogging accepted: " + ", ".join(w for w, _ in results)


def _initial_readables(s: Session) -> list:
    seen, out = set(), []
    candidates = [u.variable for u in s.md.initialUnknowns if u.variable is not None]
    if s.fmi == "fmi3":   # 2.4.8: outputs are knowns or unknowns in Initialization Mode: all can be read
        candidates += s.outputs
        types = NUMERIC
    else:
        candidates += [v for v in s.outputs if v.initial in ("exact", "approx") or v.variability == "constant"]
        candidates += [v for v in s.variables if v.causality == "calculatedParameter"]
        types = ("Real", "Integer", "Enumeration", "Boolean")
    for v in candidates:
        if v.name not in seen and v.type in types and not getattr(v, "clocks", None):
            seen.add(v.name)
            out.append(v)
    return out


def check_initial_unknowns(s: Session):
    wanted = _initial_readables(s)
    if not wanted:
        return SKIP, "no InitialUnknowns, outputs with a start value or calculated parameters"
    a = s.instance("initialUnknowns")
    a.instantiate()
    if s.early_values:   # inputs only in Initialization Mode (2.1.6)
        a.set_values(s.early_values, " start values")
    a.setup()
    a.enter_init()
    refused = []
    for v in wanted:
        try:
            a.read([v], v.name)
        except CallFailed as e:
            refused.append(f"{v.name} ({s.status_label(e.status)})")
            if e.status == 4:
                break
    if refused:
        msg = a.last_message()
        return FAIL, (f"in initialization mode {s.fmi}Get* refused {len(refused)} of {len(wanted)}: "
                      + ", ".join(refused[:6]) + (f' ("{msg}")' if msg else ""))
    a.exit_init()
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


def _run_default_experiment(s: Session, a, budget: float | None = None, last: int | None = None):
    """Run the instance from start to stop time (at most ``last`` steps; at most ``budget`` s of wall
    time). Returns (None, t_end, n) when done or cut short, or (reason of failure, t, i) /
    ("discard", t, i) at a discarded step."""
    n = _n_steps(s)
    if last is not None:
        n = min(n, last)
    inputs = s.input_values()
    row0 = a.outputs()
    finite0 = [j for j in s.real_columns if math.isfinite(row0[j])]
    t = s.t0
    deadline = time.monotonic() + budget if budget else None
    for i in range(n):
        if inputs:
            a.set_values(inputs)
        t_next = s.t_stop if i == _n_steps(s) - 1 else s.t0 + (i + 1) * s.h
        st, terminate = a.step_result(t, t_next - t)
        if st == 2 and s.fmi == "fmi2":   # FMI 3.0 has no status calls to ask after a discard
            return "discard", t, i
        if st not in OK_STATUSES:
            msg = a.last_message()
            raise CallFailed(f"{s.fmi}DoStep(t={t:.9g}, h={t_next - t:.9g})", a.name, st, msg)
        t = t_next
        row = a.outputs()
        bad = [s.columns[j] for j in finite0 if not math.isfinite(row[j])]
        if bad:
            return f"outputs became non-finite at t = {t:g} s: {', '.join(bad[:5])}", t, i + 1
        if terminate:
            return "terminate", t, i + 1
        if deadline is not None and time.monotonic() > deadline:
            return None, t, i + 1
    return None, t, n


def _budget(s: Session) -> float:
    """Wall time the default experiment may take: half the rule's timeout (the rest is for the calls
    around it), so a slow machine checks less of the experiment instead of timing out."""
    return BUDGET_FRACTION * float(s.payload.get("timeout", 60.0))


def check_default_experiment(s: Session):
    a = s.instance("defaultExperiment")
    a.initialize(stop_time=s.t_stop)
    total = _n_steps(s)
    budget = _budget(s)
    t_start = time.monotonic()
    problem, t, n = _run_default_experiment(s, a, budget, MAX_DEFAULT_STEPS)
    took = time.monotonic() - t_start
    if problem == "terminate":
        a.terminate()
        a.free()
        return PASS, f"{n} doSteps of {s.h:g} s accepted; at t = {t:g} s the FMU asked to terminate"
    if problem == "discard":
        term = _terminated(a)
        facts = {"discard": {"how": "experiment", "step": n}}
        if term:
            a.terminate()
            a.free()
            return PASS, (f"{n} doSteps of {s.h:g} s accepted; at t = {t:g} s the FMU ended the simulation "
                          f"(fmi2Discard with fmi2Terminated = true) before the stop time {s.t_stop:g} s"), facts
        return FAIL, (f"fmi2DoStep(t={t:g}, h={s.h:g}) returned fmi2Discard before the stop time "
                      f"{s.t_stop:g} s, and the FMU does not say it terminated (fmi2Terminated "
                      f"{'false' if term is False else 'not answered'})"), facts
    if problem:
        return FAIL, problem
    a.terminate()
    a.free()
    if n < total:
        limit = (f"the step cap of {MAX_DEFAULT_STEPS}" if n >= MAX_DEFAULT_STEPS
                 else f"the time budget of {budget:g} s (half the rule's timeout)")
        return PASS, (f"checked only part of the experiment: {n} of {total} doSteps of {s.h:g} s "
                      f"(t = {s.t0:g} to {t:g} s of {s.t_stop:g} s, {took:.1f} s) accepted, outputs finite; "
                      f"stopped at {limit}")
    return PASS, (f"{n} doSteps of {s.h:g} s from {s.t0:g} to the stop time {s.t_stop:g} s accepted, outputs finite "
                  f"({took:.1f} s)")


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
    f = s.fmi
    what = f"{f}DoStep(t={stop:g}, h={s.h:g}) past the defined stop time {stop:g} s"
    msg = a.last_message()
    said = f' ("{msg}")' if msg else ""
    if st in OK_STATUSES:
        return FAIL, f"{what} returned {s.status_label(st)}{said}: the FMU has to return {f}Error"
    if st == 2:
        section = "2.1.6" if f == "fmi2" else "2.3.2"
        return FAIL, f"{what} refused with {f}Discard{said}; section {section} says {f}Error", WARNING, \
            {"discard": {"how": "stop"}}
    return PASS, f"{what} refused with {s.status_label(st)}{said}"


def _repeat_discard(s: Session, how: dict):
    """Repeat the discard another rule saw (``how`` from its facts): (instance, communication point,
    step size) right after the discarded doStep. Raises CallFailed when it does not discard again."""
    kind = how.get("how")
    if kind == "stop":
        a, st, stop = _past_stop(s, "discard")
        t, h = stop, s.h
    elif kind == "experiment":
        a = s.instance("discard")
        a.initialize(stop_time=s.t_stop)
        problem, t, _ = _run_default_experiment(s, a, last=int(how["step"]) + 1)
        st, h = (2 if problem == "discard" else 0), min(s.h, s.t_stop - t) if s.t_stop > t else s.h
    elif kind == "nan":
        a = s.instance("discard")
        a.initialize()
        h = s.h
        for i in range(int(how.get("step", 0)) + 1):   # as cs.nan-inputs: NaN before every step
            for v in s.real_inputs:
                a.set_status(v.name, math.nan)
            t = s.t0 + i * h
            st = a.step_status(t, h)
            if st != 0 and st != 1:
                break
    else:
        raise ValueError(f"unknown discard {how!r}")
    if st != 2:
        raise CallFailed(f"the discard seen before ({kind}) was not repeated: fmi2DoStep(t={t:g}, h={h:g})",
                         a.name, st)
    return a, t, h


def check_status_after_discard(s: Session):
    how = s.payload.get("discard")
    if not how:   # run alone (not through the kit's scheduler): nothing says a step was discarded
        return SKIP, "precondition not met: no discarded doStep was given to repeat"
    a, stop, h = _repeat_discard(s, how)
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
    wanted = s.outputs or [v for v in s.variables if v.type == s.REAL and v.causality != "independent"]
    if not wanted:
        return SKIP, "no variables to read"
    a = s.instance("terminated")
    a.initialize()
    a.run(s.t0, 2)
    a.terminate()
    a.read(wanted, f"after {s.fmi}Terminate")
    a.free()
    return PASS, f"{len(wanted)} variables read after {s.fmi}Terminate"


def check_reset(s: Session):
    if not s.outputs:
        return SKIP, "no outputs to compare"
    a = s.instance("reset")
    a.initialize()
    first, _ = a.run(s.t0, s.steps)
    a.reset()
    a.initialize(instantiate=False)
    second, _ = a.run(s.t0, s.steps)
    a.terminate()
    a.free()
    diff = first_difference(s, second, first)
    if diff:
        return FAIL, f"after {s.fmi}Reset the same run gives different outputs: {diff} (after reset vs first run)"
    return PASS, f"after {s.fmi}Reset the same {s.steps} steps give the same outputs"
