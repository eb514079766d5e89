"""The 3-D pin law (issue 41): each planet a rigid body on a journal, its mesh forces at their axial
positions; friction load |R_0| + |R_L| (end reactions, default) or the linear pressure integral.
Hand calculations, an independent solve of the break-away, and the planar law as the limit."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import fsolve

from spurdiff.differential.locking import breakaway, locking_coefficients, pin_friction
from spurdiff.differential.params import DifferentialParams
from spurdiff.differential.rigid import RigidDifferential
from spurdiff.errors import ParameterError
from spurdiff.gears.design import derive
from spurdiff.gears.geometry import GearTable
from spurdiff.gears.layout import PinLayout, linear_pressure_load

# A hand-made pair: planet 2's sun mesh force +F x at 3/4 of its journal, its planet mesh force -F x
# at 1/4 (tangential parts only): a pure couple F L / 2, no net force.
_VEC = ((0.0, 1.0), (0.0, 0.0), (0.0, -1.0), (0.0, 0.0),     # planet 1 (both in its middle)
        (1.0, 0.0), (0.0, 0.0), (-1.0, 0.0), (0.0, 0.0))     # planet 2


def _hand(model: str) -> PinLayout:
    return PinLayout(0.0, _VEC, ((0.5, 0.5, 0.5), (0.75, 0.25, 0.5)), model)


def test_pure_couple_by_hand():
    F = 1000.0
    # moments about end 0: R_L L = F (3/4 L) - F (1/4 L) -> R_L = F / 2 (x), R_0 = -F / 2
    assert _hand("endReactions").end_reactions(1, F, F) == pytest.approx((-500.0, 0.0, 500.0, 0.0), abs=1e-12)
    # end reactions: |R_0| + |R_L| = F (the planar law: |F_pin| = 0)
    assert _hand("endReactions").pin_force(1, F, F)[0] == pytest.approx(F, rel=1e-15)
    assert _hand("planar").pin_force(1, F, F)[0] == 0.0
    # linear pressure, pure couple M = F L / 2: q(z) = q0 (1 - 2 z / L), moment q0 L^2 / 6 = M ->
    # q0 = 3 F / L, int |q| dz = q0 L / 2 = 1.5 F
    assert _hand("linearPressure").pin_force(1, F, F)[0] == pytest.approx(1.5 * F, rel=1e-12)
    # planet 1 is planar: every model gives |F_1| = 2 F (both forces along y, the same way)
    for model in ("endReactions", "linearPressure", "planar"):
        assert _hand(model).pin_force(0, F, -F)[0] == pytest.approx(2 * F, rel=1e-15)


def test_end_reactions_with_a_net_force_by_hand():
    """Sun mesh +F x at 3/4 L, planet mesh force 0.5 F (times -x) at 1/4 L: R_L = 3/4 F - 1/8 F = 5/8 F,
    R_0 = 1/4 F - 3/8 F = -1/8 F; friction load 3/4 F (net force 1/2 F)."""
    lay = _hand("endReactions")
    F = 800.0
    assert lay.end_reactions(1, F, 0.5 * F) == pytest.approx((-100.0, 0.0, 500.0, 0.0), abs=1e-12)
    assert lay.pin_force(1, F, 0.5 * F)[0] == pytest.approx(600.0, rel=1e-15)
    # linear pressure: q(0) L = 4 R_0 - 2 R_L = -1400, q(L) L = 4 R_L - 2 R_0 = 2200 (N), zero at
    # t = 1400 / 3600: int |q| = (1400 * 1400 / 3600 + 2200 * 2200 / 3600) / 2 = 944.44 N
    assert _hand("linearPressure").pin_force(1, F, 0.5 * F)[0] == pytest.approx(
        (1400 ** 2 + 2200 ** 2) / 3600 / 2, rel=1e-12)


@pytest.mark.parametrize("seed", range(6))
def test_linear_pressure_closed_form_against_quadrature(seed):
    rng = np.random.default_rng(seed)
    R = rng.normal(size=4) * 1000.0
    t = np.linspace(0.0, 1.0, 400001)
    A = np.array([4 * R[0] - 2 * R[2], 4 * R[1] - 2 * R[3]])
    B = np.array([4 * R[2] - 2 * R[0], 4 * R[3] - 2 * R[1]])
    q = np.hypot(A[0] * (1 - t) + B[0] * t, A[1] * (1 - t) + B[1] * t)
    assert linear_pressure_load(*R) == pytest.approx(np.trapezoid(q, t), rel=1e-8)
    # never below the end reactions' load (which is the lower bound of any distribution)
    assert linear_pressure_load(*R) >= math.hypot(R[0], R[1]) + math.hypot(R[2], R[3]) - 1e-9


def test_planar_law_reproduced_exactly():
    """pinModel = planar, and the end reactions when every load of each planet lies in one plane,
    give the K of the planar law (0.1779 drive / 0.2106 coast for the paper's pins) bit for bit."""
    geo = derive()
    planar = locking_coefficients(pin_friction(geo, 0.26, 0.012, pin_model="planar"))
    assert planar == (0.17789422667429886, 0.2106388602738491)
    t = GearTable().with_gear("planet2", b=0.022).with_gear("sunB", axialStart=0.001)   # all in one plane
    geo1 = derive(t)
    assert locking_coefficients(pin_friction(geo1, 0.26, 0.012, pin_model="endReactions")) == planar
    assert locking_coefficients(pin_friction(geo1, 0.26, 0.012, pin_model="linearPressure")) == planar


def _independent_K(geo, mu, r_d, model, T0, s):
    """Break-away solved with scipy from the moment balances, the pin loads from the end reactions."""
    pf = pin_friction(geo, mu, r_d, pin_model="planar")
    lay3 = PinLayout.of(geo, model)
    rbA, rb1, rbB, rb2 = pf.rb
    n = pf.n
    sg1, sg2 = math.copysign(1.0, pf.rho[0]) * s, math.copysign(1.0, pf.rho[1]) * s

    def load(i, Fs, F12):
        R = lay3.end_reactions(i, Fs, F12)
        if model == "linearPressure":
            return linear_pressure_load(*R)
        return math.hypot(R[0], R[1]) + math.hypot(R[2], R[3])

    def res(x):
        D, F12 = x[0] * T0, x[1] * T0 / (n * (rbA + rbB))
        FA, FB = (T0 + D) / (2 * n * rbA), (T0 - D) / (2 * n * rbB)
        return [(rb1 * (FA - F12) - sg1 * mu * r_d * load(0, FA, F12)) / (rb1 * abs(FA)),
                (rb2 * (FB - F12) - sg2 * mu * r_d * load(1, FB, F12)) / (rb2 * abs(FB))]

    x = fsolve(res, [-s * 0.2 * math.copysign(1.0, T0), 1.0], xtol=1e-13)
    return abs(x[0])


@pytest.mark.parametrize("model", ["endReactions", "linearPressure"])
def test_K_against_an_independent_solve(model):
    geo = derive()
    pf = pin_friction(geo, 0.26, 0.012, pin_model=model)
    for T0 in (1000.0, -1000.0):
        for s in (1.0, -1.0):
            assert breakaway(pf, T0, s).K == pytest.approx(_independent_K(geo, 0.26, 0.012, model, T0, s), rel=1e-7)
    Kd, Kc = locking_coefficients(pf)
    # the review's estimates (issue 41): drive 0.231 (end reactions) / 0.272 (linear), coast 0.219 .. 0.234
    if model == "endReactions":
        assert (round(Kd, 4), round(Kc, 4)) == (0.2326, 0.2182)
    else:
        assert (round(Kd, 4), round(Kc, 4)) == (0.2735, 0.2312)


def test_handedness_swaps_drive_and_coast():
    geo = derive()
    for model in ("planar", "endReactions", "linearPressure"):
        lead = locking_coefficients(pin_friction(geo, 0.26, 0.012, pin_model=model, handedness="leading"))
        trail = locking_coefficients(pin_friction(geo, 0.26, 0.012, pin_model=model, handedness="trailing"))
        assert trail[0] == pytest.approx(lead[1], rel=1e-12) and trail[1] == pytest.approx(lead[0], rel=1e-12)


def test_leading_sun_parameter():
    geo = derive()
    pf = pin_friction(geo, 0.26, 0.012)
    KA, KB, K = (locking_coefficients(pf, lead) for lead in ("A", "B", "either"))
    assert K[0] == min(KA[0], KB[0]) and KA[0] > KB[0] and KA[0] / KB[0] - 1 == pytest.approx(0.0066, abs=5e-4)
    p = DifferentialParams(leadingSun="A")
    m = RigidDifferential(p)
    m.initialize()
    assert m.K == KA[0]
    with pytest.raises(ParameterError, match="leadingSun"):
        DifferentialParams(leadingSun="left").validate()


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_rigid_level_breaks_away_at_the_3d_K(sign):
    """The rigid level (end reactions at every solve) holds 0.995 K T0 and slips at 1.005 K T0."""
    p = DifferentialParams(pinSpeedLoads=False)
    out = []
    for frac in (0.995, 1.005):
        m = RigidDifferential(p)
        m.w_ref = m.w_start_carrier = 1.389
        K = None
        m.initialize()
        K = m.K if sign > 0 else m.K_coast
        D = frac * K * 2100.0
        m.tau_L, m.tau_R = -1050.0 * sign - D / 2, -1050.0 * sign + D / 2
        for k in range(20):
            m.do_step(k * 1e-3, 1e-3)
        out.append(m.wd)
    assert out[0] == 0.0 and out[1] != 0.0


def test_linear_pressure_is_refused_by_the_dynamic_levels():
    with pytest.raises(ParameterError, match="pinModel"):
        RigidDifferential(DifferentialParams(pinModel="linearPressure")).initialize()
