"""ISO 6336-1:2006 method B mesh stiffness (single stiffness c', mesh stiffness c_gamma_alpha) and
its comparison with the paper's IMPACT contact law::

    q' = 0.04723 + 0.15551/z_n1 + 0.25791/z_n2 - 0.00635 x_1 - 0.11654 x_1/z_n1 - 0.00193 x_2
         - 0.24188 x_2/z_n2 + 0.00529 x_1^2 + 0.00182 x_2^2            (pinion 1)
    c' = C_M C_R C_B / q' (E / 206000),  C_M = 0.8, C_R = 1 (solid),
    C_B = [1 + 0.5 (1.2 - h_fP/m)] [1 - 0.02 (20 deg - alpha)]
    c_gamma_alpha = c' (0.75 eps_alpha + 0.25)   (x 0.9 for eps_alpha < 1.2), per mm of face width.
"""
from __future__ import annotations

import math

from spurdiff.gears.capacity.data import MM, MPA
from spurdiff.gears.capacity.loads import nominal_mesh_forces, face_width
from spurdiff.gears.geometry import DifferentialGeometry, GearGeometry, GearTable, MeshGeometry
from spurdiff.attrpath import record

# ISO 6336-1 method B single-stiffness coefficients (q' in mm um / N)
ISO_Q = (0.04723, 0.15551, 0.25791, -0.00635, -0.11654, -0.00193, -0.24188, 0.00529, 0.00182)
C_M = 0.8            # ISO 6336-1 theoretical correction factor
C_R = 1.0            # gear blank factor, solid gears
E_REF = 206000.0     # N/mm^2, ISO 6336-1 reference modulus


def single_stiffness(z1: int, x1: float, z2: int, x2: float, m: float, alpha: float, hfP: float,
                     E: float = E_REF * MPA) -> float:
    """ISO 6336-1 method B single stiffness ``c'`` in N/(mm um) per mm of face width; the gear
    with fewer teeth is the pinion; ``hfP`` the basic rack dedendum coefficient h_fP / m."""
    if z2 < z1:
        z1, x1, z2, x2 = z2, x2, z1, x1
    c = ISO_Q
    q = (c[0] + c[1] / z1 + c[2] / z2 + c[3] * x1 + c[4] * x1 / z1 + c[5] * x2 + c[6] * x2 / z2
         + c[7] * x1 * x1 + c[8] * x2 * x2)
    C_B = (1.0 + 0.5 * (1.2 - hfP)) * (1.0 - 0.02 * (20.0 - math.degrees(alpha)))
    return C_M * C_R * C_B / q * (E / MPA) / E_REF


def mesh_stiffness(me: MeshGeometry, gg: dict[str, GearGeometry], t: GearTable, E: float = E_REF * MPA,
                   eps: float | None = None) -> tuple[float, float]:
    """(c', c_gamma_alpha) of mesh ``me`` in N/(mm um) per mm of face width (ISO 6336-1 method B);
    ``eps`` the transverse contact ratio (default: the usable one)."""
    g1, g2 = gg[me.gear1], gg[me.gear2]
    c1 = single_stiffness(g1.z, g1.x, g2.z, g2.x, t.m, t.alpha, t.hf, E)
    e = me.epsilon_usable if eps is None else eps
    cg = c1 * (0.75 * e + 0.25)
    return c1, (0.9 * cg if e < 1.2 else cg)


def impact_equivalent(k_lin: float, F0: float, e: float = 1.5) -> float:
    """IMPACT stiffness K (N/m^e) whose secant stiffness at the force ``F0`` (N) is ``k_lin`` (N/m):
    ``F0 = K d^e`` and ``F0 = k_lin d`` give ``K = k_lin^e F0^(1 - e)``."""
    return k_lin ** e * F0 ** (1.0 - e)


def impact_secant(K: float, F0: float, e: float = 1.5) -> float:
    """Secant stiffness F0 / d (N/m) of the IMPACT law ``F = K d^e`` at the force ``F0``."""
    return F0 / (F0 / K) ** (1.0 / e)


@record(frozen=True)
class StiffnessComparison:
    """One mesh's ISO 6336-1 stiffness beside the paper's IMPACT law at the force F0 (N; N/m)."""

    mesh: str
    F0: float
    c_prime: float          # N/(mm um) per mm
    c_gamma: float          # N/(mm um) per mm
    k_iso: float            # c_gamma_alpha b, N/m
    K_impact: float         # the IMPACT K in use, N/m^e
    k_impact_secant: float  # F0 / d at F0, N/m
    k_impact_tangent: float # dF/dd = e F0 / d at F0, N/m
    K_iso_equivalent: float # IMPACT K with the ISO secant stiffness at F0, N/m^e
    deflection_iso: float   # F0 / k_iso, m
    deflection_impact: float


def stiffness_comparison(geo: DifferentialGeometry, F0: dict[str, float], K: dict[str, float],
                         e: float = 1.5, E: float = E_REF * MPA) -> list[StiffnessComparison]:
    """ISO 6336-1 mesh stiffness against the IMPACT constants ``K`` (N/m^e, keys A1, B2, 12) at the
    mesh forces ``F0`` (N)."""
    out = []
    for me in geo.meshes:
        c1, cg = mesh_stiffness(me, geo.gears, geo.table, E)
        k = cg * face_width(geo, me) / MM * 1e6
        F = F0[me.name]
        Ki = K[me.name]
        ks = impact_secant(Ki, F, e)
        out.append(StiffnessComparison(me.name, F, c1, cg, k, Ki, ks, e * ks, impact_equivalent(k, F, e),
                                       F / k, F / ks))
    return out


def iso_contact_parameters(geo: DifferentialGeometry, T0: float, e: float = 1.5,
                           E: float = E_REF * MPA) -> dict[str, float]:
    """The contact level's IMPACT stiffnesses with the ISO 6336-1 mesh stiffness instead of the
    paper's ADAMS constants, as SpurDifferential parameters (``meshA1.contactStiffness``...): each
    ``K = (c_gamma_alpha b)^e F0^(1 - e)``, the secant stiffness of ISO at the nominal force F0 of
    the carrier torque ``T0`` (N m). Select them by setting these parameters (a scene's
    ``[fmus.<diff>.parameters]``); the paper's constants stay the default."""
    F = nominal_mesh_forces(geo, T0)
    out = {}
    for me in geo.meshes:
        _, cg = mesh_stiffness(me, geo.gears, geo.table, E)
        out[f"mesh{me.name}.contactStiffness"] = impact_equivalent(cg * face_width(geo, me) / MM * 1e6, F[me.name], e)
    return out


__all__ = ["single_stiffness", "mesh_stiffness", "impact_equivalent", "impact_secant", "StiffnessComparison",
           "stiffness_comparison", "iso_contact_parameters", "ISO_Q", "C_M", "C_R", "E_REF"]
