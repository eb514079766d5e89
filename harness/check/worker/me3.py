"""FMI 3.0 model-exchange rules (kind ``me3``), worker side: one function per rule, run in a fresh process.

``me3.basic`` drives the FMU the way a simple importer does (3.2 and the common states of 2.3): instantiate,
start values, Initialization Mode (stop time defined), Event Mode with fmi3UpdateDiscreteStates until no
update is needed, Continuous-Time Mode, then explicit Euler steps of the DefaultExperiment stepSize (else
1e-3 s) up to its stop time: fmi3GetContinuousStateDerivatives, x += h dx, fmi3SetTime,
fmi3SetContinuousStates, fmi3GetEventIndicators, fmi3CompletedIntegratorStep; at a state event (an event
indicator changes its domain), a time event (the step shortened to end at nextEventTime) or a step event,
fmi3EnterEventMode, event iteration and back. Terminate and free at the end.
"""
from __future__ import annotations

import math
from ctypes import c_double

from .fmi3 import WRONG_TOKEN, Call3Failed, Session3
from ..report import FAIL, PASS

MAX_EVENT_ITERATIONS = 100


def _event_iteration(a) -> tuple[bool, float | None]:
    """fmi3UpdateDiscreteStates until done; (terminate requested, next time event or None)."""
    for _ in range(MAX_EVENT_ITERATIONS):
        needed, terminate, _, _, defined, t_next = a.call("fmi3UpdateDiscreteStates", a.fmu.updateDiscreteStates)
        if terminate:
            return True, None
        if not needed:
            return False, (t_next if defined else None)
    raise Call3Failed(f"fmi3UpdateDiscreteStates (still needed after {MAX_EVENT_ITERATIONS} iterations)", a.name, 0)


def check_me_basic(s: Session3):
    ders = [u.variable for u in s.md.derivatives]
    nx = sum(s.size(v) for v in ders)
    nz = sum(s.size(u.variable) for u in (getattr(s.md, "eventIndicators", None) or []))
    a = s.instance("me")
    a.initialize(stop_time=s.t_stop)
    terminated, t_event = _event_iteration(a)
    x, dx = (c_double * max(1, nx))(), (c_double * max(1, nx))()
    z, z_prev = (c_double * max(1, nz))(), (c_double * max(1, nz))()
    names = [f"{v.name}[{k}]" if s.size(v) > 1 else v.name for v in ders for k in range(s.size(v))]

    def continuous(zbuf):
        a.call("fmi3EnterContinuousTimeMode", a.fmu.enterContinuousTimeMode)
        if nx:
            a.call("fmi3GetContinuousStates", a.fmu.getContinuousStates, x, nx)
        if nz:
            a.call("fmi3GetEventIndicators", a.fmu.getEventIndicators, zbuf, nz)

    t, n_steps, n_events = s.t0, 0, 0
    if not terminated:
        continuous(z_prev)
    while not terminated and t < s.t_stop:
        t_next = min(t + s.h, s.t_stop)
        time_event = t_event is not None and t_next >= t_event
        if time_event:
            t_next = t_event
        h = t_next - t
        if nx:
            a.call("fmi3GetContinuousStateDerivatives", a.fmu.getContinuousStateDerivatives, dx, nx)
            bad = [names[i] for i in range(nx) if not math.isfinite(dx[i])]
            if bad:
                return FAIL, f"non-finite derivatives at t = {t:g} s: {', '.join(bad[:5])}"
            for i in range(nx):
                x[i] += h * dx[i]
        t = t_next
        a.call(f"fmi3SetTime({t:.9g})", a.fmu.setTime, t)
        if nx:
            a.call("fmi3SetContinuousStates", a.fmu.setContinuousStates, x, nx)
        state_event = False
        if nz:
            a.call("fmi3GetEventIndicators", a.fmu.getEventIndicators, z, nz)
            state_event = any((z_prev[i] > 0) != (z[i] > 0) for i in range(nz))
        step_event, terminated = a.call("fmi3CompletedIntegratorStep", a.fmu.completedIntegratorStep)
        n_steps += 1
        if not terminated and (time_event or state_event or step_event):
            n_events += 1
            a.call("fmi3EnterEventMode", a.fmu.enterEventMode)
            terminated, t_event = _event_iteration(a)
            if not terminated:
                continuous(z)
        if nz:
            z_prev[:nz] = z[:nz]
        bad = [names[i] for i in range(nx) if not math.isfinite(x[i])]
        if bad:
            return FAIL, f"non-finite states at t = {t:g} s: {', '.join(bad[:5])}"
        a.outputs()
    a.terminate()
    a.free()
    how = f"the FMU asked to terminate at t = {t:g} s; " if terminated else ""
    return PASS, (f"{how}{n_steps} explicit Euler steps of {s.h:g} s from {s.t0:g} to {t:g} s, {nx} states, "
                  f"{nz} event indicators, {n_events} events: every call accepted, states finite")


def check_me_instantiation_token(s: Session3):
    a = s.instance("wrongToken", token=WRONG_TOKEN)
    if a.instantiate(raise_on_null=False):
        a.free()
        return FAIL, (f"fmi3InstantiateModelExchange accepted the instantiationToken {WRONG_TOKEN} (the "
                      f"modelDescription's is {s.md.guid})")
    return PASS, "fmi3InstantiateModelExchange with a wrong instantiationToken returned NULL"


TASKS = {
    "me3.basic": check_me_basic,
    "me3.instantiation-token": check_me_instantiation_token,
}
