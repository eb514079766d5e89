"""The gear set derived and checked: :func:`derive` computes the geometry of the three meshes
(:mod:`spurdiff.gears.geometry`) and runs every design check (:mod:`spurdiff.gears.checks`) and,
when the set is feasible, the mesh phasing checks (:mod:`spurdiff.gears.phasing`)."""
from __future__ import annotations

from dataclasses import replace

from spurdiff.gears.axial import AxialLayout
from spurdiff.gears.checks import DesignLimits, design_checks
from spurdiff.gears.geometry import DifferentialGeometry, GearTable, gear_geometry, mesh_geometry
from spurdiff.gears.phasing import phase_findings


def derive(table: GearTable | None = None, limits: DesignLimits | None = None) -> DifferentialGeometry:
    """Derive the geometry of all three meshes and run every design check (with the margins of
    ``limits``, default :class:`spurdiff.gears.checks.DesignLimits`).

    Raises ParameterError only for inputs for which no geometry exists at all (non-positive
    module, no operating pressure angle, ...). Infeasible but computable gear sets come back with
    error findings; call :meth:`DifferentialGeometry.raise_on_error` to reject them.
    """
    t = table or GearTable()
    t.validate()
    gg = {name: gear_geometry(name, g, t) for name, g in t.gears().items()}
    mA1 = mesh_geometry("A1", gg["sunA"], gg["planet1"], t)
    mB2 = mesh_geometry("B2", gg["sunB"], gg["planet2"], t)
    m12 = mesh_geometry("12", gg["planet1"], gg["planet2"], t)
    findings = tuple(design_checks(t, gg, (mA1, mB2, m12), limits))
    geo = DifferentialGeometry(t, gg, mA1, mB2, m12, findings)
    geo = replace(geo, findings=findings + tuple(AxialLayout.of(t).findings(geo)))   # the axial stack-up
    if not geo.errors:
        geo = replace(geo, findings=geo.findings + tuple(phase_findings(geo)))
    return geo
