"""Force laws of the gear-mesh dynamics (plain floats, each with its partial derivatives).

Every law returns ``(F, dF/dp, dF/dv, Fc)``: the force, its partial derivatives with respect to the
penetration ``p`` and the penetration rate ``v`` (for the integrator's analytic Jacobian) and its
conservative (spring) part ``Fc`` (so that the dissipated power ``(F - Fc) v >= 0`` can be booked).

Sources (see docs/mesh-dynamics.md for the numbers):

* ADAMS ``STEP`` / ``IMPACT`` (MSC Adams documentation, function ``IMPACT``): penetration ``p > 0``,
  ``F = K p^e + STEP(p, 0, 0, d_max, C) dp/dt``, clipped at ``F >= 0``; zero when separated.
  ``STEP(x, x0, h0, x1, h1) = h0 + (h1 - h0) s^2 (3 - 2 s)``, ``s = (x - x0)/(x1 - x0)`` clamped to
  ``[0, 1]``. The damping is zero at first touch, so the force is continuous at contact onset.
* Modelica Standard Library ``Rotational.Components.ElastoBacklash``: outside the clearance
  ``Fc = k p``, ``Fd = c dp/dt``; ``F = 0`` if ``Fc + Fd <= 0`` (never pulls) else
  ``F = Fc + min(Fc, Fd)`` (damping limited so the force is continuous at first contact).
* ADAMS contact friction: ``|v| > v_d``: ``mu_d``; ``v_s < |v| < v_d``: ``STEP(|v|, v_s, mu_s, v_d,
  mu_d)``; ``|v| < v_s``: ``STEP(v, -v_s, -mu_s, v_s, mu_s)`` (signed, passes through 0, so it is a
  regularised law that creeps; this is how ADAMS does it and how the paper's model did it).
* ISO 6336-1 (method B) single-pair stiffness ``c'`` and mesh stiffness ``c_gamma_alpha``.
"""
from __future__ import annotations

import math


def step(x: float, x0: float, h0: float, x1: float, h1: float) -> float:
    """ADAMS STEP: cubic blend from h0 at x0 to h1 at x1, constant outside."""
    if x <= x0:
        return h0
    if x >= x1:
        return h1
    s = (x - x0) / (x1 - x0)
    return h0 + (h1 - h0) * s * s * (3.0 - 2.0 * s)


def step_d(x: float, x0: float, h0: float, x1: float, h1: float) -> tuple[float, float]:
    """STEP and its derivative d STEP / dx."""
    if x <= x0:
        return h0, 0.0
    if x >= x1:
        return h1, 0.0
    w = x1 - x0
    s = (x - x0) / w
    return h0 + (h1 - h0) * s * s * (3.0 - 2.0 * s), (h1 - h0) * 6.0 * s * (1.0 - s) / w


def impact(p: float, v: float, K: float, e: float, C: float, dmax: float) -> tuple[float, float, float, float]:
    """ADAMS IMPACT for penetration p (> 0 in contact) and penetration rate v = dp/dt.

    ``F = K p^e + STEP(p, 0, 0, dmax, C) v`` clipped at 0 (never pulls); 0 for ``p <= 0``.
    Returns (F, dF/dp, dF/dv, Fc) with ``Fc = K p^e``.
    """
    if p <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    pe1 = math.sqrt(p) if e == 1.5 else p ** (e - 1.0)     # Hertz's 1.5: a square root is 5x cheaper than pow
    Fc = K * pe1 * p
    if p >= dmax:
        cs, dcs = C, 0.0
    else:
        s = p / dmax
        cs = C * s * s * (3.0 - 2.0 * s)
        dcs = C * 6.0 * s * (1.0 - s) / dmax
    F = Fc + cs * v
    if F <= 0.0:
        return 0.0, 0.0, 0.0, Fc
    return F, e * K * pe1 + dcs * v, cs, Fc


def impact_potential(p: float, K: float, e: float) -> float:
    """Elastic energy of the IMPACT spring: K p^(e+1) / (e+1) for p > 0."""
    return K * p ** (e + 1.0) / (e + 1.0) if p > 0.0 else 0.0


def elasto_backlash(p: float, v: float, k: float, c: float) -> tuple[float, float, float, float]:
    """MSL ElastoBacklash on one flank: penetration p (> 0 in contact), rate v.

    ``Fc = k p``, ``Fd = c v``; ``F = 0`` if ``Fc + Fd <= 0`` else ``Fc + min(Fc, Fd)``.
    Returns (F, dF/dp, dF/dv, Fc).
    """
    if p <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    Fc = k * p
    Fd = c * v
    if Fc + Fd <= 0.0:
        return 0.0, 0.0, 0.0, Fc
    if Fd < Fc:
        return Fc + Fd, k, c, Fc
    return 2.0 * Fc, 2.0 * k, 0.0, Fc


def friction_coefficient(v: float, mu_s: float, mu_d: float, v_s: float, v_d: float) -> tuple[float, float]:
    """Signed ADAMS friction coefficient mu(v) (sign of v) and d mu / dv.

    ``|v| <= v_s``: ``STEP(v, -v_s, -mu_s, v_s, mu_s)``; ``v_s < |v| < v_d``:
    ``sign(v) STEP(|v|, v_s, mu_s, v_d, mu_d)``; beyond: ``sign(v) mu_d``.
    """
    a = v if v >= 0.0 else -v
    if a <= v_s:
        return step_d(v, -v_s, -mu_s, v_s, mu_s)
    if a < v_d:
        m, dm = step_d(a, v_s, mu_s, v_d, mu_d)
        return (m, dm) if v > 0.0 else (-m, dm)
    return (mu_d if v > 0.0 else -mu_d), 0.0


# ---------------------------------------------------------------- ISO 6336-1 mesh stiffness
ISO_C = (0.04723, 0.15551, 0.25791, -0.00635, -0.11654, -0.00193, -0.24188, 0.00529, 0.00182)
C_M = 0.8   # ISO 6336-1 theoretical correction factor (solid disc gears)
C_R = 1.0   # gear blank factor (solid gears)
E_ST = 206000.0  # N/mm^2, reference modulus of ISO 6336-1


def iso6336_q(zn1: int, x1: float, zn2: int, x2: float) -> float:
    """Minimum flexibility q' of a tooth pair (mm um / N), ISO 6336-1 method B, external gears.
    Index 1 is the pinion (smaller gear)."""
    c = ISO_C
    return (c[0] + c[1] / zn1 + c[2] / zn2 + c[3] * x1 + c[4] * x1 / zn1 + c[5] * x2 + c[6] * x2 / zn2
            + c[7] * x1 * x1 + c[8] * x2 * x2)


def iso6336_stiffness(z1: int, x1: float, z2: int, x2: float, eps_alpha: float, E: float,
                      hfP_over_m: float = 1.25, alpha_P_deg: float = 20.0) -> tuple[float, float]:
    """ISO 6336-1 method B: (c', c_gamma_alpha) in N/(mm um) per mm of face width.

    ``c'_th = 1/q'``, ``c' = c'_th C_M C_R C_B (E / 206000)`` with
    ``C_B = [1 + 0.5 (1.2 - h_fP/m)] [1 - 0.02 (20 deg - alpha_P)]``,
    ``c_gamma_alpha = c' (0.75 eps_alpha + 0.25)`` (x 0.9 if eps_alpha < 1.2). ``E`` in Pa.
    The pinion (gear with fewer teeth) takes index 1 in q'.
    """
    if z2 < z1:
        z1, x1, z2, x2 = z2, x2, z1, x1
    q = iso6336_q(z1, x1, z2, x2)
    C_B = (1.0 + 0.5 * (1.2 - hfP_over_m)) * (1.0 - 0.02 * (20.0 - alpha_P_deg))
    c1 = (1.0 / q) * C_M * C_R * C_B * (E / 1e6) / E_ST
    cg = c1 * (0.75 * eps_alpha + 0.25)
    if eps_alpha < 1.2:
        cg *= 0.9
    return c1, cg


def iso10064_backlash(a: float, m: float) -> float:
    """Minimum normal backlash (m) recommended by ANSI/AGMA 2002-B88 and ISO/TR 10064-2 for
    industrial gears: ``j_bn,min = 2/3 (0.06 + 0.0005 a + 0.03 m_n)`` mm with a, m_n in mm."""
    return 2.0 / 3.0 * (0.06 + 0.0005 * a * 1e3 + 0.03 * m * 1e3) * 1e-3
