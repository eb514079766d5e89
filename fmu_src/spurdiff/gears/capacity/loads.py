"""What a mesh is rated at: its face width (the axial overlap of its two gears,
:mod:`spurdiff.gears.axial`), the pitch-line speed of the planets relative to the carrier (for
K_v), and the nominal mesh forces of a carrier torque split equally (the locked split at
break-away, with the locking law, is :func:`spurdiff.differential.watches.rating_forces`)."""
from __future__ import annotations

import math

from spurdiff.gears.axial import axial_layout
from spurdiff.gears.geometry import DifferentialGeometry, MeshGeometry


def face_width(geo: DifferentialGeometry, me: MeshGeometry) -> float:
    """The face width (m) mesh ``me`` is rated with: the axial overlap of its gears (never more than
    the narrower gear); a mesh whose gears do not overlap has the stack-up error of
    :mod:`spurdiff.gears.axial` and is rated with the narrower gear's width."""
    w = axial_layout(geo).mesh_width(me.name)
    return w if 0.0 < w <= me.b else me.b


def face_widths(geo: DifferentialGeometry) -> dict[str, float]:
    """:func:`face_width` of the three meshes (keys A1, B2, 12)."""
    return {me.name: face_width(geo, me) for me in geo.meshes}


def pitch_line_speed(geo: DifferentialGeometry, w_rel: float) -> float:
    """Pitch-line speed (m/s) of every mesh when sun A turns at ``w_rel`` (rad/s) relative to the
    carrier: the reference circles of a gear chain roll at one speed, ``m z_sunA |w_rel| / 2``
    (planet i spins at ``z_sun / z_i`` times the sun's relative speed; equal suns)."""
    t = geo.table
    return 0.5 * t.m * t.sunA.z * abs(w_rel)


def nominal_mesh_forces(geo: DifferentialGeometry, T0: float) -> dict[str, float]:
    """Normal force per mesh and planet pair (N) for carrier torque ``T0`` (N m) split equally
    (no locking): ``F_A1 = T0 / (2 n r_b,sunA)``, ``F_B2 = T0 / (2 n r_b,sunB)``, ``F_12 = F_A1``
    (planet 1's moment balance: both its meshes act on its one base circle)."""
    n = geo.table.nPairs
    F_A1 = abs(T0) / (2.0 * n * geo.meshA1.rb1)
    F_B2 = abs(T0) / (2.0 * n * geo.meshB2.rb1)
    return {"A1": F_A1, "B2": F_B2, "12": F_A1}


def scaled(forces: dict[str, float], k: float) -> dict[str, float]:
    """``forces`` times ``k``."""
    return {key: k * abs(F) for key, F in forces.items()}


__all__ = ["face_width", "face_widths", "pitch_line_speed", "nominal_mesh_forces", "scaled"]
