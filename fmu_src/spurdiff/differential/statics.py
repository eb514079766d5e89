"""Kinematics and statics of the differential (the paper's theory, corrected as in the notes).

Kinematics (:func:`spurdiff.gears.layout.kinematics`) (external meshes, planets of a pair with equal tooth counts, equal suns):
planet 1 spins relative to the carrier at ``w_1 = -(z_a/z_1) (w_A - w_c)``, planet 2 at
``w_2 = -(z_1/z_2) w_1`` and sun B follows ``w_B - w_c = -(z_a/z_b) (w_A - w_c)``; with equal suns
``w_A + w_B = 2 w_c``.

Statics with ``n`` planet pairs and the input torque ``T0`` on the carrier:

* ideal split ``T_A = T_B = T0 / 2``;
* the paper's locking coefficient ``K = (mu r_d / n) (1/(r_a + r_1) + 1/(r_b + r_2))`` and the
  torque difference it lets the pin-bushing friction hold, ``dT = K T0`` (the paper writes 6 for
  ``n``; its figures follow from 3 pairs, see docs/paper-reproduction.md). This is
  ``lockingLaw = "paper"``; the default law, pin friction from the actual pin loads (drive and
  coast differ, independent of ``n``), is derived in :mod:`spurdiff.differential.locking`;
* normal mesh forces per planet from a free-body balance of each planet:
  ``F_A1 = T_A / (n r_a cos(alpha_wA))``, ``F_B2 = T_B / (n r_b cos(alpha_wB))`` and, from the moment
  balance of planet 1 about its pin, ``F_12 r_0 cos(alpha_w0) = F_A1 r_1 cos(alpha_wA)``.
  With exact operating radii all three are equal (each planet has one base circle); the paper's
  rounded radii (52.16 / 18.84 / 55.84 mm) give its 6,898 / 6,896 / 6,899 N.
"""
from __future__ import annotations

import math

from spurdiff.differential.locking import locking_coefficients, pin_friction
from spurdiff.gears.geometry import DifferentialGeometry
from spurdiff.attrpath import record


def locking_coefficient(mu: float, r_d: float, n_pairs: int, r_a: float, r_1: float, r_b: float, r_2: float) -> float:
    """The paper's K = (mu r_d / n) (1/(r_a + r_1) + 1/(r_b + r_2)), dimensionless
    (``lockingLaw = "paper"``; see :func:`locking_coefficients_for` for the selected law)."""
    return mu * r_d / n_pairs * (1.0 / (r_a + r_1) + 1.0 / (r_b + r_2))


def torque_bias_ratio(K: float) -> float:
    """Largest ratio of the two sun torques the locking friction allows: (1 + K) / (1 - K)."""
    return (1.0 + K) / (1.0 - K)


@record(frozen=True)
class MeshForces:
    """Normal tooth forces per planet pair (N)."""

    F_A1: float
    F_B2: float
    F_12: float


def mesh_forces(T_A: float, T_B: float, n_pairs: int,
                r_a: float, alpha_wA: float, r_1: float,
                r_b: float, alpha_wB: float,
                r_0: float, alpha_w0: float) -> MeshForces:
    """Normal mesh forces from the sun torques (N m), free-body balance of the planets."""
    F_A1 = T_A / (n_pairs * r_a * math.cos(alpha_wA))
    F_B2 = T_B / (n_pairs * r_b * math.cos(alpha_wB))
    F_12 = F_A1 * r_1 * math.cos(alpha_wA) / (r_0 * math.cos(alpha_w0))
    return MeshForces(F_A1, F_B2, F_12)


def pin_friction_share(geo: DifferentialGeometry) -> float:
    """Share of planet 1's pins in the locking friction, from the terms of K:
    ``(1/(r_a + r_1)) / (1/(r_a + r_1) + 1/(r_b + r_2))``."""
    s1, s2 = 1.0 / (geo.r_a + geo.r_1), 1.0 / (geo.r_b + geo.r_2)
    return s1 / (s1 + s2)


def mesh_forces_for(geo: DifferentialGeometry, T_A: float, T_B: float) -> MeshForces:
    """Mesh forces for sun torques T_A, T_B with the operating radii of a derived geometry.

    When T_A != T_B the difference is held by the pin friction of both planets; planet 1's
    moment balance ``(F_A1 - F_12) r_b1 = M_f1`` with its share of the friction moment gives
    ``F_12 = F_A1 - share_1 (F_A1 - F_B2)`` (planet inertia neglected)."""
    f = mesh_forces(T_A, T_B, geo.table.nPairs,
                    geo.r_a, geo.meshA1.alpha_w, geo.r_1,
                    geo.r_b, geo.meshB2.alpha_w,
                    geo.mesh12.rw1, geo.mesh12.alpha_w)
    if T_A == T_B:
        return f
    F_12 = f.F_A1 - pin_friction_share(geo) * (f.F_A1 - f.F_B2)
    return MeshForces(f.F_A1, f.F_B2, F_12)


def locking_coefficients_for(p, geo: DifferentialGeometry) -> tuple[float, float]:
    """(K_drive, K_coast) of the locking law ``p.lockingLaw`` for parameters ``p``
    (:class:`spurdiff.differential.params.DifferentialParams`): the paper's K twice, or the pin-load law's
    break-away coefficients (:func:`spurdiff.differential.locking.locking_coefficients`)."""
    if p.lockingLaw == "paper":
        K = locking_coefficient(p.mu_pin, p.r_collar, geo.table.nPairs, geo.r_a, geo.r_1, geo.r_b, geo.r_2)
        return K, K
    return locking_coefficients(pin_friction(geo, p.mu_pin, p.r_collar, 0.0, "pinFriction", p.pinModel,
                                             p.pairHandedness, p.pinContactFactor), p.leadingSun)
