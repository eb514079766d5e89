"""Mass properties from the parts (spurdiff.differential.inertia): the planets' bores removed (the
pin belongs to the carrier), the pins on the carrier, stepped planets, overrides kept; each against
a hand calculation of rings and discs."""
import math
from dataclasses import replace

import pytest

from spurdiff.differential import inertia
from spurdiff.differential.params import DifferentialParams
from spurdiff.gears.design import derive
from spurdiff.gears.design_sets import gear_set

RHO = 7850.0


@pytest.fixture(scope="module", params=["paper", "designed"])
def geo(request):
    return derive(gear_set(request.param))


def test_ring_by_hand():
    """m = rho pi (R^2 - r^2) b, J = m (R^2 + r^2) / 2: a 40 / 24 mm ring 22 mm wide."""
    m, J = inertia.ring(0.020, 0.012, 0.022, RHO)
    assert m == pytest.approx(RHO * math.pi * (0.020 ** 2 - 0.012 ** 2) * 0.022, rel=1e-15)
    assert J == pytest.approx(0.5 * m * (0.020 ** 2 + 0.012 ** 2), rel=1e-15)


def test_planets_lose_their_bore_and_the_pins_go_to_the_carrier(geo):
    """Planet 1 (one plane, every mm of it meshes): the solid disc times 1 - (r_pin / r_mean)^2;
    the carrier gains 2 n pins of diameter 2 r_collar across wallB at the orbit radii."""
    p = DifferentialParams()
    mp = inertia.mass_properties(p, geo)
    g1 = geo.gears["planet1"]
    r = 0.5 * (g1.ra + g1.rf)
    solid = RHO * math.pi * r * r * g1.b
    assert inertia.toothed_width(geo, "planet1") == pytest.approx(g1.b, abs=1e-15)
    assert mp.m_planet1 == pytest.approx(solid * (1.0 - (p.r_collar / r) ** 2), rel=1e-12)
    assert 0.3 < 1.0 - mp.m_planet1 / solid < 0.45          # the "about 40 % lower"
    m_pin = RHO * math.pi * p.r_collar ** 2 * geo.table.carrier.wallB
    assert mp.m_pin == pytest.approx(m_pin, rel=1e-12)
    R = geo.meshB2.a + geo.gears["planet2"].ra + inertia.CARRIER_RIM_MARGIN
    plates = RHO * math.pi * R ** 2 * inertia.CARRIER_PLATE_THICKNESS * R ** 2
    pins = 3 * m_pin * (geo.meshA1.a ** 2 + p.r_collar ** 2 / 2 + geo.meshB2.a ** 2 + p.r_collar ** 2 / 2)
    assert mp.J_carrier == pytest.approx(plates + pins, rel=1e-12)


def test_planet2_is_stepped_where_it_meshes_nothing(geo):
    """Planet 2 spans both planes; its face between mesh 12 and mesh B2 meshes nothing (1 mm in the
    assumed layouts): a hub at the root radius there."""
    p = DifferentialParams()
    g2 = geo.gears["planet2"]
    bt = inertia.toothed_width(geo, "planet2")
    lay = __import__("spurdiff.gears.axial", fromlist=["x"]).axial_layout(geo)
    assert bt == pytest.approx(lay.mesh_width("12") + lay.mesh_width("B2"), abs=1e-15)
    assert bt < g2.b
    r, ri = 0.5 * (g2.ra + g2.rf), p.r_collar
    m = RHO * math.pi * ((r * r - ri * ri) * bt + (g2.rf ** 2 - ri * ri) * (g2.b - bt))
    assert inertia.mass_properties(p, geo).m_planet2 == pytest.approx(m, rel=1e-12)


def test_overrides_are_kept(geo):
    p = replace(DifferentialParams(), J_carrier=13.1, m_planet1=0.5, J_planet2=1e-4)
    mp = inertia.mass_properties(p, geo)
    assert (mp.J_carrier, mp.m_planet1, mp.J_planet2) == (13.1, 0.5, 1e-4)


def test_no_pin_no_bore(geo):
    """r_collar = 0 (no pins): solid planets, no pin mass."""
    p = replace(DifferentialParams(), r_collar=0.0)
    mp = inertia.mass_properties(p, geo)
    g1 = geo.gears["planet1"]
    r = 0.5 * (g1.ra + g1.rf)
    assert mp.m_planet1 == pytest.approx(RHO * math.pi * r * r * g1.b, rel=1e-12)
    assert mp.m_pin == 0.0
