"""Co-simulation rules (kind ``cs``), worker side: the steps and the calls around them (variable
steps, input interpolation, output and directional derivatives, refused steps and settings, NaN
inputs), one function per rule.

Conventions (what a rule returns, "refused", "the same") as in :mod:`.cs_lifecycle`.
"""
from __future__ import annotations

import math

from .driver import REFUSED, Session, perturbed, refusal
from .report import FAIL, PASS, SKIP

VARIABLE_STEP_FACTORS = (1.0, 0.5, 2.0, 0.25, 1.5, 3.0, 0.75, 1.0)
NAN_STEPS = 3


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
            return (*refusal(st, a, f"fmi2DoStep with NaN on inputs {names}"),
                    {"discard": {"how": "nan", "step": i}} if st == 2 else {})
        row = a.outputs()
        bad = [s.outputs[j].name for j in real if not math.isfinite(row[j])]
        if bad:
            return PASS, f"NaN on inputs {names} shows in outputs after step {i + 1}: {', '.join(bad)}"
    if not real:
        return SKIP, f"NaN on inputs {names} was accepted, and there are no Real outputs to observe"
    return FAIL, (f"NaN written to inputs {names} was accepted and {NAN_STEPS} doSteps returned fmi2OK with "
                  f"all Real outputs finite: the NaN was silently ignored")


def _input_candidates(v, start) -> list[float]:
    """Values to set on input ``v`` (start value ``start``) to see an output follow it: different from
    the start value, within min/max."""
    out = []
    p = perturbed(v, start)
    if p is not None:
        out.append(p)
    lo = float(v.min) if v.min is not None else -math.inf
    hi = float(v.max) if v.max is not None else math.inf
    for c in (start + 1.0, start - 1.0, 2.0 * start + 0.5):
        if lo <= c <= hi and c != start and c not in out:
            out.append(c)
    return out[:3]


def check_feedthrough(s: Session):
    if not s.real_inputs:
        return SKIP, "no Real inputs"
    pairs = {}
    for u in s.md.outputs:
        v = u.variable
        if v is None or v.type != "Real" or v not in s.outputs or not u.dependencies:
            continue
        for d in u.dependencies:
            if d in s.real_inputs:
                pairs.setdefault(d.name, []).append(v)
    if not pairs:
        return SKIP, "no Real output declares a dependency on a Real input"
    a = s.instance("feedthrough")
    a.initialize()
    _, t = a.run(s.t0, 1)
    idx = {v.name: j for j, v in enumerate(s.outputs)}
    base = a.outputs()
    stale, followed = [], []
    for name, outs in pairs.items():
        v = s.by_name[name]
        start = s.start_values.get(name, 0.0)
        seen = set()
        tried = _input_candidates(v, start)
        for value in tried:
            a.set_values({name: value})
            now = a.outputs()
            seen |= {o.name for o in outs if not (now[idx[o.name]] == base[idx[o.name]]
                                                   or (math.isnan(now[idx[o.name]]) and math.isnan(base[idx[o.name]])))}
            a.set_values({name: start})
        for o in outs:
            (followed if o.name in seen else stale).append((o.name, name, tried))
    if stale:
        out_name, in_name, tried = stale[0]
        # does the next doStep show the change? (then the output was stale, not insensitive)
        a.set_values({in_name: tried[0]} if tried else {})
        a.do_step(t, s.h)
        after = a.outputs()[idx[out_name]]
        later = (f"; after the next doStep it is {after!r}" if after != base[idx[out_name]] else
                 "; it did not change after the next doStep either (insensitive here, or stale)")
        listed = ", ".join(f"{o} (on {i})" for o, i, _ in stale[:5])
        return FAIL, (f"at t = {t:g} s, {len(stale)} output(s) declaring a dependency on an input did not change "
                      f"when the input was set to {', '.join(f'{x:g}' for x in tried)}: {listed}; "
                      f"{out_name} stayed {base[idx[out_name]]!r}{later}")
    return PASS, (f"at t = {t:g} s every output declaring a dependency on a Real input followed it at once: "
                  + ", ".join(f"{o} on {i}" for o, i, _ in followed[:6]))


CLOCK_FRACTION = 0.6180339887498949   # steps of 0.618 h and 1.382 h: neither a multiple of the other, nor of h


def check_clock(s: Session):
    if not s.cs.canHandleVariableCommunicationStepSize:
        return SKIP, "canHandleVariableCommunicationStepSize is not declared (only uniform steps are allowed)"
    real = [j for j, v in enumerate(s.outputs) if v.type == "Real"]
    if not real:
        return SKIP, "no Real outputs"
    import numpy as np
    h = s.h
    pairs = max(1, min(max(2, s.steps // 2), int((s.t_stop - s.t0) / (2 * h) + 1e-9)))
    a_step = CLOCK_FRACTION * h

    def run(name, sizes, every):
        inst = s.instance(name)
        inst.initialize()
        rows, t_end = inst.run(s.t0, sizes)
        inst.terminate()
        inst.free()
        return np.asarray(rows, dtype=float)[::every][:, real], t_end

    uniform, t_u = run("clockUniform", [h] * (2 * pairs), 2)
    double, _ = run("clockDouble", [2 * h] * pairs, 1)
    mixed, t_m = run("clockMixed", [a_step, 2 * h - a_step] * pairs, 2)
    with np.errstate(invalid="ignore"):
        d_ref = np.nanmax(np.abs(double - uniform), axis=0)
        d = np.nanmax(np.abs(mixed - uniform), axis=0)
        scale = np.nanmax(np.abs(uniform), axis=0)
    allowed = 2.0 * d_ref + 10.0 * s.tolerance * scale + 1e-12
    bad = [(k, float(d[k]), float(allowed[k])) for k in range(len(real)) if not d[k] <= allowed[k]]
    grid = f"{2 * pairs} steps of {h:g} s vs {2 * pairs} alternating steps of {a_step:.4g} s and {2 * h - a_step:.4g} s"
    if bad:
        k, dk, ak = max(bad, key=lambda x: x[1] / max(x[2], 1e-300))
        i = int(np.nanargmax(np.abs(mixed[:, k] - uniform[:, k])))
        name = s.outputs[real[k]].name
        return FAIL, (f"{grid} to t = {t_m:g} s: {name} at t = {s.t0 + 2 * h * i:g} s is {float(mixed[i, k])!r} against "
                      f"{float(uniform[i, k])!r} with uniform steps (difference {dk:.3g}, allowed {ak:.3g}: twice the "
                      f"difference between uniform steps of {h:g} and {2 * h:g} s, plus {10 * s.tolerance:g} of its "
                      f"magnitude): the FMU does not integrate to currentCommunicationPoint + communicationStepSize")
    return PASS, (f"{grid}: the outputs at every common communication point agree within twice the difference "
                  f"between uniform steps of {h:g} and {2 * h:g} s (largest {float(np.nanmax(d)):.3g})")
