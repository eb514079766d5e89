"""Issue 46.3: the min and max a model description declares are the ranges the FMU enforces, from
one declaration (spurdiff.errors), and every variable has a description.

A value just outside a declared min or max must be refused when the model is built (the path the
FMU's adapter takes at fmi2ExitInitializationMode), naming the variable; the value at the start
must be accepted. Parameters a configuration does not read are checked in one that reads them.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
import zipfile

import pytest

from spurdiff.errors import ParameterError
from spurdiff.fmi import differential_fmu, vehicle_fmu, wheel_fmu

MESH_ONLY = ("mesh", "flank.", "tolerance", "maxInternalSteps")   # read by the compliant/contact levels
SHAFT_ONLY = ("leftShaft.", "rightShaft.", "shafts.")               # read with shaftCoupling = wheel


def _outside(v) -> list:
    """Values just outside the declared range of ``v`` (one per declared side)."""
    out = []
    if v.min is not None:
        out.append(v.min - 1 if v.kind == "Integer" else v.min - max(1e-9, abs(v.min) * 1e-6))
    if v.max is not None:
        out.append(v.max + 1 if v.kind == "Integer" else v.max + max(1e-9, abs(v.max) * 1e-6))
    return out


def _differential_values(name: str) -> dict:
    values = {v.name: v.start for v in differential_fmu.VARIABLES}
    if name.startswith(MESH_ONLY):
        values["meshModel"] = "compliant"
    if name.startswith(SHAFT_ONLY):
        values["shaftCoupling"] = "wheel"
    return values


def _bounded(module) -> list:
    """The parameters of an FMU's adapter ``module`` that declare a min or a max."""
    return [v for v in module.VARIABLES if v.causality == "parameter" and (v.min is not None or v.max is not None)]


def _refuses_outside(module, values: dict, v) -> None:
    """The model builds from ``values`` (the start value is inside); each value just outside the declared
    range of ``v`` is refused, naming ``v``."""
    module.build_model(dict(values))
    for bad in _outside(v):
        with pytest.raises(ParameterError) as e:
            module.build_model(dict(values, **{v.name: bad}))
        assert e.value.name == v.name, (v.name, bad, str(e.value))


BOUNDED = _bounded(differential_fmu)


def test_most_differential_parameters_declare_their_range():
    numeric = [v for v in differential_fmu.VARIABLES if v.causality == "parameter" and v.kind in ("Real", "Integer")]
    unbounded = sorted(v.name for v in numeric if v.min is None and v.max is None)
    # the start speeds are not bounded by any check: everything else numeric is
    assert unbounded == ["carrier.w_start", "differential.w_start"]


@pytest.mark.parametrize("v", BOUNDED, ids=lambda v: v.name)
def test_differential_refuses_values_outside_the_declared_range(v):
    _refuses_outside(differential_fmu, _differential_values(v.name), v)


@pytest.mark.parametrize("v", _bounded(wheel_fmu), ids=lambda v: v.name)
def test_wheel_refuses_values_outside_the_declared_range(v):
    _refuses_outside(wheel_fmu, {x.name: x.start for x in wheel_fmu.VARIABLES}, v)


@pytest.mark.parametrize("module", [differential_fmu, wheel_fmu, vehicle_fmu], ids=lambda m: m.FMU_NAME)
def test_every_variable_has_a_description_and_reals_a_unit(module):
    for v in module.VARIABLES:
        assert v.description and v.description.strip() == v.description and v.description != v.name, v.name
        if v.kind == "Real":
            assert v.unit, v.name
        if v.min is not None and v.max is not None:
            assert v.min < v.max, v.name
        if v.causality in ("parameter", "input") and v.kind in ("Real", "Integer") and not (
                isinstance(v.start, float) and math.isnan(v.start)):
            assert v.min is None or v.start >= v.min, v.name
            assert v.max is None or v.start <= v.max, v.name


def test_built_model_description_carries_the_declared_ranges_units_and_tool(fmu_files):
    with zipfile.ZipFile(fmu_files["SpurDifferential"]) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    assert root.get("generationTool").startswith("spurdiff ")
    assert "pythonfmu" in root.get("generationTool").lower()
    by_name = {sv.get("name"): sv for sv in root.iter("ScalarVariable")}
    for v in differential_fmu.VARIABLES:
        sv = by_name[v.name]
        assert sv.get("description") == v.description
        typed = sv.find(v.kind)
        for key, want in (("min", v.min), ("max", v.max)):
            got = typed.get(key)
            assert (got is None) == (want is None), (v.name, key)
            if want is not None:
                assert float(got) == float(want), (v.name, key)
    units = {u.get("name"): u for u in root.iter("Unit")}
    for name, u in units.items():
        assert u.find("DisplayUnit") is not None or name == "1", name
    without_base = sorted(n for n, u in units.items() if u.find("BaseUnit") is None and n != "1")
    # every unit with its SI base units (the IMPACT stiffness, N/m^e with a fractional e, is declared
    # as the contact force at 1 m of penetration, in N: FMI's base-unit exponents are integers)
    assert without_base == [], without_base


def test_checksum_file_is_the_fmus_own_digest(fmu_files):
    import hashlib
    from harness.build.fmu_checksum import checksum_path
    for fmu in fmu_files.values():
        digest, name = checksum_path(fmu).read_text().split()
        assert name == fmu.name
        assert digest == hashlib.sha256(fmu.read_bytes()).hexdigest()


@pytest.mark.parametrize("v", _bounded(vehicle_fmu), ids=lambda v: v.name)
def test_vehicle_refuses_values_outside_the_declared_range(v):
    _refuses_outside(vehicle_fmu, {x.name: x.start for x in vehicle_fmu.VARIABLES}, v)


def test_an_fmu_changed_after_its_build_is_not_current(tmp_path):
    from harness.build import fmu_checksum
    fmu = tmp_path / "X.fmu"
    fmu.write_bytes(b"an fmu")
    fmu_checksum.write(fmu, "sources-1")
    assert fmu_checksum.is_current(fmu, "sources-1") and not fmu_checksum.is_current(fmu, "sources-2")
    assert (tmp_path / "X.sha256").read_text().split()[1] == "X.fmu"
    fmu.write_bytes(b"an FMU changed")
    assert not fmu_checksum.is_current(fmu, "sources-1")
