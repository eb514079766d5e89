"""Model-exchange rules (kind ``me``), worker side: one function per rule, run in a fresh process.

``me.basic`` drives the FMU the way a simple importer does (FMI 2.0 section 3.2.3, the
pseudocode of 3.2.4): instantiate, start values, setupExperiment (stop time defined),
initialization, event iteration (fmi2NewDiscreteStates until no new discrete states are
needed), continuous-time mode, then explicit Euler steps of the DefaultExperiment stepSize (else
1e-3 s) up to its stop time: fmi2GetDerivatives, x += h dx, fmi2SetTime, fmi2SetContinuousStates,
fmi2GetEventIndicators, fmi2CompletedIntegratorStep; at a state event (an event indicator changes
sign), a time event (the step is shortened to end at nextEventTime) or when the FMU asks for one
(enterEventMode), fmi2EnterEventMode, event iteration and back to continuous-time mode. The time
grid is t += h, the last step shortened to end at the stop time: the grid of the FMU Compliance
Checker's forward Euler (``fmuCheck -k me -h h -n 0``), whose results it reproduces.
Terminate and free at the end. Every call must be accepted; states and derivatives must stay
finite. An optional ``out_csv`` in the payload receives time and the outputs after every step.
"""
from __future__ import annotations

import math

from .fmi2 import WRONG_GUID, CallFailed, Session, accepts_wrong_guid
from ..report import FAIL, PASS, SKIP

MAX_EVENT_ITERATIONS = 100


def _event_iteration(a) -> tuple[bool, float | None]:
    """fmi2NewDiscreteStates until done; (terminate requested, next time event or None)."""
    for _ in range(MAX_EVENT_ITERATIONS):
        needed, terminate, _, _, defined, t_next = a.call("fmi2NewDiscreteStates", a.slave.newDiscreteStates)
        if terminate:
            return True, None
        if not needed:
            return False, (t_next if defined else None)
    raise CallFailed(f"fmi2NewDiscreteStates (still needed after {MAX_EVENT_ITERATIONS} iterations)", a.name, 0)


def _continuous_mode(a, x, nx: int, z, nz: int) -> None:
    """fmi2EnterContinuousTimeMode, then the states into ``x`` and the event indicators into ``z``."""
    a.call("fmi2EnterContinuousTimeMode", a.slave.enterContinuousTimeMode)
    if nx:
        a.call("fmi2GetContinuousStates", a.slave.getContinuousStates, x, nx)
    if nz:
        a.call("fmi2GetEventIndicators", a.slave.getEventIndicators, z, nz)


def check_me_basic(s: Session, out_csv: str | None = None):
    from ctypes import c_double
    nx = len(s.md.derivatives)
    nz = int(s.md.numberOfEventIndicators or 0)
    a = s.instance("me")
    a.initialize(stop_time=s.t_stop)   # instantiate, start values, setupExperiment, initialization
    terminated, t_event = _event_iteration(a)
    x, dx = (c_double * max(1, nx))(), (c_double * max(1, nx))()
    z, z_prev = (c_double * max(1, nz))(), (c_double * max(1, nz))()
    t = s.t0
    rows = [[t] + a.outputs()]
    n_steps = n_events = 0
    if not terminated:
        _continuous_mode(a, x, nx, z_prev, nz)
    while not terminated and t < s.t_stop:
        t_next = t + s.h
        time_event = t_event is not None and t_next >= t_event
        if time_event:
            t_next = t_event
        if t_next > s.t_stop:
            t_next = s.t_stop
        h = t_next - t
        if nx:
            a.call("fmi2GetDerivatives", a.slave.getDerivatives, dx, nx)
            bad = [s.md.derivatives[i].variable.name for i in range(nx) if not math.isfinite(dx[i])]
            if bad:
                return FAIL, f"non-finite derivatives at t = {t:g} s: {', '.join(bad[:5])}"
            for i in range(nx):
                x[i] += h * dx[i]
        t = t_next
        a.call(f"fmi2SetTime({t:.9g})", a.slave.setTime, t)
        if nx:
            a.call("fmi2SetContinuousStates", a.slave.setContinuousStates, x, nx)
        state_event = False
        if nz:
            a.call("fmi2GetEventIndicators", a.slave.getEventIndicators, z, nz)
            state_event = any(z_prev[i] * z[i] < 0 for i in range(nz))
        step_event, terminated = a.call("fmi2CompletedIntegratorStep", a.slave.completedIntegratorStep)
        n_steps += 1
        if not terminated and (time_event or state_event or step_event):
            n_events += 1
            a.call("fmi2EnterEventMode", a.slave.enterEventMode)
            terminated, t_event = _event_iteration(a)
            if not terminated:
                _continuous_mode(a, x, nx, z, nz)
        if nz:
            z_prev[:nz] = z[:nz]
        bad = [s.md.derivatives[i].variable.name for i in range(nx) if not math.isfinite(x[i])]
        if bad:
            return FAIL, f"non-finite states at t = {t:g} s: {', '.join(bad[:5])}"
        rows.append([t] + a.outputs())
    a.terminate()
    a.free()
    if out_csv:
        from ..crosscheck import write_cross_check_csv
        as_int = [v.type != "Real" for v in s.outputs]
        write_cross_check_csv(out_csv, ["time"] + [v.name for v in s.outputs],
                              [[r[0]] + [int(x) if i else x for i, x in zip(as_int, r[1:])] for r in rows])
    how = f"the FMU asked to terminate at t = {t:g} s; " if terminated else ""
    return PASS, (f"{how}{n_steps} explicit Euler steps of {s.h:g} s from {s.t0:g} to {t:g} s, {nx} states, "
                  f"{nz} event indicators, {n_events} events: every call accepted, states finite")


def _continuous_time(s: Session, name: str):
    """An ME instance initialized and in continuous-time mode (None if the FMU asked to terminate)."""
    a = s.instance(name)
    a.initialize(stop_time=s.t_stop)   # instantiate, start values, setupExperiment, initialization
    terminated, _ = _event_iteration(a)
    if terminated:
        return None
    a.call("fmi2EnterContinuousTimeMode", a.slave.enterContinuousTimeMode)
    return a


def check_me_directional_derivative(s: Session):
    from ctypes import c_double
    if not s.me.providesDirectionalDerivative:
        return SKIP, "providesDirectionalDerivative is not declared"
    nx = len(s.md.derivatives)
    if nx == 0:
        return SKIP, "no continuous states"
    ders = [u.variable for u in s.md.derivatives]
    states = [v.derivative for v in ders]
    a = _continuous_time(s, "jacobian")
    if a is None:
        return SKIP, "the FMU asked to terminate during initialization"
    x, dx = (c_double * nx)(), (c_double * nx)()
    a.call("fmi2GetContinuousStates", a.slave.getContinuousStates, x, nx)
    x0 = list(x)
    worst = (0.0, "")
    for k in range(nx):
        seed = [0.0] * nx
        seed[k] = 1.0
        col = a.call(f"fmi2GetDirectionalDerivative(derivatives, d/d {states[k].name})", a.slave.getDirectionalDerivative,
                     [v.valueReference for v in ders], [v.valueReference for v in states], seed)
        delta = 1e-6 * max(1.0, abs(x0[k]))
        fd = []
        for sign in (1.0, -1.0):
            xs = (c_double * nx)(*x0)
            xs[k] = x0[k] + sign * delta
            a.call("fmi2SetContinuousStates", a.slave.setContinuousStates, xs, nx)
            a.call("fmi2GetDerivatives", a.slave.getDerivatives, dx, nx)
            fd.append(list(dx))
        a.call("fmi2SetContinuousStates", a.slave.setContinuousStates, (c_double * nx)(*x0), nx)
        for i in range(nx):
            approx = (fd[0][i] - fd[1][i]) / (2 * delta)
            if not math.isfinite(col[i]):
                return FAIL, f"d {ders[i].name}/d {states[k].name} is {col[i]!r}"
            err = abs(col[i] - approx) / (1.0 + abs(approx))
            if err > worst[0]:
                worst = (err, f"d {ders[i].name}/d {states[k].name}: {col[i]!r} vs central difference {approx!r}")
    a.terminate()
    a.free()
    if worst[0] > 1e-4:
        return FAIL, f"directional derivatives differ from central differences of fmi2GetDerivatives: {worst[1]}"
    return PASS, (f"the {nx}x{nx} state Jacobian from fmi2GetDirectionalDerivative matches central differences of "
                  f"fmi2GetDerivatives (worst relative difference {worst[0]:.1e})")


def check_me_guid(s: Session):
    if accepts_wrong_guid(s)[0]:
        return FAIL, (f"fmi2Instantiate(fmi2ModelExchange) accepted the GUID {WRONG_GUID} "
                      f"(the modelDescription's is {s.md.guid})")
    return PASS, "fmi2Instantiate(fmi2ModelExchange) with a wrong GUID returned NULL"


TASKS = {
    "me.basic": check_me_basic,
    "me.directional-derivative": check_me_directional_derivative,
    "me.guid": check_me_guid,
}
