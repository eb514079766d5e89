"""The ISO 6336 factors of one spur mesh, each a plain function (N, mm, um and N/mm^2 inside, as
the standard's coefficients are written; docs/capacity.md gives each beside its test):

* ``K_v`` dynamic factor, ISO 6336-1 method C:
  ``1 + (K_1 / (K_A F_t / b) + K_2) z_1 v / 100 sqrt(u^2 / (1 + u^2))`` (``K_A F_t / b >= 100 N/mm``,
  ``K_1`` by accuracy grade, ``K_2 = 0.0193`` spur, ``v`` the pitch-line speed in m/s, ``z_1`` the pinion);
* ``K_Hbeta`` face load factor, method C: ``1 + c_gamma_beta F_betay / (2 F_m / b)`` (``<= 2``), else
  ``sqrt(2 c_gamma_beta F_betay / (F_m / b))``, ``c_gamma_beta = 0.85 c_gamma_alpha``;
  ``K_Fbeta = K_Hbeta^N_F``, ``N_F = (b/h)^2 / (1 + b/h + (b/h)^2)``, ``b/h >= 3``;
* ``K_Halpha = K_Falpha`` transverse load factor, method B:
  ``eps_gamma / 2 (0.9 + 0.4 c_gamma_alpha (f_pb - y_alpha) / (F_tH / b))``, ``y_alpha = 0.075 f_pb``
  (<= 3 um), limited to ``1 .. eps_gamma / (eps_alpha Z_eps^2)`` and ``eps_gamma / (0.25 eps_alpha + 0.75)``;
* ``Z_H``, ``Z_E``, ``Z_eps`` (ISO 6336-2), ``Z_B`` / ``Z_D`` from the radii of curvature at the inner
  points of single contact; ``Y_F``, ``Y_S`` (ISO 6336-3 method B, 30-deg tangent), ``Y_B`` rim factor.
"""
from __future__ import annotations

import math
from functools import lru_cache

from spurdiff.gears.capacity.data import K1_SPUR, K2_SPUR, Material
from spurdiff.gears.geometry import MeshGeometry, inv
from spurdiff.attrpath import record


def zone_factor(alpha_w: float, alpha: float) -> float:
    """Z_H (spur): ``sqrt(2 cos(alpha_w) / (cos^2(alpha) sin(alpha_w)))``."""
    return math.sqrt(2.0 * math.cos(alpha_w) / (math.cos(alpha) ** 2 * math.sin(alpha_w)))


def contact_ratio_factor(eps: float) -> float:
    """Z_eps (spur): ``sqrt((4 - eps_alpha) / 3)``."""
    return math.sqrt((4.0 - eps) / 3.0)


def elasticity_factor(m1: Material, m2: Material) -> float:
    """Z_E in sqrt(Pa): ``sqrt(1 / (pi ((1 - nu1^2)/E1 + (1 - nu2^2)/E2)))``."""
    return math.sqrt(1.0 / (math.pi * ((1.0 - m1.nu ** 2) / m1.E + (1.0 - m2.nu ** 2) / m2.E)))


def dynamic_factor(grade: int, K_A: float, F_t: float, b_mm: float, z1: int, u: float, v: float) -> float:
    """K_v, ISO 6336-1 method C, spur: ``F_t`` N, ``b_mm`` mm, ``z1`` the pinion's teeth, ``u >= 1``
    the tooth ratio, ``v`` the pitch-line speed in m/s."""
    w = max(K_A * F_t / b_mm, 100.0)
    return 1.0 + (K1_SPUR[grade] / w + K2_SPUR) * z1 * v / 100.0 * math.sqrt(u * u / (1.0 + u * u))


def face_load_factors(F_t: float, b_mm: float, h_mm: float, K_A: float, K_v: float, c_gamma: float,
                      F_betay_um: float) -> tuple[float, float]:
    """(K_Hbeta, K_Fbeta), ISO 6336-1 method C: ``h_mm`` the tooth depth (the deeper-rooted gear's,
    mm) for ``N_F``; ``c_gamma`` in N/(mm um)."""
    F_m_b = max(F_t * K_A * K_v / b_mm, 1e-9)
    c_gb = 0.85 * c_gamma
    r = c_gb * F_betay_um / (2.0 * F_m_b)
    K_Hbeta = 1.0 + r if r <= 1.0 else math.sqrt(2.0 * c_gb * F_betay_um / F_m_b)
    bh = max(b_mm / h_mm, 3.0)
    N_F = bh * bh / (1.0 + bh + bh * bh)
    return K_Hbeta, K_Hbeta ** N_F


def transverse_load_factors(F_t: float, b_mm: float, K_A: float, K_v: float, K_Hbeta: float, c_gamma: float,
                            f_pb_um: float, eps: float) -> tuple[float, float]:
    """(K_Halpha, K_Falpha), ISO 6336-1 method B, spur (``eps_gamma = eps_alpha = eps``)."""
    F_tH_b = max(F_t * K_A * K_v * K_Hbeta / b_mm, 1e-9)
    y_alpha = min(0.075 * f_pb_um, 3.0)
    K_al = eps / 2.0 * (0.9 + 0.4 * c_gamma * (f_pb_um - y_alpha) / F_tH_b)
    Z_eps = contact_ratio_factor(eps)
    return min(max(K_al, 1.0), eps / (eps * Z_eps ** 2)), min(max(K_al, 1.0), eps / (0.25 * eps + 0.75))


@record(frozen=True)
class ToothForm:
    """ISO 6336-3 method B root section: form factor Y_F, stress correction Y_S, the 30-deg
    tangent section s_Fn, bending arm h_Fe, fillet radius rho_F (m), for one load point."""

    Y_F: float
    Y_S: float
    s_Fn: float
    h_Fe: float
    rho_F: float
    q_s: float


@lru_cache(maxsize=256)
def tooth_form(z: int, x: float, m: float, alpha: float, haP0: float, rhoaP0: float, d_en: float) -> ToothForm:
    """Y_F and Y_S of a rack-generated external spur gear (tool addendum ``haP0 m``, tip radius
    ``rhoaP0 m``) loaded at diameter ``d_en`` (ISO 6336-3:2006 method B, no protuberance). (Cached: a
    set's rating and its limited life ask for the same few points some 80 times at an FMU's start.)"""
    hfP, rho = haP0, rhoaP0                      # in modules
    E = math.pi / 4.0 - hfP * math.tan(alpha) - (1.0 - math.sin(alpha)) * rho / math.cos(alpha)
    G = rho - hfP + x
    H = 2.0 / z * (math.pi / 2.0 - E) - math.pi / 3.0
    th = math.pi / 6.0
    for _ in range(200):
        nxt = 2.0 * G / z * math.tan(th) - H
        if abs(nxt - th) < 1e-15:
            th = nxt
            break
        th = nxt
    s_Fn = z * math.sin(math.pi / 3.0 - th) + math.sqrt(3.0) * (G / math.cos(th) - rho)
    rho_F = rho + 2.0 * G * G / (math.cos(th) * (z * math.cos(th) ** 2 - 2.0 * G))
    d_b = m * z * math.cos(alpha)
    a_en = math.acos(min(1.0, d_b / d_en))
    g_e = (0.5 * math.pi + 2.0 * x * math.tan(alpha)) / z + inv(alpha) - inv(a_en)
    a_Fen = a_en - g_e
    h_Fe = 0.5 * ((math.cos(g_e) - math.sin(g_e) * math.tan(a_Fen)) * d_en / m - z * math.cos(math.pi / 3.0 - th)
                  - G / math.cos(th) + rho)
    Y_F = 6.0 * h_Fe * math.cos(a_Fen) / (s_Fn ** 2 * math.cos(alpha))
    L = s_Fn / h_Fe
    q_s = s_Fn / (2.0 * rho_F)
    Y_S = (1.2 + 0.13 * L) * q_s ** (1.0 / (1.21 + 2.3 / L))
    return ToothForm(Y_F, Y_S, s_Fn * m, h_Fe * m, rho_F * m, q_s)


def rim_factor(s_R: float, h_t: float) -> float:
    """ISO 6336-3:2006 rim thickness factor Y_B: 1 for s_R / h_t >= 1.2, ``1.6 ln(2.242 h_t / s_R)``
    down to 0.5 (below: outside the standard; the formula is continued and a finding says so)."""
    r = s_R / h_t
    if r >= 1.2:
        return 1.0
    return 1.6 * math.log(2.242 / max(r, 1e-6))


def single_contact_factor(me: MeshGeometry, l: float) -> float:
    """sqrt(rho_C1 rho_C2 / (rho_1 rho_2)) at distance ``l`` from gear 1's base tangent point."""
    L = me.a * math.sin(me.alpha_w)
    c1, c2 = me.rb1 * math.tan(me.alpha_w), me.rb2 * math.tan(me.alpha_w)
    r1, r2 = l, L - l
    if r1 <= 0.0 or r2 <= 0.0:
        return math.inf
    return math.sqrt(c1 * c2 / (r1 * r2))


__all__ = ["zone_factor", "contact_ratio_factor", "elasticity_factor", "dynamic_factor", "face_load_factors",
           "transverse_load_factors", "ToothForm", "tooth_form", "rim_factor", "single_contact_factor"]
