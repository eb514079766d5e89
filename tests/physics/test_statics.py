"""The paper's theory numbers (paper-notes.md) to 4 significant digits."""
import pytest

from spurdiff.gears.design import derive
from spurdiff.gears.geometry import MM, GearTable
from spurdiff.gears.layout import kinematics
from spurdiff.differential.statics import locking_coefficient, mesh_forces, mesh_forces_for, torque_bias_ratio

T0 = 2100.0  # N m


def sig4(a, b):
    return abs(a - b) <= 0.5e-3 * abs(b)


@pytest.fixture(scope="module")
def geo():
    return derive(GearTable.paper())


def test_locking_coefficient_three_pairs(geo):
    K = locking_coefficient(0.26, 0.012, 3, geo.r_a, geo.r_1, geo.r_b, geo.r_2)
    assert sig4(K, 0.028332)
    assert sig4(K * T0 * 1e3, 59_497)  # N mm


def test_paper_delta_t_is_not_from_six_pairs(geo):
    # the paper's formula with its literal 6 gives half of what it prints
    K6 = locking_coefficient(0.26, 0.012, 6, geo.r_a, geo.r_1, geo.r_b, geo.r_2)
    assert K6 * T0 * 1e3 == pytest.approx(59_497 / 2, rel=1e-3)


def test_mesh_forces_with_the_papers_rounded_radii(geo):
    f = mesh_forces(T0 / 2, T0 / 2, 3, 52.16 * MM, geo.meshA1.alpha_w, 18.84 * MM,
                    55.84 * MM, geo.meshB2.alpha_w, 19.5 * MM, geo.mesh12.alpha_w)
    assert sig4(f.F_A1, 6897.9) and sig4(f.F_B2, 6897.1) and sig4(f.F_12, 6899.1)
    # and the paper's printed figures within 0.03 %
    for ours, paper in ((f.F_A1, 6898), (f.F_B2, 6896), (f.F_12, 6899)):
        assert ours == pytest.approx(paper, rel=3e-4)


def test_exact_radii_give_equal_forces(geo):
    # each planet has one base circle, so the moment balance makes all three normal forces equal
    f = mesh_forces_for(geo, T0 / 2, T0 / 2)
    assert f.F_A1 == pytest.approx(f.F_B2, rel=1e-12) == pytest.approx(f.F_12, rel=1e-12)
    assert sig4(f.F_A1, 6897.4)


def test_kinematics_symmetric(geo):
    k = kinematics(geo)
    assert k.sunB_per_sunA == -1.0
    assert k.planet1_per_sunA == pytest.approx(-36 / 13)
    assert k.planet2_per_sunA == pytest.approx(36 / 13)


def test_torque_bias_ratio():
    assert torque_bias_ratio(0.0) == 1.0
    assert torque_bias_ratio(0.028332) == pytest.approx(1.05832, rel=1e-5)


def test_planet_mesh_force_lies_between_the_sun_mesh_forces_when_friction_holds_a_difference(geo):
    f = mesh_forces_for(geo, 1075.0, 1025.0)
    assert f.F_B2 < f.F_12 < f.F_A1
    # the two planets' moment balances add up: F_A1 - F_B2 is shared by the two pin frictions
    assert (f.F_A1 - f.F_12) + (f.F_12 - f.F_B2) == pytest.approx(f.F_A1 - f.F_B2)


def test_locking_coefficients_for_each_law(geo):
    from spurdiff.differential.params import DifferentialParams
    from spurdiff.differential.statics import locking_coefficients_for

    assert locking_coefficients_for(DifferentialParams(lockingLaw="paper"), geo) == pytest.approx((0.028332, 0.028332),
                                                                                                 rel=2e-5)
    Kd, Kc = locking_coefficients_for(DifferentialParams(pinModel="planar"), geo)
    assert Kd == pytest.approx(0.17789, rel=1e-4) and Kc == pytest.approx(0.21064, rel=1e-4)
    # the default since issue 41: planet 2's couple in the end reactions of its journal
    Kd, Kc = locking_coefficients_for(DifferentialParams(), geo)
    assert Kd == pytest.approx(0.23265, rel=1e-4) and Kc == pytest.approx(0.21819, rel=1e-4)


def test_pin_law_breakaway_power_balance_and_review_numbers(geo):
    # the review: pin loads per unit mesh force 1.689 / 0.398 (drive), 0.821 / 1.661 (coast),
    # K_drive about 0.178; the quasi-static break-away satisfies (T_B - T_A) dw = n sum M_i |w_i|
    from spurdiff.differential.locking import breakaway, first_order_K, pin_friction

    pf = pin_friction(geo, 0.26, 0.012, pin_model="planar")    # the review's planar pins
    assert pf.layout.unit_pin_loads(1.0) == pytest.approx((1.689, 0.398), abs=5e-4)
    assert pf.layout.unit_pin_loads(-1.0) == pytest.approx((0.821, 1.661), abs=5e-4)
    assert first_order_K(pf, 1.0) == pytest.approx(0.178, abs=5e-4)
    for T0 in (2100.0, -2100.0):
        for s in (1.0, -1.0):
            b = breakaway(pf, T0, s)
            assert b.T_A + b.T_B == pytest.approx(T0, rel=1e-12)
            dw = s   # sun A relative to the carrier; the planets turn 36/13 times as fast
            loss = 3 * sum(abs(M) * 36 / 13 * abs(dw) for M in b.M)
            assert (b.T_B - b.T_A) * dw == pytest.approx(loss, rel=1e-10)
            assert [abs(M) for M in b.M] == pytest.approx([0.26 * 0.012 * F for F in b.F_pin], rel=1e-12)
