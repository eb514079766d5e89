"""Model-exchange rules (kinds ``me`` and ``me3``), worker side: one function per rule on either version's
session (:class:`.fmi2.Session`, :class:`.fmi3.Session3`), run in a fresh process.

``me.basic`` / ``me3.basic`` drive the FMU the way a simple importer does (FMI 2.0 section 3.2.3, the
pseudocode of 3.2.4; FMI 3.0 section 3.2): instantiate, start values, setupExperiment (stop time defined),
initialization, event iteration (fmi2NewDiscreteStates until no new discrete states are
needed), continuous-time mode, then explicit Euler steps of the DefaultExperiment stepSize (else
1e-3 s) up to its stop time: fmi2GetDerivatives, x += h dx, fmi2SetTime, fmi2SetContinuousStates,
fmi2GetEventIndicators, fmi2CompletedIntegratorStep; at a state event (an event indicator changes
sign), a time event (the step is shortened to end at nextEventTime) or when the FMU asks for one
(enterEventMode), fmi2EnterEventMode, event iteration and back to continuous-time mode. The time
grid is t += h, the last step shortened to end at the stop time: the grid of the FMU Compliance
Checker's forward Euler (``fmuCheck -k me -h h -n 0``), whose results it reproduces.
Terminate and free at the end. Every call must be accepted; states and derivatives must stay
finite. An optional ``out_csv`` in the payload receives time and the outputs after every step. FMI 3.0
names: fmi3UpdateDiscreteStates, fmi3GetContinuousStateDerivatives; a state event is an event indicator
changing its domain (FMI 2.0: changing sign).
"""
from __future__ import annotations

import math

from .fmi2 import CallFailed, Session
from ..report import FAIL, PASS, SKIP

MAX_EVENT_ITERATIONS = 100


# the calls whose names differ: FMI 2.0 name -> (FMI 3.0 call, fmpy method of each version)
CALLS = {"fmi2NewDiscreteStates": ("fmi3UpdateDiscreteStates", "newDiscreteStates", "updateDiscreteStates"),
         "fmi2GetDerivatives": ("fmi3GetContinuousStateDerivatives", "getDerivatives", "getContinuousStateDerivatives")}


def _me(a, name: str, *args):
    """The model-exchange call ``name`` (its FMI 2.0 name) in the instance's version."""
    if name in CALLS:
        label3, m2, m3 = CALLS[name]
        label, method = (name, m2) if a.s.fmi == "fmi2" else (label3, m3)
    else:
        label, method = a.s.fmi + name[4:], name[4].lower() + name[5:]
    return a.call(label, getattr(a.slave, method), *args)


def sizes(s: Session) -> tuple[int, int, list[str], list]:
    """(number of states, of event indicators, the derivatives' names, the derivative variables)."""
    ders = [u.variable for u in s.md.derivatives]
    if s.fmi == "fmi2":
        return len(ders), int(s.md.numberOfEventIndicators or 0), [v.name for v in ders], ders
    names = [f"{v.name}[{k}]" if s.size(v) > 1 else v.name for v in ders for k in range(s.size(v))]
    nz = sum(s.size(u.variable) for u in (getattr(s.md, "eventIndicators", None) or []))
    return len(names), nz, names, ders


def _crossed(s: Session, before: float, after: float) -> bool:
    """A state event: FMI 2.0 an event indicator changing sign, FMI 3.0 changing its domain (> 0 or <= 0)."""
    return before * after < 0 if s.fmi == "fmi2" else (before > 0) != (after > 0)


def _event_iteration(a) -> tuple[bool, float | None]:
    """fmi2NewDiscreteStates (fmi3UpdateDiscreteStates) until done; (terminate requested, next time event or None)."""
    for _ in range(MAX_EVENT_ITERATIONS):
        needed, terminate, _, _, defined, t_next = _me(a, "fmi2NewDiscreteStates")
        if terminate:
            return True, None
        if not needed:
            return False, (t_next if defined else None)
    raise CallFailed(f"{CALLS['fmi2NewDiscreteStates'][0] if a.s.fmi == 'fmi3' else 'fmi2NewDiscreteStates'} (still "
                     f"needed after {MAX_EVENT_ITERATIONS} iterations)", a.name, 0)


def _continuous_mode(a, x, nx: int, z, nz: int) -> None:
    """EnterContinuousTimeMode, then the states into ``x`` and the event indicators into ``z``."""
    _me(a, "fmi2EnterContinuousTimeMode")
    if nx:
        _me(a, "fmi2GetContinuousStates", x, nx)
    if nz:
        _me(a, "fmi2GetEventIndicators", z, nz)


def check_me_basic(s: Session, out_csv: str | None = None):
    from ctypes import c_double
    nx, nz, names, _ = sizes(s)
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
            _me(a, "fmi2GetDerivatives", dx, nx)
            bad = [names[i] for i in range(nx) if not math.isfinite(dx[i])]
            if bad:
                return FAIL, f"non-finite derivatives at t = {t:g} s: {', '.join(bad[:5])}"
            for i in range(nx):
                x[i] += h * dx[i]
        t = t_next
        a.call(f"{s.fmi}SetTime({t:.9g})", a.slave.setTime, t)
        if nx:
            _me(a, "fmi2SetContinuousStates", x, nx)
        state_event = False
        if nz:
            _me(a, "fmi2GetEventIndicators", z, nz)
            state_event = any(_crossed(s, z_prev[i], z[i]) for i in range(nz))
        step_event, terminated = _me(a, "fmi2CompletedIntegratorStep")
        n_steps += 1
        if not terminated and (time_event or state_event or step_event):
            n_events += 1
            _me(a, "fmi2EnterEventMode")
            terminated, t_event = _event_iteration(a)
            if not terminated:
                _continuous_mode(a, x, nx, z, nz)
        if nz:
            z_prev[:nz] = z[:nz]
        bad = [names[i] for i in range(nx) if not math.isfinite(x[i])]
        if bad:
            return FAIL, f"non-finite states at t = {t:g} s: {', '.join(bad[:5])}"
        rows.append([t] + a.outputs())
    a.terminate()
    a.free()
    if out_csv:
        from ..crosscheck.formats import write_cross_check_csv
        as_int = [v.type != s.REAL for v in s.outputs]
        write_cross_check_csv(out_csv, ["time"] + [v.name for v in s.outputs],
                              [[r[0]] + [int(x) if i else x for i, x in zip(as_int, r[1:])] for r in rows])
    how = f"the FMU asked to terminate at t = {t:g} s; " if terminated else ""
    return PASS, (f"{how}{n_steps} explicit Euler steps of {s.h:g} s from {s.t0:g} to {t:g} s, {nx} states, "
                  f"{nz} event indicators, {n_events} events: every call accepted, states finite")


def _continuous_time(s: Session, name: str):
    """An ME instance initialized and in continuous-time mode (None if the FMU asked to terminate)."""
    return _continuous_time_with(s, name, {})


def check_me_directional_derivative(s: Session):
    from ctypes import c_double
    if not s.me.providesDirectionalDerivative:
        return SKIP, "providesDirectionalDerivative is not declared"
    nx, _, _, ders = sizes(s)
    if nx == 0:
        return SKIP, "no continuous states"
    if nx != len(ders):
        return SKIP, "array states: not checked"
    states = [v.derivative for v in ders]
    a = _continuous_time(s, "jacobian")
    if a is None:
        return SKIP, "the FMU asked to terminate during initialization"
    x, dx = (c_double * nx)(), (c_double * nx)()
    _me(a, "fmi2GetContinuousStates", x, nx)
    x0 = list(x)
    worst = (0.0, "")
    for k in range(nx):
        seed = [0.0] * nx
        seed[k] = 1.0
        col = a.directional_derivative(f"derivatives, d/d {states[k].name}", [v.valueReference for v in ders],
                                       [v.valueReference for v in states], seed)
        delta = 1e-6 * max(1.0, abs(x0[k]))
        fd = []
        for sign in (1.0, -1.0):
            xs = (c_double * nx)(*x0)
            xs[k] = x0[k] + sign * delta
            _me(a, "fmi2SetContinuousStates", xs, nx)
            _me(a, "fmi2GetDerivatives", dx, nx)
            fd.append(list(dx))
        _me(a, "fmi2SetContinuousStates", (c_double * nx)(*x0), nx)
        for i in range(nx):
            approx = (fd[0][i] - fd[1][i]) / (2 * delta)
            if not math.isfinite(col[i]):
                return FAIL, f"d {ders[i].name}/d {states[k].name} is {col[i]!r}"
            err = abs(col[i] - approx) / (1.0 + abs(approx))
            if err > worst[0]:
                worst = (err, f"d {ders[i].name}/d {states[k].name}: {col[i]!r} vs central difference {approx!r}")
    a.terminate()
    a.free()
    der = "fmi2GetDerivatives" if s.fmi == "fmi2" else "fmi3GetContinuousStateDerivatives"
    if worst[0] > 1e-4:
        return FAIL, f"directional derivatives differ from central differences of {der}: {worst[1]}"
    return PASS, (f"the {nx}x{nx} state Jacobian from {s.fmi}GetDirectionalDerivative matches central differences of "
                  f"{der} (worst relative difference {worst[0]:.1e})")


def _input_candidates(s: Session, v) -> list[float]:
    """Values for the scalar Real input ``v`` other than its start value, within min/max."""
    start = s.start_values.get(v.name, 0.0)
    lo = float(v.min) if v.min is not None else -math.inf
    hi = float(v.max) if v.max is not None else math.inf
    d = 0.1 * abs(start) if start else 0.1
    return [x for x in (start + d, start - d, start + 1.0, start - 1.0) if lo <= x <= hi and x != start][:2]


def check_me_stale_outputs(s: Session):
    """me.stale-outputs, me3.stale-outputs: in continuous-time mode, after a Real input is set, every Real output
    declaring a dependency on it is read again: unchanged while an instance initialized with that input value
    gives another value there, it is stale (an integrator evaluating the outputs at the new input reads old ones)."""
    pairs: dict[str, list] = {}
    for u in s.md.outputs:
        v = u.variable
        if v is None or not s.is_real(v) or v not in s.outputs:
            continue
        for d in (u.dependencies or []):   # continuous inputs: the ones continuous-time mode lets the importer set
            if d in s.real_inputs and d.variability == "continuous":
                pairs.setdefault(d.name, []).append(v)
    if not pairs:
        return SKIP, "no Real output declares a dependency on a continuous Real input"
    col = {v.name: j for j, v in enumerate(s.outputs)}
    a = _continuous_time(s, "stale")
    if a is None:
        return SKIP, "the FMU asked to terminate during initialization"
    base = a.outputs()
    stale, followed = [], []
    for name, outs in pairs.items():
        tried = _input_candidates(s, s.by_name[name])
        if not tried:
            continue
        a.set_values({name: tried[0]})
        now = a.outputs()
        a.set_values({name: s.start_values.get(name, 0.0)})
        for o in outs:
            (stale if now[col[o.name]] == base[col[o.name]] else followed).append((o.name, name, tried[0]))
    a.terminate()
    a.free()
    confirmed = []
    for in_name in dict.fromkeys(i for _, i, _ in stale):   # insensitive here, or stale? a fresh instance tells
        value = next(x for _, i, x in stale if i == in_name)
        b = _continuous_time_with(s, "staleReference", {in_name: value})
        if b is None:
            continue
        ref = b.outputs()
        b.terminate()
        b.free()
        confirmed += [(o, i, x, ref[col[o]]) for o, i, x in stale if i == in_name and ref[col[o]] != base[col[o]]]
    mode = "continuous-time mode"
    if confirmed:
        o, i, x, r = confirmed[0]
        return FAIL, (f"in {mode} at t = {s.t0:g} s, {len(confirmed)} output(s) did not follow an input they declare a "
                      f"dependency on: after {s.fmi}Set{'Real' if s.fmi == 'fmi2' else 'Float64'}({i} = {x:g}), {o} "
                      f"is still {base[col[o]]!r}, while an instance initialized with {i} = {x:g} gives {r!r} (stale "
                      f"until the FMU is stepped)")
    if not followed:
        return PASS, f"in {mode}: no output changed with its inputs, at once or in a fresh instance (insensitive here)"
    return PASS, (f"in {mode} every output declaring a dependency on a Real input followed it at once: "
                  + ", ".join(f"{o} on {i}" for o, i, _ in followed[:6]))


def _continuous_time_with(s: Session, name: str, overrides: dict):
    """An ME instance initialized with ``overrides`` and in continuous-time mode (None if it asked to terminate)."""
    a = s.instance(name)
    a.initialize(overrides, stop_time=s.t_stop)
    terminated, _ = _event_iteration(a)
    if terminated:
        return None
    _me(a, "fmi2EnterContinuousTimeMode")
    return a


TASKS = {
    "me.basic": check_me_basic,
    "me.directional-derivative": check_me_directional_derivative,
    "me3.basic": check_me_basic,
    "me3.directional-derivative": check_me_directional_derivative,
    "me.stale-outputs": check_me_stale_outputs,
    "me3.stale-outputs": check_me_stale_outputs,
}
