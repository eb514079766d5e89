"""FMI 3.0 co-simulation rules (kind ``cs3``), worker side: one function per rule of :mod:`.rules3`, run in a
fresh process on a :class:`~.driver3.Session3`. Each returns (status, reason) or (status, reason, severity)
when a failure is milder than the rule's own severity. A :class:`~.driver3.Call3Failed` raised by a call
the rule needs is a FAIL of the rule naming that call (:mod:`.worker`).
"""
from __future__ import annotations

import math
import time

from .fmi3 import NUMERIC, WRONG_TOKEN, Call3Failed, Session3, first_difference3, status3
from ..report import FAIL, PASS, SKIP
from ..rules import WARNING

MAX_DEFAULT_STEPS = 1_000_000
BUDGET_FRACTION = 0.5


def check_basic(s: Session3):
    a = s.instance("basic")
    a.initialize()
    a.run(s.t0, s.steps)
    a.terminate()
    a.free()
    return PASS, (f"instantiate, start values, initialization, {s.steps} doSteps of {s.h:g} s, terminate, "
                  f"freeInstance all accepted; {len(s.outputs)} outputs ({sum(s.size(v) for v in s.outputs)} values) read")


def check_version(s: Session3):
    a = s.instance("version")
    s.trace("fmi3GetVersion")
    version = a.fmu.fmi3GetVersion()
    if version != b"3.0":
        return FAIL, f'fmi3GetVersion returned {version!r}, not "3.0"'
    return PASS, 'fmi3GetVersion "3.0"'


def check_instantiation_token(s: Session3):
    a = s.instance("wrongToken", token=WRONG_TOKEN)
    if a.instantiate(raise_on_null=False):
        a.free()
        return FAIL, (f"fmi3Instantiate accepted the instantiationToken {WRONG_TOKEN} (the modelDescription's is "
                      f"{s.md.guid}): a binary and a modelDescription.xml that do not belong together would run")
    msg = a.last_message()
    return PASS, "fmi3Instantiate with a wrong instantiationToken returned NULL" + (f' ("{msg}")' if msg else "")


def check_initial_unknowns(s: Session3):
    wanted, seen = [], set()
    for v in [u.variable for u in s.md.initialUnknowns if u.variable is not None] + s.outputs:
        if v.name not in seen and v.type in NUMERIC and not getattr(v, "clocks", None):
            seen.add(v.name)
            wanted.append(v)
    if not wanted:
        return SKIP, "no outputs or InitialUnknowns"
    a = s.instance("initialUnknowns")
    a.instantiate()
    a.set_values(s.start_vars, " start values")
    a.enter_init()
    refused = []
    for v in wanted:
        try:
            a.read([v], v.name)
        except Call3Failed as e:
            refused.append(f"{v.name} ({status3(e.status)})")
            if e.status == 4:
                break
    if refused:
        msg = a.last_message()
        return FAIL, (f"in Initialization Mode fmi3Get* refused {len(refused)} of {len(wanted)}: " + ", ".join(refused[:6])
                      + (f' ("{msg}")' if msg else ""))
    a.call("fmi3ExitInitializationMode", a.fmu.exitInitializationMode)
    a.terminate()
    a.free()
    return PASS, f"in Initialization Mode all {len(wanted)} outputs / InitialUnknowns were read"


def check_stop_time(s: Session3):
    stop = s.t0 + 2 * s.h
    a = s.instance("stopTime")
    a.initialize(stop_time=stop)
    a.run(s.t0, 2)
    if s.inputs:
        a.set_values(s.inputs)
    st = a.step_status(stop, s.h)
    what = f"fmi3DoStep(t={stop:g}, h={s.h:g}) past the defined stop time {stop:g} s"
    msg = a.last_message()
    said = f' ("{msg}")' if msg else ""
    if st in (0, 1):
        return FAIL, f"{what} returned {status3(st)}{said}: the FMU has to return fmi3Error"
    if st == 2:
        return FAIL, f"{what} refused with fmi3Discard{said}; section 2.3.2 says fmi3Error", WARNING
    return PASS, f"{what} refused with {status3(st)}{said}"


def check_get_after_terminate(s: Session3):
    if not s.outputs:
        return SKIP, "no outputs to read"
    a = s.instance("terminated")
    a.initialize()
    a.run(s.t0, 2)
    a.terminate()
    a.read(s.outputs, "after fmi3Terminate")
    a.free()
    return PASS, f"{len(s.outputs)} outputs read after fmi3Terminate"


def check_reset(s: Session3):
    if not s.outputs:
        return SKIP, "no outputs to compare"
    a = s.instance("reset")
    a.initialize()
    first, _ = a.run(s.t0, s.steps)
    a.call("fmi3Reset", a.fmu.reset)
    a.initialize(instantiate=False)
    second, _ = a.run(s.t0, s.steps)
    a.terminate()
    a.free()
    diff = first_difference3(s, second, first)
    if diff:
        return FAIL, f"after fmi3Reset the same run gives different outputs: {diff} (after reset vs first run)"
    return PASS, f"after fmi3Reset the same {s.steps} steps give the same outputs"


def check_get_set_state(s: Session3):
    if not s.iface.canGetAndSetFMUstate:
        return SKIP, "canGetAndSetFMUState is not declared"
    if not s.outputs:
        return SKIP, "no outputs to compare"
    k = max(1, s.steps // 2)
    a = s.instance("state")
    a.initialize()
    _, t_k = a.run(s.t0, k)
    saved = a.outputs()
    state = a.call("fmi3GetFMUState", a.fmu.getFMUState)
    first, _ = a.run(t_k, k)
    for n in ("first", "second"):   # 2.2.7.4: the FMU must not change the state, "to allow multiple calls"
        a.call("fmi3SetFMUState", a.fmu.setFMUState, state)
        at = first_difference3(s, [a.outputs()], [saved], f"right after fmi3SetFMUState (t = {t_k:g} s)")
        if at:
            return FAIL, f"set for the {n} time, the outputs right after fmi3SetFMUState are not the saved ones: {at}"
        diff = first_difference3(s, a.run(t_k, k)[0], first, "after the restore")
        if diff:
            return FAIL, f"set for the {n} time, the state continues differently from the original run: {diff}"
    a.call("fmi3FreeFMUState", a.fmu.freeFMUState, state)
    a.terminate()
    a.free()
    return PASS, (f"a state saved at t = {t_k:g} s and set twice gives the saved outputs and the same {k} steps "
                  f"both times")


def _illegal(a, st: int, what: str):
    """2.2.4: an FMU that detects an illegal call or argument must return fmi3Error."""
    msg = a.last_message()
    said = f' ("{msg}")' if msg else ""
    if st == 3:
        return PASS, f"{what} refused with fmi3Error{said}"
    if st == 4:
        return PASS, f"{what} refused with fmi3Fatal{said} (fmi3Error would leave the other instances usable)"
    if st == 2:
        return FAIL, f"{what} refused with fmi3Discard{said}: an FMU that detects it must return fmi3Error"
    return FAIL, (f"{what} returned {status3(st)}{said}: the call is not allowed; an FMU that detects it must "
                  f"return fmi3Error"), WARNING


def check_step_before_init(s: Session3):
    a = s.instance("early")
    a.instantiate()
    a.set_values(s.start_vars, " start values")
    return _illegal(a, a.step_status(s.t0, s.h), "fmi3DoStep in Instantiated (before initialization)")


def check_zero_step_size(s: Session3):
    a = s.instance("zeroStep")
    a.initialize()
    return _illegal(a, a.step_status(s.t0, 0.0), "fmi3DoStep with communicationStepSize = 0")


def check_default_experiment(s: Session3):
    a = s.instance("defaultExperiment")
    a.initialize(stop_time=s.t_stop)
    total = max(1, int(round((s.t_stop - s.t0) / s.h)))
    n_max = min(total, MAX_DEFAULT_STEPS)
    deadline = time.monotonic() + BUDGET_FRACTION * float(s.payload.get("timeout", 60.0))
    t, n = s.t0, 0
    floats = [j for j, x in enumerate(a.outputs()) if math.isfinite(x)]
    for i in range(n_max):
        if s.inputs:
            a.set_values(s.inputs)
        t_next = s.t_stop if i == total - 1 else s.t0 + (i + 1) * s.h
        _, terminate, _, _ = a.call(f"fmi3DoStep(t={t:.9g}, h={t_next - t:.9g})", a.fmu.doStep, t, t_next - t, True)
        t, n = t_next, i + 1
        row = a.outputs()
        bad = [j for j in floats if not math.isfinite(row[j])]
        if bad:
            return FAIL, f"outputs became non-finite at t = {t:g} s"
        if terminate:
            a.terminate()
            a.free()
            return PASS, f"{n} doSteps of {s.h:g} s accepted; at t = {t:g} s the FMU asked to terminate"
        if time.monotonic() > deadline:
            break
    a.terminate()
    a.free()
    if n < total:
        return PASS, (f"checked only part of the experiment: {n} of {total} doSteps of {s.h:g} s (t = {s.t0:g} to "
                      f"{t:g} s of {s.t_stop:g} s) accepted, outputs finite")
    return PASS, f"{n} doSteps of {s.h:g} s from {s.t0:g} to the stop time {s.t_stop:g} s accepted, outputs finite"


# ------------------------------------------------------------------ output derivatives, early return
def _continuous_floats(s: Session3) -> list:
    return [v for v in s.outputs if v.type == "Float64" and v.variability == "continuous" and s.size(v) == 1]


def _derivative_status(a, v, order: int) -> int:
    return a.status(f"fmi3GetOutputDerivatives({v.name}, order {order})", a.fmu.getOutputDerivatives,
                    [v.valueReference], [order])


def check_output_derivative_orders(s: Session3):
    top = int(s.iface.maxOutputDerivativeOrder or 0)
    if top < 1:
        return SKIP, "maxOutputDerivativeOrder is 0"
    outs = _continuous_floats(s)
    if not outs:
        return SKIP, "no continuous scalar Float64 outputs"
    a = s.instance("derivativeOrders")
    a.initialize()
    a.run(s.t0, 1)
    v = next((v for v in outs if _derivative_status(a, v, 1) <= 1), None)
    if v is None:
        return SKIP, f"no continuous Float64 output gives its first derivative (of {len(outs)})"
    for order in (0, top + 1):
        verdict = _illegal(a, _derivative_status(a, v, order), f"fmi3GetOutputDerivatives({v.name}, order {order})")
        if verdict[0] != PASS:
            return verdict
    a.terminate()
    a.free()
    return PASS, (f"fmi3GetOutputDerivatives({v.name}) with order 0 and order {top + 1} (maxOutputDerivativeOrder "
                  f"= {top}) refused with fmi3Error")


def check_output_derivatives(s: Session3):
    if int(s.iface.maxOutputDerivativeOrder or 0) < 1:
        return SKIP, "maxOutputDerivativeOrder is 0"
    outs = _continuous_floats(s)
    if not outs:
        return SKIP, "no continuous scalar Float64 outputs"
    a = s.instance("outputDerivatives")
    a.initialize()
    a.run(s.t0, 1)
    given, refused, bad = [], [], []
    for v in outs:
        if _derivative_status(a, v, 1) > 1:
            refused.append(v.name)
            continue
        x = a.call(f"fmi3GetOutputDerivatives({v.name}, order 1)", a.fmu.getOutputDerivatives,
                   [v.valueReference], [1])[0]
        (given if math.isfinite(x) else bad).append(v.name)
    a.terminate()
    a.free()
    if bad:
        return FAIL, f"non-finite first derivatives: {', '.join(bad[:6])}"
    if refused:
        return FAIL, (f"first derivatives given for {len(given)} of {len(outs)} continuous Float64 outputs, refused "
                      f"for {', '.join(refused[:6])}{' ...' if len(refused) > 6 else ''}")
    return PASS, f"first derivatives of all {len(outs)} continuous Float64 outputs given, finite"


def _experiment_steps(s: Session3):
    total = max(1, int(round((s.t_stop - s.t0) / s.h)))
    return min(total, MAX_DEFAULT_STEPS), time.monotonic() + BUDGET_FRACTION * float(s.payload.get("timeout", 60.0))


def check_early_return_not_allowed(s: Session3):
    if not s.iface.mightReturnEarlyFromDoStep:
        return SKIP, "mightReturnEarlyFromDoStep is false"
    a = s.instance("noEarlyReturn")
    a.initialize(stop_time=s.t_stop)
    n_max, deadline = _experiment_steps(s)
    t, n = s.t0, 0
    for i in range(n_max):
        if s.inputs:
            a.set_values(s.inputs)
        t = s.t0 + i * s.h
        _, terminate, early, last = a.call(f"fmi3DoStep(t={t:.9g}, h={s.h:.9g})", a.fmu.doStep, t, s.h, True)
        n = i + 1
        if early:
            return FAIL, (f"fmi3DoStep(t={t:.9g}, h={s.h:.9g}) returned earlyReturn = true (lastSuccessfulTime "
                          f"{last:.9g}) although the instance was made with earlyReturnAllowed = false")
        if terminate or time.monotonic() > deadline:
            break
    a.terminate()
    a.free()
    return PASS, f"{n} doSteps of {s.h:g} s with earlyReturnAllowed = false: none returned early"


def check_early_return_time(s: Session3):
    if not s.iface.mightReturnEarlyFromDoStep:
        return SKIP, "mightReturnEarlyFromDoStep is false"
    a = s.instance("earlyReturn")
    a.initialize(stop_time=s.t_stop, early_return=True)
    n_max, deadline = _experiment_steps(s)
    t, n, early_n, at_end = s.t0, 0, 0, 0
    while n < 4 * n_max and t < s.t_stop - 1e-9 * max(1.0, abs(s.t_stop)):
        if s.inputs:
            a.set_values(s.inputs)
        h = min(s.h, s.t_stop - t)
        _, terminate, early, last = a.call(f"fmi3DoStep(t={t:.9g}, h={h:.9g})", a.fmu.doStep, t, h, True)
        n += 1
        if early:
            early_n += 1
            # t_i <= t_{i+1} < t_i + h, to the rounding of a time the FMU sums itself (the Reference
            # BouncingBall returns early at an event on the step's end with its own t + h)
            tol = 1e-9 * max(1.0, abs(t)) + 1e-9 * h
            if not (t - tol <= last <= t + h + tol):
                return FAIL, (f"fmi3DoStep(t={t:.9g}, h={h:.9g}) returned earlyReturn = true with lastSuccessfulTime "
                              f"{last!r}, not in [t, t + h)")
            at_end += last >= t + h - tol
            t = last
        else:
            t = t + h
        if terminate or time.monotonic() > deadline:
            break
    a.terminate()
    a.free()
    if not early_n:
        return PASS, f"{n} doSteps of {s.h:g} s with earlyReturnAllowed = true: none returned early"
    return PASS, (f"{n} doSteps with earlyReturnAllowed = true: {early_n} returned early, each with lastSuccessfulTime "
                  f"in [t, t + h)" + (f" ({at_end} at t + h to rounding: an event on the step's end)" if at_end else "")
                  + ", and the doStep from there was accepted")


TASKS = {
    "cs3.basic": check_basic,
    "cs3.version": check_version,
    "cs3.instantiation-token": check_instantiation_token,
    "cs3.initial-unknowns": check_initial_unknowns,
    "cs3.stop-time": check_stop_time,
    "cs3.get-after-terminate": check_get_after_terminate,
    "cs3.reset": check_reset,
    "cs3.get-set-state": check_get_set_state,
    "cs3.step-before-init": check_step_before_init,
    "cs3.zero-step-size": check_zero_step_size,
    "cs3.default-experiment": check_default_experiment,
    "cs3.output-derivative-orders": check_output_derivative_orders,
    "cs3.output-derivatives": check_output_derivatives,
    "cs3.early-return-not-allowed": check_early_return_not_allowed,
    "cs3.early-return-time": check_early_return_time,
}
