"""The designed gear set (spurdiff.gears.design_search, design_sets): the proposal meets every
target and margin by the checks of gears/checks.py and by direct geometry (generating shift of the
thinned teeth 0.02 beyond undercut, the basic rack's bottom clearance 0.25 m, specific sliding >= -4,
usable contact ratio >= 1.1), the bundled data set is the command's proposal, the paper's set is
untouched (docs/capacity.md)."""
import math

import pytest

from spurdiff.errors import ParameterError
from spurdiff.gears import design_search as ds
from spurdiff.gears.design import derive
from spurdiff.gears.design_sets import fmu_parameters, gear_set
from spurdiff.gears.geometry import Gear, GearTable, gear_geometry, mesh_geometry

Z = dict(sunA=36, planet1=13, sunB=36, planet2=13)
A = {"A1": 0.0725, "B2": 0.0775, "12": 0.04075}


@pytest.fixture(scope="module")
def prop():
    return ds.propose(Z, A)


def test_proposal_has_no_blocking_finding(prop):
    assert [f.check for f in prop.geometry.findings if f.check in ds.BLOCKING] == []
    assert prop.geometry.errors == []


def test_proposal_meets_the_targets_by_direct_geometry(prop):
    geo, t = prop.geometry, prop.table
    m, al = t.m, t.alpha
    for me in geo.meshes:
        assert me.a == pytest.approx(A[me.name], abs=1e-12)            # the given centre distances
        assert me.epsilon_usable >= 1.1
        for g in (me.gear1, me.gear2):
            assert geo.gears[g].ra <= me.tip_limit(g) * (1 + 1e-12)  # no tip interference
        g1, g2 = geo.gears[me.gear1], geo.gears[me.gear2]
        assert me.a - g1.ra - g2.rf >= 0.25 * m - 1e-12 and me.a - g2.ra - g1.rf >= 0.25 * m - 1e-12
        # specific sliding at both starts of active profile, by hand: zeta = 1 - (r_b,i rho_j) / (r_b,j rho_i)
        L = me.a * math.sin(me.alpha_w)
        rho1 = L - math.sqrt(g2.ra ** 2 - g2.rb ** 2)          # gear 1's start of active profile
        rho2 = L - math.sqrt(g1.ra ** 2 - g1.rb ** 2)
        assert 1 - g1.rb * (L - rho1) / (g2.rb * rho1) >= -4.0 - 1e-9
        assert 1 - g2.rb * (L - rho2) / (g1.rb * rho2) >= -4.0 - 1e-9
    # the teeth thinned for the backlash: A_sn1 + A_sn2 = -j_t cos(alpha_w) / cos(alpha) per mesh,
    # mesh 12's share halved between the planets; generating shift x_E = x + A_sn / (2 m tan(alpha))
    j = {"A1": 0.000127, "B2": 0.000138, "12": 0.00012}
    need = {me.name: -j[me.name] * math.cos(me.alpha_w) / math.cos(al) for me in geo.meshes}
    A_sn = {"planet1": need["12"] / 2, "planet2": need["12"] / 2, "sunA": need["A1"] - need["12"] / 2,
            "sunB": need["B2"] - need["12"] / 2}
    h_ffp0 = t.haP0 - t.rhoaP0 * (1 - math.sin(al))
    for name, g in geo.gears.items():
        x_E = g.x + A_sn[name] / (2 * m * math.tan(al))
        assert x_E >= h_ffp0 - g.z * math.sin(al) ** 2 / 2 + 0.02 - 1e-9   # undercut margin
        assert not g.undercut and g.rF >= g.rb
        assert g.sa >= 0.3 * m - 1e-9                                      # tip thickness
    assert geo.meshB2.a - geo.gears["planet2"].ra - geo.gears["sunA"].ra >= 0.25 * m - 1e-12


def test_the_old_designed_set_had_no_margins():
    """The set of round 3 (71.5 / 76.5 / 40.5 mm, zero-backlash shifts, 0.2 m clearances) fails the
    margins the issue asks for: planet 2 thinned for its backlash is undercut, clearances 0.2 m,
    specific sliding -9.2 and -4.7."""
    old = GearTable.paper()
    for n, x, da in (("sunA", -0.9150521650026869, 0.105877), ("planet1", 0.3247846962353801, 0.04679),
                     ("sunB", 0.896311684163298, 0.118861), ("planet2", 0.23971209460043286, 0.045922)):
        old = old.with_gear(n, x=x, da=da)
    checks = {f.check for f in derive(old).warnings}
    assert {"undercut-margin", "tip-clearance", "specific-sliding"} <= checks


def test_shift_sum_gives_the_centre_distance():
    """x_1 + x_2 from a (ISO 21771) and back through the gear geometry: a = m (z1+z2)/2 at sum 0."""
    t = GearTable()
    assert ds.shift_sum(13, 13, 0.039, t.m, t.alpha, "a12") == pytest.approx(0.0, abs=1e-12)
    S = ds.shift_sum(36, 13, 0.0715, t.m, t.alpha, "aA1")
    me = mesh_geometry("X", gear_geometry("g1", Gear(36, S / 2, 0.02), t), gear_geometry("g2", Gear(13, S / 2, 0.02), t), t)
    assert me.a == pytest.approx(0.0715, abs=1e-12)


def test_bundled_designed_set_is_the_commands_proposal(prop):
    d = gear_set("designed")
    for n in ds.GEARS:
        got, want = getattr(d, n), getattr(prop.table, n)
        assert (got.z, got.b, got.da) == (want.z, want.b, want.da)
        assert got.x == pytest.approx(want.x, abs=1e-12)
    assert d.nPairs == 3


def test_paper_set_is_unchanged():
    """The paper scenes keep the paper's table: its findings are those the paper set always had, plus
    the axial stack-up's (issue 41: mesh B2 gets 17 of sun B's 22 mm, spurdiff.gears.axial)."""
    assert gear_set("paper") == GearTable.paper()
    checks = sorted(f.check for f in derive(gear_set("paper")).findings)
    assert checks == ["contact-ratio", "contact-ratio", "mesh-width", "specific-sliding", "specific-sliding",
                      "specific-sliding", "specific-sliding", "tip-clearance", "tip-interference", "tip-interference",
                      "tip-interference", "undercut"]


def test_fmu_parameters_name_fmu_variables():
    from spurdiff.fmi.differential_fmu import VARIABLES
    names = {v.name for v in VARIABLES}
    p = fmu_parameters("designed")
    assert set(p) <= names
    assert p["planet2.x"] == gear_set("designed").planet2.x
    with pytest.raises(ParameterError, match="gearSet"):
        gear_set("nope")


@pytest.mark.parametrize("z,a,name,allowed", [
    (dict(Z, sunA=-5), A, "sunA.z", "an integer from 6 to 400"),
    (Z, dict(A, **{"12": 0.039}), "a12", ">= 0.040523 m"),
    (Z, dict(A, **{"12": 0.4}), "a12", "between"),
    (Z, dict(A, B2=0.079), "aB2", "usable contact ratio >= 1.1"),
    (dict(Z, sunB=35), A, "sunB.z", "= sunA.z"),
])
def test_impossible_input_names_the_parameter_and_range(z, a, name, allowed):
    with pytest.raises(ParameterError) as e:
        ds.propose(z, a)
    assert e.value.name == name and allowed in e.value.allowed
