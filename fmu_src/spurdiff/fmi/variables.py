"""Declaration of an FMU's variables, readable without pythonfmu (used by the build step).

Each :class:`Var` binds to what it stands for (``bind``), as PythonFMU binds a variable name to
an attribute: an input to the model attribute it sets, an output or calculated parameter to the
model attribute it reads (a dotted path: ``mesh_forces.F_A1``), a parameter to its field in the
parameter objects (``diff.table.sunA.z``, ``mesh.contactExponent``, ``shafts.left.c``). The
copying between the FMU's value table and the model follows from these bindings
(:mod:`spurdiff.fmi.binding`); nothing is written per variable.
"""
from __future__ import annotations

from typing import Any, Callable

from spurdiff.attrpath import record


@record(frozen=True)
class Var:
    """One FMI variable of an FMU built on this adapter."""

    name: str
    causality: str                 # parameter | calculatedParameter | input | output | local
    description: str
    unit: str | None = None        # SI unit string as in UnitDefinitions (e.g. "N.m", "rad/s", "1")
    display_unit: str | None = None
    start: Any = 0.0
    kind: str = "Real"             # Real | Integer | Boolean | String
    variability: str | None = None  # default from causality
    depends: tuple[str, ...] = ()  # outputs: inputs with direct feedthrough (none: values are
    #                                those at the end of the last step)
    min: float | None = None       # inputs: the physical range a step accepts (modelDescription
    max: float | None = None       # min/max; a value outside is refused with fmi2Discard)
    bind: str | None = None        # what the variable stands for (see the module docstring);
    #                                None: set by the interface module's build_model itself

    @property
    def fmi_variability(self) -> str:
        if self.variability:
            return self.variability
        return {"parameter": "fixed", "calculatedParameter": "fixed"}.get(
            self.causality, "continuous" if self.kind == "Real" else "discrete")


def magic_formula_factors(param: Callable[..., Var], group: str, who: str = "") -> list[Var]:
    """The Magic Formula factors B, C, E of the tyre parameters ``group`` (a WheelLoad's longitudinal
    tyre, the Vehicle's lateral axle tyres; their ranges :data:`spurdiff.vehicle.tyre.SHAPE_BOUNDS`),
    declared by the FMU's ``param(group, field, description, unit)``; ``who`` starts each description."""
    return [param(group, "B", f"{who}Magic Formula stiffness factor", "1"),
            param(group, "C", f"{who}Magic Formula shape factor (0 < C <= 2)", "1"),
            param(group, "E", f"{who}Magic Formula curvature factor (<= 1)", "1")]
