"""Co-simulation rules (kinds ``cs`` and ``cs3``), worker side: the steps and the calls around them (variable
steps, the clock, input interpolation, output and directional derivatives, refused steps and settings, NaN
inputs), one function per rule; variable steps, the clock and directional derivatives on either version's
session.

Conventions (what a rule returns, "refused", "the same") as in :mod:`.cs_lifecycle`.
"""
from __future__ import annotations

import math

from .common import perturbed
from .fmi2 import REFUSED, Session, refusal
from ..report import FAIL, PASS, SKIP

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
    finite0 = [j for j in s.real_columns if math.isfinite(rows[0][j])]
    for i, row in enumerate(rows[1:], 1):
        bad = [s.columns[j] for j in finite0 if not math.isfinite(row[j])]
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
    unknowns = [v for v in s.outputs if s.is_real(v)]
    knowns = s.real_inputs
    a = s.instance("directionalDerivative")
    if unknowns and knowns:  # after initialization: outputs with respect to the inputs
        a.initialize()
        a.run(s.t0, 1)
        what = "after a step"
    else:  # in initialization mode: the InitialUnknowns with respect to their dependencies
        initial = [u for u in s.md.initialUnknowns if u.variable is not None and s.is_real(u.variable)
                   and u.dependencies]
        unknowns = [u.variable for u in initial]
        seen, knowns = set(), []
        for u in initial:
            for d in u.dependencies:
                if s.is_real(d) and d.name not in seen:
                    seen.add(d.name)
                    knowns.append(d)
        if not unknowns or not knowns:
            return SKIP, "no Real inputs, and no InitialUnknowns with Real dependencies"
        a.instantiate()
        if s.early_values:   # inputs only in Initialization Mode (2.1.6)
            a.set_values(s.early_values, " start values")
        a.setup()
        a.enter_init()
        what = "in initialization mode"
    bad = []
    for k, known in enumerate(knowns):
        seed = [0.0] * len(knowns)
        seed[k] = 1.0
        values = a.directional_derivative(f"{what}, d/d {known.name}", [v.valueReference for v in unknowns],
                                          [v.valueReference for v in knowns], seed)
        bad += [f"d {v.name}/d {known.name}" for v, x in zip(unknowns, values) if not math.isfinite(x)]
    if bad:
        return FAIL, f"non-finite directional derivatives {what}: {', '.join(bad[:5])}"
    a.free()
    return PASS, (f"{what}: derivatives of {', '.join(v.name for v in unknowns[:4])} with respect to "
                  f"{', '.join(v.name for v in knowns[:4])} given, finite")


def check_step_before_init(s: Session):
    a = s.instance("early")
    a.instantiate()
    if s.early_values:   # inputs only in Initialization Mode (2.1.6)
        a.set_values(s.early_values, " start values")
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
    confirmed, insensitive = [], []
    for in_name in dict.fromkeys(i for _, i, _ in stale):   # stale, or insensitive here? one more step tells
        outs = [o for o, i, _ in stale if i == in_name]
        tried = next(t for _, i, t in stale if i == in_name)
        if not tried:
            insensitive += outs
            continue
        after = {}
        for name, value in (("feedthroughNew", tried[0]), ("feedthroughOld", None)):
            b = s.instance(name)
            b.initialize()
            b.run(s.t0, 1)
            inputs = s.input_values()
            if value is not None:
                inputs[in_name] = value
            b.run(t, 1, inputs)
            after[name] = b.outputs()
            b.terminate()
            b.free()
        for o in outs:
            j = idx[o]
            if after["feedthroughNew"][j] != after["feedthroughOld"][j]:
                confirmed.append((o, in_name, tried, after["feedthroughNew"][j]))
            else:
                insensitive.append(o)
    a.terminate()
    a.free()
    if confirmed:
        out_name, in_name, tried, later = confirmed[0]
        listed = ", ".join(f"{o} (on {i})" for o, i, _, _ in confirmed[:5])
        return FAIL, (f"at t = {t:g} s, {len(confirmed)} output(s) declaring a dependency on an input did not change "
                      f"when the input was set to {', '.join(f'{x:g}' for x in tried)}: {listed}; {out_name} stayed "
                      f"{base[idx[out_name]]!r}, and only after the next doStep it is {later!r} (with the old input "
                      f"it would be otherwise): stale until the next step")
    note = (f"; {', '.join(insensitive[:4])} did not change with the input, at once or after the next step either "
            f"(insensitive here)" if insensitive else "")
    if not followed:
        return PASS, f"at t = {t:g} s " + note[2:]
    return PASS, (f"at t = {t:g} s every output declaring a dependency on a Real input and changing with it "
                  f"followed it at once: " + ", ".join(f"{o} on {i}" for o, i, _ in followed[:6]) + note)


CLOCK_FRACTION = 0.6180339887498949   # each step h split into 0.618 h and 0.382 h: not multiples of each other


def check_clock(s: Session):
    if not s.cs.canHandleVariableCommunicationStepSize:
        return SKIP, "canHandleVariableCommunicationStepSize is not declared (only uniform steps are allowed)"
    real = s.real_columns
    if not real:
        return SKIP, "no Real outputs"
    import numpy as np
    h = s.h
    n = max(2, min(s.steps, int((s.t_stop - s.t0) / h + 1e-9)))   # communication points compared: n
    n -= n % 2
    a = CLOCK_FRACTION * h

    def run(name, sizes, every):
        inst = s.instance(name)
        inst.initialize()
        rows, _ = inst.run(s.t0, sizes)
        inst.terminate()
        inst.free()
        return np.asarray(rows, dtype=float)[::every][:, real]

    uniform = run("clockUniform", [h] * n, 1)             # rows at t0 + k h, k = 0..n
    split = run("clockSplit", [a, h - a] * n, 2)          # the same points, each step split in two
    double = run("clockDouble", [2 * h] * (n // 2), 1)    # every second point
    half = run("clockHalf", [h / 2] * (2 * n), 2)         # the same points, halved steps
    with np.errstate(invalid="ignore"):
        scale = np.nanmax(np.abs(uniform), axis=0)
        moved = np.nanmax(np.abs(uniform - uniform[0]), axis=0) > 1e-12 * (1.0 + scale)
        stuck = moved & (np.nanmax(np.abs(half - half[0]), axis=0) == 0.0)
        d_ref = np.maximum(np.nanmax(np.abs(double - uniform[::2]), axis=0), np.nanmax(np.abs(half - uniform), axis=0))
        d = np.nanmax(np.abs(split - uniform), axis=0)
    grid = f"{n} steps of {h:g} s against the same steps split into {a:.4g} s + {h - a:.4g} s"
    if stuck.any():
        k = int(np.argmax(stuck))
        name = s.columns[real[k]]
        return FAIL, (f"{name} changes with steps of {h:g} s but not at all with steps of {h / 2:g} s (it stays "
                      f"{float(half[0, k])!r} to t = {s.t0 + n * h:g} s): the FMU ignores steps shorter than its own "
                      f"and does not integrate to currentCommunicationPoint + communicationStepSize")
    allowed = 2.0 * d_ref + 10.0 * s.tolerance * scale + 1e-12
    bad = [(k, float(d[k]), float(allowed[k])) for k in range(len(real)) if not d[k] <= allowed[k]]
    if bad:
        k, dk, ak = max(bad, key=lambda x: x[1] / max(x[2], 1e-300))
        i = int(np.nanargmax(np.abs(split[:, k] - uniform[:, k])))
        name = s.columns[real[k]]
        return FAIL, (f"{grid}: {name} at t = {s.t0 + h * i:g} s is {float(split[i, k])!r} against "
                      f"{float(uniform[i, k])!r} (difference {dk:.3g}, allowed {ak:.3g}: twice the largest difference "
                      f"of uniform steps of {h:g} s from steps of {2 * h:g} and {h / 2:g} s, plus {10 * s.tolerance:g} "
                      f"of its magnitude): the FMU does not integrate to currentCommunicationPoint + "
                      f"communicationStepSize")
    return PASS, (f"{grid}: the outputs at every communication point agree within twice the difference between "
                  f"uniform steps of {h:g} s and of {2 * h:g} or {h / 2:g} s (largest {float(np.nanmax(d)):.3g})")
