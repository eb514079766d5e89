"""The carrier and sun (flange) accelerations of a mesh level at its present state, from its
right-hand side (the inputs and friction modes held): what the FMI 3.0 output derivatives of the
speeds are at the end of a step (:mod:`spurdiff.differential.derivatives`)."""
from __future__ import annotations

from spurdiff.differential.mesh.layout import VA, VB, WC


def sun_accelerations(model) -> tuple[float, float, float]:
    """(a_c, a_L, a_R) of a :class:`~spurdiff.differential.mesh.MeshDifferential`; the carrier's is 0
    under the speed drive (the reached speed held, as its outputs report)."""
    f = model.rhs(model.t, model.y)
    ac = 0.0 if model.speed_drive else float(f[WC])
    return ac, ac + float(f[VA]), ac + float(f[VB])


__all__ = ["sun_accelerations"]
