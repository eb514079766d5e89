"""Involute geometry and design checks against the verified values in shared/docs/paper-notes.md."""
import dataclasses
import math

import pytest
from hypothesis import given, settings, strategies as st

from spurdiff.errors import ParameterError
from spurdiff.geometry import MM, GearTable, derive, inv, inv_inverse


def sig4(a, b):
    """Equal to 4 significant digits."""
    return abs(a - b) <= 0.5e-3 * abs(b)


@pytest.fixture(scope="module")
def geo():
    return derive(GearTable.paper())


@pytest.mark.parametrize("mesh,alpha_w_deg,a_mm,rw1_mm,rw2_mm", [
    ("meshA1", 13.3987, 70.9999, 52.1632, 18.8367),
    ("meshB2", 24.6626, 76.0001, 55.8368, 20.1633),
    ("mesh12", 20.0000, 39.0000, 19.5, 19.5),
])
def test_operating_geometry_matches_notes(geo, mesh, alpha_w_deg, a_mm, rw1_mm, rw2_mm):
    me = getattr(geo, mesh)
    assert math.degrees(me.alpha_w) == pytest.approx(alpha_w_deg, abs=1e-4)
    assert me.a / MM == pytest.approx(a_mm, abs=1e-4)
    assert me.rw1 / MM == pytest.approx(rw1_mm, abs=1e-4)
    assert me.rw2 / MM == pytest.approx(rw2_mm, abs=1e-4)


def test_base_circles_match_table(geo):
    assert sig4(2 * geo.gears["sunA"].rb / MM, 101.487)
    assert sig4(2 * geo.gears["planet1"].rb / MM, 36.648)


@pytest.mark.parametrize("mesh,eps_table_tips,eps_untrimmed", [
    ("meshA1", 1.667, 1.861), ("meshB2", 1.351, 1.469), ("mesh12", 1.302, 1.428)])
def test_contact_ratios(geo, mesh, eps_table_tips, eps_untrimmed):
    assert getattr(geo, mesh).epsilon_alpha == pytest.approx(eps_table_tips, abs=5e-4)
    t = GearTable.paper()
    for g in ("sunA", "planet1", "sunB", "planet2"):
        t = t.with_gear(g, da=0.0)
    assert getattr(derive(t), mesh).epsilon_alpha == pytest.approx(eps_untrimmed, abs=5e-4)


def test_symmetry_condition_holds_as_corrected(geo):
    # r_a/r_b = r_1/r_2 (the paper prints r_2/r_1)
    assert geo.r_a / geo.r_b == pytest.approx(geo.r_1 / geo.r_2, rel=1e-12)
    assert geo.r_a / geo.r_b != pytest.approx(geo.r_2 / geo.r_1, rel=1e-3)


def test_paper_set_findings(geo):
    checks = {(f.level, f.check, f.parameter) for f in geo.findings}
    assert not geo.errors
    assert ("warning", "undercut", "planet2.x") in checks
    assert ("warning", "tip-interference", "sunA.da") in checks


def test_six_pairs_do_not_fit_three_do():
    assert not derive(dataclasses.replace(GearTable.paper(), nPairs=3)).errors
    errs = derive(dataclasses.replace(GearTable.paper(), nPairs=6)).errors
    assert [f.check for f in errs] == ["neighbour-clearance"]
    with pytest.raises(ParameterError, match="nPairs"):
        derive(dataclasses.replace(GearTable.paper(), nPairs=6)).raise_on_error()


def test_unequal_suns_break_symmetry():
    errs = derive(GearTable.paper().with_gear("sunB", z=37)).errors
    assert any(f.check == "symmetry" for f in errs)


def test_planet2_must_clear_sun_a():
    # a bigger planet 2 tip runs into sun A's tip circle (the paper's profile-shift trick fails)
    errs = derive(GearTable.paper().with_gear("planet2", da=46.0 * MM)).errors
    assert any(f.check == "planet2-sunA-clearance" for f in errs)


def test_pointed_tip_is_an_error():
    t = GearTable.paper().with_gear("planet1", x=1.2, da=0.0)
    assert any(f.check == "pointed-tip" and f.level == "error" for f in derive(t).findings)


@pytest.mark.parametrize("field,value,name", [
    ("m", -3e-3, "gearing.m"), ("m", float("nan"), "gearing.m"), ("alpha", 0.0, "gearing.alpha"),
    ("nPairs", 0, "nPairs"),
])
def test_bad_table_values_name_the_parameter(field, value, name):
    with pytest.raises(ParameterError, match=name.replace(".", r"\.")):
        derive(dataclasses.replace(GearTable.paper(), **{field: value}))


def test_bad_gear_values_name_the_parameter():
    with pytest.raises(ParameterError, match=r"sunA\.z"):
        derive(GearTable.paper().with_gear("sunA", z=3))
    with pytest.raises(ParameterError, match=r"planet2\.b"):
        derive(GearTable.paper().with_gear("planet2", b=-0.01))


def test_impossible_shift_sum_has_no_operating_angle():
    t = GearTable.paper().with_gear("sunA", x=-3.0).with_gear("planet1", x=-3.0)
    with pytest.raises(ParameterError, match="sunA.x"):
        derive(t)


def test_involute_inverse_roundtrip():
    for deg in (5.0, 13.4, 20.0, 24.66, 40.0):
        a = math.radians(deg)
        assert inv_inverse(inv(a)) == pytest.approx(a, abs=1e-12)


@settings(max_examples=60, deadline=None)
@given(zs=st.integers(24, 60), zp=st.integers(12, 24), xa=st.floats(-0.6, 0.8), x1=st.floats(-0.3, 0.6),
       xb=st.floats(-0.6, 0.8), x2=st.floats(-0.3, 0.6), n=st.integers(2, 5))
def test_derived_geometry_is_consistent_for_drawn_tables(zs, zp, xa, x1, xb, x2, n):
    t = GearTable(sunA=GearTable().sunA.__class__(z=zs, x=xa, b=0.022),
                  planet1=GearTable().planet1.__class__(z=zp, x=x1, b=0.022),
                  sunB=GearTable().sunB.__class__(z=zs, x=xb, b=0.022),
                  planet2=GearTable().planet2.__class__(z=zp, x=x2, b=0.040), nPairs=n)
    alpha = t.alpha
    sums = {"A1": (xa + x1, zs + zp), "B2": (xb + x2, zs + zp), "12": (x1 + x2, 2 * zp)}
    if any(2 * math.tan(alpha) * xs / zsum + inv(alpha) <= 0.0 for xs, zsum in sums.values()):
        # no operating pressure angle exists: a clear error naming the shifts, not a crash
        with pytest.raises(ParameterError, match=r"\.x \+ "):
            derive(t)
        return
    geo = derive(t)
    for me in geo.meshes:
        z1, z2 = t.gears()[me.gear1].z, t.gears()[me.gear2].z
        assert me.rw1 + me.rw2 == pytest.approx(me.a, rel=1e-12)
        assert me.rw2 / me.rw1 == pytest.approx(z2 / z1, rel=1e-12)
        assert math.isfinite(me.epsilon_alpha)
        # operating pitch circles are the base circles scaled by 1/cos(alpha_w)
        assert me.rw1 * math.cos(me.alpha_w) == pytest.approx(me.rb1, rel=1e-12)
    # equal suns and equal planets: symmetric kinematics, never a symmetry error
    assert not any(f.check == "symmetry" for f in geo.findings)
    for f in geo.findings:
        assert f.level in ("error", "warning") and f.parameter and f.message
