"""The axial layout (spurdiff.gears.axial): mesh widths as overlaps, journal positions, stack-up findings."""
from __future__ import annotations

import pytest

from spurdiff.errors import ParameterError
from spurdiff.gears.axial import AxialLayout
from spurdiff.gears.design import derive
from spurdiff.gears.design_sets import fmu_parameters, gear_set, table_from_data
from spurdiff.gears.geometry import GearTable

MM = 1e-3


def _checks(geo, kind):
    return [f for f in geo.findings if f.check == kind]


def test_paper_layout_widths_and_positions():
    lay = AxialLayout.of(GearTable())
    assert lay.mesh_width("A1") == pytest.approx(22 * MM, abs=1e-12)
    assert lay.mesh_width("12") == pytest.approx(22 * MM, abs=1e-12)
    assert lay.mesh_width("B2") == pytest.approx(17 * MM, abs=1e-12)   # 24 .. 41 mm
    j1, j2 = lay.journals
    assert j1.planar and not j2.planar
    # planet 2's journal 1 .. 41 mm: mesh 12 at 12 mm, mesh B2 at 32.5 mm, mass at 21 mm
    assert j2.length == pytest.approx(40 * MM)
    assert j2.planet_mesh == pytest.approx(11 / 40) and j2.sun_mesh == pytest.approx(31.5 / 40)
    assert j2.mass == 0.5
    assert not lay.planar


def test_paper_set_stackup_findings():
    geo = derive(GearTable())
    w = _checks(geo, "mesh-width")
    assert len(w) == 1 and "mesh B2 is 17.00 mm" in w[0].message
    assert not _checks(geo, "axial-stackup") and not _checks(geo, "carrier-wall") and not geo.errors


def test_planet1_in_sun_B_plane_is_an_error():
    t = GearTable().with_gear("sunB", axialStart=0.010)     # sun B 10 .. 32 mm: into planet 1 (1 .. 23 mm)
    geo = derive(t)
    errs = [f for f in geo.errors if f.check == "axial-stackup"]
    # planet 1's tip circle reaches 12.4 mm inside sun B's (71.0 - 23.03 against 60.4 mm)
    assert any("planet 1 and sun B overlap axially by 13.00 mm" in f.message and "12.4" in f.message for f in errs)
    assert any("sun A and sun B overlap axially" in f.message for f in errs)
    with pytest.raises(ParameterError):
        geo.raise_on_error()


def test_clearance_and_wall_warnings_and_errors():
    geo = derive(GearTable().with_gear("sunB", axialStart=0.0235))   # 0.5 mm from planet 1 and sun A
    assert [f.level for f in _checks(geo, "axial-stackup")] == ["warning", "warning"]
    geo = derive(GearTable().with_gear("sunB", axialStart=0.030))    # ends at 52 mm > wall B 47 mm
    assert any(f.level == "error" for f in _checks(geo, "carrier-wall"))
    geo = derive(GearTable().with_gear("planet2", axialStart=0.024))  # 24 .. 64: no overlap with planet 1
    assert any(f.check == "axial-mesh" and "mesh 12" in f.message for f in geo.errors)


def test_planar_layout_when_all_coplanar():
    t = GearTable().with_gear("planet2", axialStart=0.001, b=0.022).with_gear("sunB", axialStart=0.001)
    lay = AxialLayout.of(t)
    assert lay.planar


def test_designed_set_and_data_roundtrip():
    t = gear_set("designed")
    assert t.sunB.axialStart == 0.024 and t.carrier.wallB == 0.047
    p = fmu_parameters(t)
    assert p["planet2.axialStart"] == 0.001 and p["carrier.axialClearance"] == 0.001
    t2 = table_from_data({"carrier": {"wallB": 0.05}, "sunB": {"axialStart": 0.025}})
    assert t2.carrier.wallB == 0.05 and t2.sunB.axialStart == 0.025
    with pytest.raises(ParameterError, match="carrier.wall"):
        table_from_data({"carrier": {"wall": 0.05}})
    with pytest.raises(ParameterError, match="sunA.axialStart"):
        GearTable().with_gear("sunA", axialStart=-0.001).validate()


def test_a_table_without_axial_layout_is_coplanar_with_one_warning():
    from spurdiff.gears.geometry import Gear
    from spurdiff.differential.locking import locking_coefficients, pin_friction

    t = GearTable(sunA=Gear(36, -1.0099, 0.022, 0.1072), planet1=Gear(13, 0.3, 0.022, 0.046058999999999996),
                  sunB=Gear(36, 1.2296, 0.022, 0.1208), planet2=Gear(13, -0.3, 0.04, 0.042662))
    lay = AxialLayout.of(t)
    assert not lay.given and lay.planar and lay.mesh_width("B2") == 0.022
    geo = derive(t)
    w = [f for f in geo.findings if f.check == "axial-layout"]
    assert len(w) == 1 and w[0].level == "warning" and "sunA.axialStart" in w[0].message
    assert not geo.errors
    # the planar law (the paper's pins): 0.1779 / 0.2106
    assert locking_coefficients(pin_friction(geo, 0.26, 0.012)) == (0.17789422667429886, 0.2106388602738491)
    assert "sunA.axialStart" not in fmu_parameters(t)
