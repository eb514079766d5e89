"""Involute geometry and design checks against the verified values in shared/docs/paper-notes.md."""
import dataclasses
import math

import pytest
from hypothesis import given, settings, strategies as st

from spurdiff.errors import ParameterError
from spurdiff.gears.design import derive
from spurdiff.gears.geometry import MM, GearTable, inv, inv_inverse


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


# ------------------------------------------------------------------ form circle, undercut, usable contact
def test_form_diameter_of_the_undercut_planet_2_from_the_generating_rack():
    # the review simulated the rack: involute only above r = 18.42 mm (ISO 53 tool), 18.52 mm
    # with a sharp 1.25 m tool; base radius 18.32 mm
    g = derive(GearTable.paper()).gears["planet2"]
    assert g.undercut and g.rb / MM == pytest.approx(18.324, abs=1e-3)
    assert g.rF / MM == pytest.approx(18.429, abs=1e-3)
    sharp = derive(dataclasses.replace(GearTable.paper(), rhoaP0=0.0)).gears["planet2"]
    assert sharp.rF / MM == pytest.approx(18.519, abs=1e-3)


def test_sharp_tool_form_radius_is_where_the_tip_corner_trochoid_crosses_the_involute():
    # independent construction: the sharp tool corner traces a trochoid in the gear; find where
    # it crosses the involute flank by a root search along the trochoid
    from scipy.optimize import brentq

    z, x, m, a, ha = 13, -0.3, 3e-3, math.radians(20.0), 1.25
    r, rb = m * z / 2, m * z / 2 * math.cos(a)
    y_dat = r + x * m
    y_tip = y_dat - ha * m
    Xc = math.pi * m / 4 + (y_tip - y_dat) * math.tan(a)      # tool corner, right side
    psi_ref = (math.pi / 2 + 2 * x * math.tan(a)) / z + inv(a)

    def gap(phi):   # polar angle (from the space centre line) of the trochoid minus the involute's
        X, Y = Xc - r * phi, y_tip
        R = math.hypot(X, Y)
        return math.atan2(X, Y) + phi - (math.pi / z - psi_ref + inv(math.acos(min(1.0, rb / R))))

    phis = [i * 1e-3 for i in range(-1200, 1200)]
    roots = [brentq(gap, p0, p1) for p0, p1 in zip(phis, phis[1:])
             if gap(p0) * gap(p1) < 0 and math.hypot(Xc - r * p0, y_tip) > rb]
    R_cross = max(math.hypot(Xc - r * p, y_tip) for p in roots)
    from spurdiff.gears.generating import form_radius
    assert form_radius(z, x, m, a, ha, 0.0, 0.021331)[0] == pytest.approx(R_cross, abs=1e-8)


def test_form_radius_is_continuous_across_the_undercut_limit():
    from spurdiff.gears.generating import form_radius, straight_flank_reach

    z, m, a = 13, 3e-3, math.radians(20.0)
    x_lim = 1.0 - z * math.sin(a) ** 2 / 2          # ISO 53 tool: straight flank ends 1.0 m deep
    rb = m * z / 2 * math.cos(a)
    above = form_radius(z, x_lim + 1e-4, m, a, 1.25, 0.38, 0.03)
    below = form_radius(z, x_lim - 1e-4, m, a, 1.25, 0.38, 0.03)
    assert not above[1] and below[1]
    assert above[0] == pytest.approx(math.hypot(rb, straight_flank_reach(z, x_lim + 1e-4, m, a, 1.25, 0.38)))
    assert below[0] - rb < 2e-6 and above[0] - rb < 2e-6       # both just above the base circle
    assert form_radius(z, x_lim - 0.1, m, a, 1.25, 0.38, 0.03)[0] > below[0] + 1e-6


def test_usable_contact_ratios_from_the_form_circles_with_findings():
    # review: meshes B2 and 12 about 1.0 (0.93 with a 1.25 m sharp tool) instead of 1.233
    geo = derive(GearTable.paper())
    assert geo.meshB2.epsilon_usable == pytest.approx(1.011, abs=1e-3)
    assert geo.mesh12.epsilon_usable == pytest.approx(1.011, abs=1e-3)
    assert geo.meshA1.epsilon_usable == pytest.approx(1.515, abs=1e-3)
    warn = {f.check + ":" + f.message.split(":")[0] for f in geo.warnings}
    assert {"contact-ratio:mesh B2", "contact-ratio:mesh 12"} <= warn
    msg = next(f.message for f in geo.warnings if f.check == "contact-ratio" and "B2" in f.message)
    assert "1.011" in msg and "36.859" in msg and "1.351" in msg
    sharp = derive(dataclasses.replace(GearTable.paper(), rhoaP0=0.0))
    assert sharp.meshB2.epsilon_usable == pytest.approx(0.930, abs=1e-3)
    assert any(f.check == "contact-ratio" and f.level == "error" for f in sharp.errors)


def test_start_of_active_profile_is_checked_against_the_form_circle():
    # mesh 12: planet 1's tip reaches past planet 2's base tangent point; trimmed to the
    # interference-free diameter the tip meets planet 2 exactly at its form circle
    geo = derive(GearTable.paper())
    me = geo.mesh12
    f = next(f for f in geo.warnings if f.check == "tip-interference" and f.parameter == "planet1.da")
    assert "36.859" in f.message and "43.13" in f.message
    trimmed = derive(GearTable.paper().with_gear("planet1", da=2 * me.tip_limit("planet1")))
    assert not any(f.check == "tip-interference" and f.parameter == "planet1.da" for f in trimmed.findings)
    assert trimmed.mesh12.start_of_active_profile("planet2") == pytest.approx(geo.gears["planet2"].rF, rel=1e-9)


@pytest.mark.parametrize("field,value", [("haP0", 0.1), ("rhoaP0", -0.1), ("rhoaP0", 0.6)])
def test_bad_tool_values_name_the_parameter(field, value):
    with pytest.raises(ParameterError, match=f"gearing.{field}"):
        derive(dataclasses.replace(GearTable.paper(), **{field: value}))


# ------------------------------------------------------------------ mesh phasing
def test_mesh_phases_from_the_tooth_positions():
    from spurdiff.gears.phasing import mesh_phases

    ph = mesh_phases(derive(GearTable.paper()))
    # reference: an A1 drive pair at its pitch point; planet 1's nearest 12 drive pair is then
    # 0.45 base pitch from the 12 pitch point (review)
    assert ph["A1"].drive == pytest.approx(ph["A1"].pitch, abs=1e-12)
    off12 = (ph["12"].drive - ph["12"].pitch + 0.5) % 1.0 - 0.5
    assert abs(off12) == pytest.approx(0.453, abs=1e-3)


def _contacts(geo, theta):
    """Planet-1 drive flanks on the usable paths of A1 and 12, planet 1 turned by theta from the
    reference (direct count over its teeth, no modulo arithmetic on phases)."""
    from spurdiff.gears.layout import PinLayout
    from spurdiff.gears.phasing import _psi_b, mesh_phases

    t = geo.table
    phi1 = mesh_phases(geo)["_planets"][0] + theta
    lay = PinLayout.of(geo)
    C1 = (geo.meshA1.a, 0.0)
    C2 = (geo.meshB2.a * math.cos(lay.theta), geo.meshB2.a * math.sin(lay.theta))
    psi = _psi_b(t.planet1.z, t.planet1.x, t.alpha)
    z = t.planet1.z
    out = []
    # A1: planet 1 is gear 2, drive on its "-" flanks; tangent on planet 1 at theta_d + a_w + pi
    me = geo.meshA1
    l0, l1 = me.usable_path
    L = me.a * math.sin(me.alpha_w)
    tau2 = math.atan2(C1[1], C1[0]) + me.alpha_w + math.pi
    n = 0
    for i in range(z):
        beta = phi1 + 2 * math.pi * i / z - psi
        s2 = me.rb2 * ((tau2 - beta) % (2 * math.pi))
        n += l0 <= L - s2 <= l1
    out.append(n)
    # 12: planet 1 is gear 1, drive on its "+" flanks; tangent at theta_d - a_w
    me = geo.mesh12
    l0, l1 = me.usable_path
    tau1 = math.atan2(C2[1] - C1[1], C2[0] - C1[0]) - me.alpha_w
    n = 0
    for i in range(z):
        beta = phi1 + 2 * math.pi * i / z + psi
        s1 = me.rb1 * ((beta - tau1) % (2 * math.pi))
        n += l0 <= s1 <= l1
    out.append(n)
    return out


def test_planet_1_through_one_turn_single_and_double_contact_offset_by_the_phase():
    from spurdiff.gears.phasing import mesh_phases

    geo = derive(GearTable.paper())
    ph = mesh_phases(geo)
    z = geo.table.planet1.z
    pitch_angle = 2 * math.pi / z
    N = 13 * 400
    thetas = [2 * math.pi * k / N for k in range(N)]
    counts = [_contacts(geo, th) for th in thetas]
    # the mesh model's wave: both phases advance by rb_1 theta / p_b as planet 1 turns by theta
    eps = (geo.meshA1.epsilon_usable, geo.mesh12.epsilon_usable)
    xi0 = (ph["A1"].drive, ph["12"].drive)
    wrong = 0
    for th, c in zip(thetas, counts):
        for j in (0, 1):
            xi = (xi0[j] + th / pitch_angle) % 1.0
            model = 2 if xi < eps[j] - 1.0 else 1
            if min(abs(xi), abs(1 - xi), abs(xi - (eps[j] - 1.0))) > 1e-3:   # away from the edges
                wrong += c[j] != model
    assert wrong == 0
    # the double-contact intervals start where each phase wraps: offset by the phase difference
    starts = []
    for j in (0, 1):
        rising = [thetas[k] for k in range(1, N) if counts[k][j] == 2 and counts[k - 1][j] == 1]
        assert len(rising) == z                       # one per tooth over the turn
        starts.append(rising[0] % pitch_angle)
    offset = ((starts[1] - starts[0]) / pitch_angle) % 1.0
    assert offset == pytest.approx((xi0[0] - xi0[1]) % 1.0, abs=2 * z / N)


def test_pairs_out_of_phase_when_z_sun_over_n_is_not_an_integer():
    from spurdiff.gears.phasing import pair_phases

    assert pair_phases(36, 3) == [0.0, 0.0, 0.0]
    assert pair_phases(35, 2) == [0.0, 0.5]
    t = GearTable.paper().with_gear("sunA", z=35, x=-1.0, da=0.0).with_gear("sunB", z=35, x=1.1, da=0.0)
    geo = derive(dataclasses.replace(t, nPairs=2))
    assert [f.parameter for f in geo.warnings if f.check == "mesh-phasing"] == ["nPairs", "nPairs"]
    assert not any(f.check == "mesh-phasing" for f in derive(GearTable.paper()).findings)


# ------------------------------------------------------------------ design checks the old code got wrong
def test_unequal_planets_are_symmetric():
    # the old check demanded equal planets; the kinematics only need equal suns
    from spurdiff.gears.layout import kinematics

    t = GearTable.paper().with_gear("planet2", z=14, x=0.0, da=0.0).with_gear("sunB", x=1.1, da=0.0)
    geo = derive(t)
    assert not geo.errors, [str(f) for f in geo.errors]
    assert kinematics(geo).sunB_per_sunA == -1.0


def test_assembly_needs_z_A_plus_z_B_over_n_integer():
    # two pairs with 35-tooth suns: (35 + 35) / 2 = 35 pairs assemble (the old z % n check
    # warned); they mesh out of phase (35 / 2), which is a phasing warning, not an assembly error
    t = GearTable.paper().with_gear("sunA", z=35, x=-1.0, da=0.0).with_gear("sunB", z=35, x=1.1, da=0.0)
    geo = derive(dataclasses.replace(t, nPairs=2))
    assert not geo.errors
    assert not any(f.check in ("assembly", "equal-spacing") for f in geo.findings)
    # three pairs with 35-tooth suns: 70 / 3 is not an integer: they cannot be assembled
    geo3 = derive(dataclasses.replace(t, nPairs=3))
    assert [f.check for f in geo3.errors] == ["assembly"]


def test_tip_clearance_against_a_minimum():
    # sun A's tip 0.7 mm larger: 0.05 mm left to planet 1's root (the old check only caught < 0)
    t = GearTable.paper().with_gear("sunA", da=108.6 * MM)
    geo = derive(t)
    f = [f for f in geo.warnings if f.check == "tip-clearance"]
    assert [x.parameter for x in f] == ["sunA.da", "planet2.da"] and "0.0499 mm" in f[0].message
    # the paper's set against the basic rack's bottom clearance 0.25 m: planet 2's tip leaves 0.243 m
    # to sun B's root (sun A's 0.24998 m is within the 1 um a tip is made to)
    f = [f for f in derive(GearTable.paper()).findings if f.check == "tip-clearance"]
    assert [x.parameter for x in f] == ["planet2.da"] and "0.2434 m < 0.25 m" in f[0].message
