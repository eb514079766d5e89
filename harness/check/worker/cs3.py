"""The co-simulation rules only FMI 3.0 has (kind ``cs3``), worker side: version, refused calls, output
derivatives, early return, event mode, intermediate update, configuration mode; one function per rule, run in
a fresh process on a :class:`~.fmi3.Session3`. The rules FMI 3.0 shares with FMI 2.0 are in
:mod:`.cs_lifecycle`, :mod:`.cs_state` and :mod:`.cs_steps`. Each returns (status, reason) or (status,
reason, severity) when a failure is milder than the rule's own severity. A :class:`~.fmi3.Call3Failed` raised
by a call the rule needs is a FAIL of the rule naming that call.
"""
from __future__ import annotations

import math
import time

from .common import first_difference
from .fmi3 import Call3Failed, Session3, status3
from ..report import FAIL, PASS, SKIP
from ..rules import WARNING

MAX_DEFAULT_STEPS = 1_000_000
BUDGET_FRACTION = 0.5


def check_version(s: Session3):
    a = s.instance("version")
    s.trace("fmi3GetVersion")
    version = a.fmu.fmi3GetVersion()
    if version != b"3.0":
        return FAIL, f'fmi3GetVersion returned {version!r}, not "3.0"'
    return PASS, 'fmi3GetVersion "3.0"'


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
    a.set_values(s.early_values, " start values")
    return _illegal(a, a.step_status(s.t0, s.h), "fmi3DoStep in Instantiated (before initialization)")


def check_zero_step_size(s: Session3):
    a = s.instance("zeroStep")
    a.initialize()
    return _illegal(a, a.step_status(s.t0, 0.0), "fmi3DoStep with communicationStepSize = 0")


# ------------------------------------------------------------------ output derivatives, early return
def _continuous_floats(s: Session3) -> list:
    return [v for v in s.outputs if v.type == "Float64" and v.variability == "continuous" and s.size(v) == 1]


def _derivative_status(a, v, order: int) -> int:
    return a.status(f"fmi3GetOutputDerivatives({v.name}, order {order})", a.fmu.getOutputDerivatives,
                    [v.valueReference], [order])


def _after_one_step(s: Session3, name: str):
    """(an instance one doStep after initialization, the continuous scalar Float64 outputs), or (None, the SKIP
    reason) when the FMU declares no output derivatives or has no such output."""
    if int(s.iface.maxOutputDerivativeOrder or 0) < 1:
        return None, "maxOutputDerivativeOrder is 0"
    outs = _continuous_floats(s)
    if not outs:
        return None, "no continuous scalar Float64 outputs"
    a = s.instance(name)
    a.initialize()
    a.run(s.t0, 1)
    return a, outs


def check_output_derivative_orders(s: Session3):
    top = int(s.iface.maxOutputDerivativeOrder or 0)
    a, outs = _after_one_step(s, "derivativeOrders")
    if a is None:
        return SKIP, outs
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
    a, outs = _after_one_step(s, "outputDerivatives")
    if a is None:
        return SKIP, outs
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
            a.set_values(s.input_values())
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
            a.set_values(s.input_values())
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


# ------------------------------------------------------------------ event mode, intermediate update, configuration
def _solo(s: Session3, name: str, before=None) -> list[list[float]]:
    """The outputs of a new instance: instantiated, ``before(instance)`` (calls in Instantiated), initialized,
    --steps doSteps; terminated and freed."""
    a = s.instance(name)
    a.instantiate()
    if before is not None:
        before(a)
    a.initialize(instantiate=False)
    rows, _ = a.run(s.t0, s.steps)
    a.terminate()
    a.free()
    return rows


def check_event_mode(s: Session3):
    """(hasEventMode) instantiated with eventModeUsed: after initialization Event Mode, fmi3UpdateDiscreteStates
    until done, fmi3EnterStepMode, the basic steps (an event signalled by a doStep: Event Mode and back); the
    outputs those of the same steps without event mode."""
    if not s.cs.hasEventMode:
        return SKIP, "hasEventMode is false"
    expected = _solo(s, "noEventMode")
    a = s.instance("eventMode")
    a.initialize(event_mode=True)
    rows, events = [], 0

    def event_iteration():
        for _ in range(100):
            needed, terminate, *_ = a.call("fmi3UpdateDiscreteStates", a.fmu.updateDiscreteStates)
            if terminate or not needed:
                return terminate
        raise Call3Failed("fmi3UpdateDiscreteStates (still needed after 100 iterations)", a.name, 0)

    if event_iteration():
        return SKIP, "the FMU asked to terminate in the first Event Mode"
    a.call("fmi3EnterStepMode", a.fmu.enterStepMode)
    rows.append(a.outputs())
    for i in range(s.steps):
        if s.inputs:
            a.set_values(s.input_values())
        t = s.t0 + i * s.h
        event, terminate, _, _ = a.call(f"fmi3DoStep(t={t:.9g}, h={s.h:.9g})", a.fmu.doStep, t, s.h, True)
        rows.append(a.outputs())
        if terminate:
            break
        if event:
            events += 1
            a.call("fmi3EnterEventMode", a.fmu.enterEventMode)
            if event_iteration():
                break
            a.call("fmi3EnterStepMode", a.fmu.enterStepMode)
    a.terminate()
    a.free()
    if events == 0 and len(rows) == len(expected):
        diff = first_difference(s, rows, expected, "after fmi3EnterStepMode")
        if diff:
            return FAIL, (f"with event mode (no event signalled) the same steps give other outputs: {diff} "
                          f"(with vs without)")
    return PASS, (f"eventModeUsed = true: Event Mode after initialization, fmi3UpdateDiscreteStates, fmi3EnterStepMode "
                  f"and {len(rows) - 1} doSteps accepted ({events} event(s) handled)"
                  + ("; outputs as without event mode" if events == 0 else ""))


def check_intermediate_update(s: Session3):
    """(providesIntermediateUpdate) every fmi3CallbackIntermediateUpdate during a doStep comes with the
    instanceEnvironment given and an intermediateUpdateTime within [t, t + h], not decreasing."""
    if not s.cs.providesIntermediateUpdate:
        return SKIP, "providesIntermediateUpdate is false"
    a = s.instance("intermediateUpdate")
    a.initialize()
    problems, n = [], 0
    for i in range(s.steps):
        if s.inputs:
            a.set_values(s.input_values())
        t = s.t0 + i * s.h
        before = len(a.updates)
        a.do_step(t, s.h)
        calls = a.updates[before:]
        n += len(calls)
        eps = 1e-9 * max(1.0, abs(t + s.h))
        last = -float("inf")
        for env, tu in calls:
            if env != a.env:
                problems.append(f"a call with instanceEnvironment {env:#x}, not {a.env:#x}")
            if not (t - eps <= tu <= t + s.h + eps):
                problems.append(f"fmi3DoStep(t={t:g}, h={s.h:g}): intermediateUpdateTime {tu!r} outside [{t:g}, "
                                f"{t + s.h:g}]")
            elif tu < last - eps:
                problems.append(f"fmi3DoStep(t={t:g}, h={s.h:g}): intermediateUpdateTime {tu!r} before {last!r}")
            last = max(last, tu)
        if problems:
            break
    a.terminate()
    a.free()
    if problems:
        return FAIL, "; ".join(problems[:3])
    if n == 0:
        return PASS, f"{s.steps} doSteps: the FMU made no intermediate update call (it may choose not to)"
    return PASS, (f"{s.steps} doSteps: all {n} intermediate update calls came with the instanceEnvironment given and "
                  f"an intermediateUpdateTime within the step")


def check_configuration_mode(s: Session3):
    """(structural parameters) fmi3EnterConfigurationMode in Instantiated, each structural parameter set to its
    start value, fmi3ExitConfigurationMode, then the basic run: accepted, outputs as without it."""
    structural = [v for v in s.variables if v.causality == "structuralParameter" and v.start is not None
                  and v.variability in ("fixed", "tunable")]
    if not structural:
        return SKIP, "no structural parameter"
    expected = _solo(s, "noConfiguration")

    def configure(a):
        a.call("fmi3EnterConfigurationMode", a.fmu.enterConfigurationMode)
        a.set_values({v.name: s.value_of(v) for v in structural}, " (structural parameters, their start values)")
        a.call("fmi3ExitConfigurationMode", a.fmu.exitConfigurationMode)
    rows = _solo(s, "configuration", configure)
    diff = first_difference(s, rows, expected)
    if diff:
        return FAIL, (f"after Configuration Mode with the structural parameters at their start values the run differs "
                      f"from one without it: {diff}")
    return PASS, (f"fmi3EnterConfigurationMode, {len(structural)} structural parameter(s) set, "
                  f"fmi3ExitConfigurationMode accepted; the {s.steps} steps after it as without")


TASKS = {
    "cs3.version": check_version,
    "cs3.step-before-init": check_step_before_init,
    "cs3.zero-step-size": check_zero_step_size,
    "cs3.output-derivative-orders": check_output_derivative_orders,
    "cs3.output-derivatives": check_output_derivatives,
    "cs3.early-return-not-allowed": check_early_return_not_allowed,
    "cs3.early-return-time": check_early_return_time,
    "cs3.event-mode": check_event_mode,
    "cs3.intermediate-update": check_intermediate_update,
    "cs3.configuration-mode": check_configuration_mode,
}
