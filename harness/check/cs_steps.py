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
            return refusal(st, a, f"fmi2DoStep with NaN on inputs {names}")
        row = a.outputs()
        bad = [s.outputs[j].name for j in real if not math.isfinite(row[j])]
        if bad:
            return PASS, f"NaN on inputs {names} shows in outputs after step {i + 1}: {', '.join(bad)}"
    if not real:
        return SKIP, f"NaN on inputs {names} was accepted, and there are no Real outputs to observe"
    return FAIL, (f"NaN written to inputs {names} was accepted and {NAN_STEPS} doSteps returned fmi2OK with "
                  f"all Real outputs finite: the NaN was silently ignored")
