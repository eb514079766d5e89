"""Every output derivative the differential declares (FMI 3.0 ``maxOutputDerivativeOrder = 1``: the
outputs :func:`spurdiff.fmi.differential_fmu.output_rates` answers, which fmi3GetOutputDerivatives
passes on unchanged, tests/fmus/test_fmu3_features.py) checked one variable at a time against
central differences of that output (issue 47 item 4), the suns' speeds and angles included.

The difference: from the state saved at ``t``, the model steps by ``H - d`` and ``H + d`` with the
inputs held (what it does in a communication step), so ``(y(H + d) - y(H - d)) / 2d`` tends to the
rate at the end of a step of ``H``, the point the FMU's derivative is for. Richardson with ``d`` and
``d/2`` gives ``R = (4 D(d/2) - D(d)) / 3``; the tolerance follows from the step: the truncation
estimate ``|D(d/2) - D(d)| / 3`` (central differences: ``O(d^2)``; R's own error is smaller), plus the
rounding of the outputs divided by the step (``64 eps |y| / d``) and, for the mesh level, its
integrator's tolerance likewise (``16 tol |y| / d``). Each derivative must also be far from the wrong
one it would be with its sign flipped, so a sign error (the right sun's acceleration, planted once:
``ac - lam ad`` in derivatives.sun_accelerations) fails here directly.

The half-shafts' outputs (shaftCoupling = wheel) need the wheel side continued between steps; they are
checked against differences over consecutive steps in tests/fmus/test_fmu3_features.py.
"""
from __future__ import annotations

import math

import pytest

from spurdiff.fmi import differential_fmu as D

EPS = 2.220446049250313e-16
TORQUE = {"shaftCoupling": "torque", "carrierDrive": "torque", "carrier.tau": 200.0, "J_carrier": 2.0,
          "left.tau": -120.0, "right.tau": -60.0, "differential.w_start": 0.5, "carrier.w_start": 5.0}
SPEED = {"shaftCoupling": "torque", "carrierDrive": "speed", "carrier.w": 5.0, "left.tau": -150.0,
         "right.tau": -40.0, "differential.w_start": 0.5, "carrier.w_start": 5.0}
CASES = {   # name: (parameters, communication step H, difference step d, integrator tolerance or 0)
    "rigid-torque-drive": (TORQUE, 1e-4, 1e-4 / 16, 0.0),
    "rigid-speed-drive": (SPEED, 1e-4, 1e-4 / 16, 0.0),
    "rigid-stuck": ({**TORQUE, "differential.w_start": 0.0, "left.tau": -100.0, "right.tau": -100.0}, 1e-4,
                    1e-4 / 16, 0.0),
    # the mesh modes (kHz) make the third derivative large: a smaller d
    "compliant-torque-drive": ({**TORQUE, "meshModel": "compliant", "tolerance": 1e-12}, 1e-4, 1e-4 / 256, 1e-12),
}
# the outputs with a declared derivative that do not need the half-shafts
SUN_AND_CARRIER = ("carrier.w", "carrier.phi", "left.w", "left.phi", "right.w", "right.phi")


def model_of(values: dict):
    v = {x.name: x.start for x in D.VARIABLES}
    v.update(values)
    return D.build_model(v)


def declared(model) -> dict[str, str]:
    """{output name: attribute} of every output whose derivative the interface gives for ``model``."""
    rates = D.output_rates(model)
    return {v.name: v.bind for v in D.VARIABLES if v.causality == "output" and v.bind in rates}


def differences(case: str):
    """(rates at the end of a step of H, {output: (R, tolerance, |D(d/2)|)}) for every declared output."""
    values, H, d, itol = CASES[case]
    m = model_of(values)
    t = 0.0
    for _ in range(5):
        m.do_step(t, H)
        t += H
    saved = m.get_state()

    def end_of(h: float) -> dict:
        m.set_state(saved)
        m.do_step(t, h)
        return {n: float(getattr(m, b)) for n, b in names.items()}

    names = declared(m)
    m.set_state(saved)
    m.do_step(t, H)
    rates = {n: float(D.output_rates(m)[b]) for n, b in names.items()}
    ys = {k: end_of(H + k * d / 2.0) for k in (-2, -1, 1, 2)}
    out = {}
    for n in names:
        D1 = (ys[2][n] - ys[-2][n]) / (2.0 * d)
        D2 = (ys[1][n] - ys[-1][n]) / d
        R = (4.0 * D2 - D1) / 3.0
        y = max(abs(ys[k][n]) for k in ys)
        tol = abs(D2 - D1) / 3.0 + (64.0 * EPS + 16.0 * itol) * y / (d / 2.0)
        out[n] = (R, tol, abs(D2))
    return rates, out


@pytest.mark.parametrize("case", list(CASES))
def test_every_declared_derivative_is_the_limit_of_central_differences(case):
    rates, fd = differences(case)
    assert set(SUN_AND_CARRIER) <= set(rates)   # the suns' and the carrier's speeds and angles are declared
    for n, (R, tol, size) in fd.items():
        assert abs(R - rates[n]) <= tol, (n, rates[n], R, tol)
        # the check can tell the derivative from its opposite (unless it is 0 to the tolerance)
        if abs(rates[n]) > 2.0 * tol:
            assert abs(R + rates[n]) > tol, n


def test_the_tolerances_are_tight_enough_to_see_a_sign_error_of_each_sun():
    """In the slipping rigid case both suns accelerate (a_L = a_c + a_d, a_R = a_c + lam a_d with a_d
    not 0): a flipped sign of a_d in either moves the derivative by far more than the tolerance."""
    rates, fd = differences("rigid-torque-drive")
    m = model_of(TORQUE)
    m.do_step(0.0, 1e-4)
    ac, ad, lam = m.ac, m.ad, m.lam
    assert abs(ad) > 1.0 and lam != 0.0
    for n, wrong in (("left.w", ac - ad), ("right.w", ac - lam * ad)):
        R, tol, _ = fd[n]
        assert abs(wrong - R) > 1e6 * tol, (n, wrong, R, tol)
    for n in ("left.w", "right.w", "carrier.w"):
        assert fd[n][1] <= 1e-8 * max(1.0, abs(rates[n])), (n, fd[n])   # rounding-level for the rigid level


def test_the_compliant_levels_sun_accelerations_come_from_its_right_hand_side():
    rates, fd = differences("compliant-torque-drive")
    for n in ("left.w", "right.w", "carrier.w"):
        R, tol, _ = fd[n]
        assert tol <= 1e-3 * abs(rates[n]), (n, tol, rates[n])     # the check is not vacuous
        assert math.isfinite(rates[n]) and abs(R - rates[n]) <= tol
