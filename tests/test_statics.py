"""The paper's theory numbers (paper-notes.md) to 4 significant digits."""
import pytest

from spurdiff.geometry import MM, GearTable, derive
from spurdiff.statics import kinematics, locking_coefficient, mesh_forces, mesh_forces_for, torque_bias_ratio

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
