"""Load capacity of the differential's spur meshes: contact (pitting) and root (bending) stress by
ISO 6336 method B, the ISO 6336-1 mesh stiffness, and the safety factors of each gear of each mesh.

Units: inputs and outputs in SI (N, m, Pa); the ISO formulas are written in N, mm, um and N/mm^2
inside (their coefficients are for those units). Materials and rating conditions come from
``spurdiff/data/materials.toml`` (with sources). The derivation and every number's check: docs/capacity.md.

Contact stress, ISO 6336-2:2006 method B (spur, beta = 0)::

    sigma_H0 = Z_H Z_E Z_eps sqrt(F_t / (d_1 b) (u + 1) / u)     F_t = F_n cos(alpha) (reference circle)
    sigma_H  = Z_B|Z_D sigma_H0 sqrt(K_A K_v K_Hbeta K_Halpha)
    Z_H = sqrt(2 cos(alpha_w) / (cos^2(alpha) sin(alpha_w))),  Z_E = sqrt(1 / (pi ((1-nu1^2)/E1 + (1-nu2^2)/E2)))
    Z_eps = sqrt((4 - eps_alpha) / 3)
    Z_B, Z_D = sqrt(rho_C1 rho_C2 / (rho_1 rho_2)) at the inner point of single contact of each gear (>= 1)

``(u + 1) / (u d_1) = 1/d_1 + 1/d_2``, so the formula is the same whichever gear is the pinion; it
is Hertz's line contact at the pitch point (``sigma = sqrt(F_n E* / (2 pi b rho_red))`` with
``E* = 1/((1-nu1^2)/E1 + (1-nu2^2)/E2)``... written out in the tests as the independent check).
The single-contact factors use the usable path of contact (:attr:`MeshGeometry.usable_path`: the
tips as given, each flank from its form circle), which is ISO's ``sqrt(d_a^2/d_b^2 - 1) - 2 pi / z``
construction when the tips do not interfere.

Root stress, ISO 6336-3:2006 method B (load at the outer point of single tooth contact)::

    sigma_F = F_t / (b m) Y_F Y_S Y_beta Y_B Y_DT K_A K_v K_Fbeta K_Falpha
    Y_F, Y_S from the 30-deg tangent to the rack-generated fillet (E, G, H, theta iteration);
    Y_B rim factor from the bore (s_R / h_t); Y_beta = Y_DT = 1 (spur, eps_alpha <= 2.05)

and, as a cross-check, the tip-load variant (ISO 6336-3 method C / DIN 3990): ``Y_Fa Y_Sa Y_eps`` with
``Y_eps = 0.25 + 0.75 / eps_alpha``.

Load factors, ISO 6336-1:2006:

* ``K_A`` application factor: data (uniform load, 1.0; a simulated run's forces carry their dynamics);
* ``K_v`` dynamic factor, method C: ``1 + (K_1 / (K_A F_t / b) + K_2) z_1 v / 100 sqrt(u^2 / (1 + u^2))``
  (``K_A F_t / b >= 100 N/mm``; ``K_1`` by accuracy grade, ``K_2 = 0.0193`` spur) with ``v`` the pitch-line
  speed relative to the carrier (a differential's planets turn slowly: ``K_v`` is about 1);
* ``K_Hbeta`` face load factor, method C: ``1 + c_gamma_beta F_betay / (2 F_m / b)`` (``<= 2``), else
  ``sqrt(2 c_gamma_beta F_betay / (F_m / b))``, ``c_gamma_beta = 0.85 c_gamma_alpha``,
  ``F_m = F_t K_A K_v``; ``K_Fbeta = K_Hbeta^N_F``, ``N_F = (b/h)^2 / (1 + b/h + (b/h)^2)``, ``b/h >= 3``;
* ``K_Halpha = K_Falpha`` transverse load factor, method B (``eps_gamma <= 2``):
  ``eps_gamma / 2 (0.9 + 0.4 c_gamma_alpha (f_pb - y_alpha) / (F_tH / b))``, ``y_alpha = 0.075 f_pb``,
  ``F_tH = F_t K_A K_v K_Hbeta``, limited to ``1 <= K_Halpha <= eps_gamma / (eps_alpha Z_eps^2)`` and
  ``K_Falpha <= eps_gamma / (0.25 eps_alpha + 0.75)``.

Mesh stiffness, ISO 6336-1:2006 method B: ``q' = 0.04723 + 0.15551/z_n1 + 0.25791/z_n2 - 0.00635 x_1
- 0.11654 x_1/z_n1 - 0.00193 x_2 - 0.24188 x_2/z_n2 + 0.00529 x_1^2 + 0.00182 x_2^2`` (pinion 1),
``c' = C_M C_R C_B / q' (E / 206000)``, ``C_M = 0.8``, ``C_R = 1`` (solid), ``C_B = [1 + 0.5 (1.2 - h_fP/m)]
[1 - 0.02 (20 deg - alpha)]``, ``c_gamma_alpha = c' (0.75 eps_alpha + 0.25)`` (x 0.9 for eps_alpha < 1.2); per mm of face width.

Permissible: ``sigma_HG = sigma_Hlim Z_NT Z_L Z_v Z_R Z_W Z_X``, ``sigma_FG = sigma_Flim Y_ST Y_NT
Y_deltarelT Y_RrelT Y_X``; ``S_H = sigma_HG / sigma_H``, ``S_F = sigma_FG / sigma_F`` for endurance
(``Z_NT = Y_NT = 1``, long life; the planets' root strength times ``Y_M = 0.7``: their teeth are bent
one way in one mesh and back in the other) and static stress (``Z_NT``, ``Y_NT`` of the material's
static line).
"""
from __future__ import annotations

import copy
import math
import tomllib
from dataclasses import dataclass, field, replace
from functools import lru_cache

from spurdiff.bounds import Bound
from spurdiff.datafile import DATA_FOLDER
from spurdiff.errors import ParameterError, require_finite
from spurdiff.gears.geometry import DifferentialGeometry, Finding, GearGeometry, GearTable, MeshGeometry, inv

MATERIALS_FILE = "materials.toml"
# read once at import, from this package's own data folder (see spurdiff.datafile)
_MATERIALS_TEXT = (DATA_FOLDER / MATERIALS_FILE).read_text(encoding="utf-8")

MM = 1e-3
MPA = 1e6
# ISO 6336-1 method B single-stiffness coefficients (q' in mm um / N)
ISO_Q = (0.04723, 0.15551, 0.25791, -0.00635, -0.11654, -0.00193, -0.24188, 0.00529, 0.00182)
C_M = 0.8            # ISO 6336-1 theoretical correction factor
C_R = 1.0            # gear blank factor, solid gears
E_REF = 206000.0     # N/mm^2, ISO 6336-1 reference modulus
# ISO 6336-1 method C dynamic factor: K_1 for spur gears by ISO 1328 accuracy grade, K_2 (spur)
K1_SPUR = {3: 2.1, 4: 3.9, 5: 7.5, 6: 14.9, 7: 26.8, 8: 39.1, 9: 52.8, 10: 76.6, 11: 102.6, 12: 146.3}
K2_SPUR = 0.0193


# ------------------------------------------------------------------ data
@dataclass(frozen=True)
class Material:
    """A gear material: elastic constants (Pa, 1), endurance limits (Pa), static life factors."""

    name: str
    description: str
    E: float
    nu: float
    sigma_Hlim: float
    sigma_Flim: float
    Z_NT_static: float
    Y_NT_static: float


@dataclass(frozen=True)
class Conditions:
    """Rating conditions (ISO 6336 factors not computed from the geometry)."""

    K_A: float = 1.0
    grade: int = 6
    f_pb_um: float = 8.0
    F_betay_um: float = 10.0
    Z_LvR: float = 0.92
    Z_W: float = 1.0
    Z_X: float = 1.0
    Y_ST: float = 2.0
    Y_deltarelT: float = 1.0
    Y_RrelT: float = 1.0
    Y_X: float = 1.0
    Y_M_reversed: float = 0.7   # idlers (teeth bent both ways): sigma_Flim times this, long life
    v: float = 0.0         # pitch-line speed relative to the carrier, m/s (K_v)

    def validate(self) -> None:
        if not (math.isfinite(self.K_A) and self.K_A >= 1.0):
            raise ParameterError("capacity.K_A", self.K_A, ">= 1 (ISO 6336-1 application factor)")
        if self.grade not in K1_SPUR:
            raise ParameterError("capacity.grade", self.grade, f"an ISO 1328 accuracy grade {min(K1_SPUR)} .. {max(K1_SPUR)}")
        for name in ("f_pb_um", "F_betay_um", "v"):
            v = require_finite(f"capacity.{name}", getattr(self, name))
            if v < 0.0:
                raise ParameterError(f"capacity.{name}", v, ">= 0")


@dataclass(frozen=True)
class CapacityParams:
    """What an FMU rates its gear set with: the carrier torque ``T0`` (N m) of the safety factors
    and of the stress scaling, and the material's name (defaults: ``materials.toml``)."""

    T0: float = tomllib.loads(_MATERIALS_TEXT)["rating"]["T0"]
    material: str = tomllib.loads(_MATERIALS_TEXT)["default"]
    bushingWall: float = 0.0     # m, wall of the planets' pin bushings: the bore is 2 (r_j + bushingWall)

    # the fields' ranges (spurdiff.bounds: checked where the FMU's capacity watch is built, and its min/max)
    BOUNDS = {"T0": Bound(0.0, lo_open=True), "bushingWall": Bound(0.0, 0.1, hi_open=True, allowed=">= 0 m and < 0.1 m")}


def pin_bores(journal_radius: float, bushing_wall: float) -> dict[str, float] | None:
    """Bore diameters (m) of the planets, which turn on pins of ``journal_radius`` in bushings of
    ``bushing_wall`` (the rims under their roots set the rim factor Y_B); None without pins."""
    if not journal_radius > 0.0:
        return None
    bore = 2.0 * (journal_radius + bushing_wall)
    return {"planet1": bore, "planet2": bore}


def materials_data() -> dict:
    """The bundled ``materials.toml`` as a dict (the caller's own copy; parsed once per process)."""
    return copy.deepcopy(_materials_parsed())


@lru_cache(maxsize=None)
def _materials_parsed() -> dict:
    return tomllib.loads(_MATERIALS_TEXT)


def material(name: str | None = None) -> Material:
    """The material ``name`` of ``materials.toml`` (None: its ``default``)."""
    data = materials_data()
    name = name or data["default"]
    table = data["material"]
    if name not in table:
        raise ParameterError("capacity.material", name, "one of " + ", ".join(sorted(table)))
    return Material(name=name, **table[name])


def conditions(**changes) -> Conditions:
    """The rating conditions of ``materials.toml`` with ``changes``."""
    c = replace(Conditions(**materials_data()["conditions"]), **changes)
    c.validate()
    return c


# ------------------------------------------------------------------ ISO 6336-1 stiffness
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


@dataclass(frozen=True)
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
        k = cg * me.b / MM * 1e6
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
        out[f"mesh{me.name}.contactStiffness"] = impact_equivalent(cg * me.b / MM * 1e6, F[me.name], e)
    return out


# ------------------------------------------------------------------ ISO 6336-3 tooth form
@dataclass(frozen=True)
class ToothForm:
    """ISO 6336-3 method B root section: form factor Y_F, stress correction Y_S, the 30-deg
    tangent section s_Fn, bending arm h_Fe, fillet radius rho_F (m), for one load point."""

    Y_F: float
    Y_S: float
    s_Fn: float
    h_Fe: float
    rho_F: float
    q_s: float


def tooth_form(z: int, x: float, m: float, alpha: float, haP0: float, rhoaP0: float, d_en: float) -> ToothForm:
    """Y_F and Y_S of a rack-generated external spur gear (tool addendum ``haP0 m``, tip radius
    ``rhoaP0 m``) loaded at diameter ``d_en`` (ISO 6336-3:2006 method B, no protuberance)."""
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


# ------------------------------------------------------------------ one mesh
@dataclass(frozen=True)
class GearRating:
    """Stresses and safety factors of one gear in one mesh (Pa, 1)."""

    gear: str
    sigma_H: float
    sigma_F: float
    Z_BD: float          # Z_B (first gear) or Z_D (second gear)
    Y_F: float
    Y_S: float
    Y_Fa: float          # tip-load form factor (method C cross-check)
    Y_Sa: float
    Y_B: float
    sigma_F_tip: float   # root stress with the load at the tip, Y_Fa Y_Sa Y_eps (cross-check)
    S_H: float           # endurance
    S_F: float
    S_H_static: float
    S_F_static: float
    backup_ratio: float  # s_R / h_t (inf: solid)


@dataclass(frozen=True)
class MeshRating:
    """ISO 6336 rating of one mesh at normal force F_n (N)."""

    mesh: str
    F_n: float
    F_t: float           # at the reference circle, F_n cos(alpha)
    Z_H: float
    Z_E: float
    Z_eps: float
    K_A: float
    K_v: float
    K_Hbeta: float
    K_Fbeta: float
    K_Halpha: float
    K_Falpha: float
    Y_eps: float
    sigma_H0: float      # nominal contact stress at the pitch point
    c_prime: float       # N/(mm um) per mm
    c_gamma: float       # N/(mm um) per mm
    k_mesh: float        # c_gamma_alpha b, N/m
    eps_alpha: float     # usable transverse contact ratio
    gears: tuple[GearRating, GearRating]

    @property
    def sigma_H(self) -> float:
        return max(g.sigma_H for g in self.gears)

    @property
    def sigma_F(self) -> float:
        return max(g.sigma_F for g in self.gears)


def _pitch_point_factor(me: MeshGeometry, l: float) -> float:
    """sqrt(rho_C1 rho_C2 / (rho_1 rho_2)) at distance ``l`` from gear 1's base tangent point."""
    L = me.a * math.sin(me.alpha_w)
    c1, c2 = me.rb1 * math.tan(me.alpha_w), me.rb2 * math.tan(me.alpha_w)
    r1, r2 = l, L - l
    if r1 <= 0.0 or r2 <= 0.0:
        return math.inf
    return math.sqrt(c1 * c2 / (r1 * r2))


def elasticity_factor(m1: Material, m2: Material) -> float:
    """Z_E in sqrt(Pa): ``sqrt(1 / (pi ((1 - nu1^2)/E1 + (1 - nu2^2)/E2)))``."""
    return math.sqrt(1.0 / (math.pi * ((1.0 - m1.nu ** 2) / m1.E + (1.0 - m2.nu ** 2) / m2.E)))


IDLERS = ("planet1", "planet2")   # the differential's planets: each tooth loaded on both flanks


def rate_mesh(me: MeshGeometry, gg: dict[str, GearGeometry], t: GearTable, F_n: float, mat: Material,
              cond: Conditions, bores: dict[str, float] | None = None,
              idlers: tuple[str, ...] = IDLERS) -> MeshRating:
    """ISO 6336 method B rating of mesh ``me`` under normal force ``F_n`` (N, per mesh, its sign
    ignored); ``bores``: bore diameters (m) of gears that are rims on a pin (Y_B); ``idlers``: gears
    whose teeth are bent both ways (long-life root strength times ``Y_M_reversed``)."""
    F_n = abs(float(F_n))
    g1, g2 = gg[me.gear1], gg[me.gear2]
    m, alpha = t.m, t.alpha
    b = me.b
    b_mm = b / MM
    aw = me.alpha_w
    eps = me.epsilon_usable
    L = me.a * math.sin(aw)
    l0, l1 = me.usable_path
    pb = me.pb
    Z_H = math.sqrt(2.0 * math.cos(aw) / (math.cos(alpha) ** 2 * math.sin(aw)))
    Z_E = elasticity_factor(mat, mat)
    Z_eps = math.sqrt((4.0 - eps) / 3.0)
    F_t = F_n * math.cos(alpha)
    d1, d2 = 2.0 * g1.r, 2.0 * g2.r
    sigma_H0 = Z_H * Z_E * Z_eps * math.sqrt(F_t / b * (1.0 / d1 + 1.0 / d2))
    # K_v (method C), pinion = fewer teeth
    zp, zw = min(g1.z, g2.z), max(g1.z, g2.z)
    u = zw / zp
    w = max(cond.K_A * F_t / b_mm, 100.0)
    K_v = 1.0 + (K1_SPUR[cond.grade] / w + K2_SPUR) * zp * cond.v / 100.0 * math.sqrt(u * u / (1.0 + u * u))
    c_prime, c_gamma = mesh_stiffness(me, gg, t, mat.E, eps)
    # K_Hbeta (method C)
    F_m_b = max(F_t * cond.K_A * K_v / b_mm, 1e-9)
    c_gb = 0.85 * c_gamma
    r = c_gb * cond.F_betay_um / (2.0 * F_m_b)
    K_Hbeta = 1.0 + r if r <= 1.0 else math.sqrt(2.0 * c_gb * cond.F_betay_um / F_m_b)
    h = min((g.ra - g.rf) for g in (g1, g2))
    bh = max(b / h, 3.0)
    N_F = bh * bh / (1.0 + bh + bh * bh)
    K_Fbeta = K_Hbeta ** N_F
    # K_Halpha (method B), spur: eps_gamma = eps_alpha
    F_tH_b = max(F_t * cond.K_A * K_v * K_Hbeta / b_mm, 1e-9)
    y_alpha = min(0.075 * cond.f_pb_um, 3.0)
    K_al = eps / 2.0 * (0.9 + 0.4 * c_gamma * (cond.f_pb_um - y_alpha) / F_tH_b)
    K_Halpha = min(max(K_al, 1.0), eps / (eps * Z_eps ** 2))
    K_Falpha = min(max(K_al, 1.0), eps / (0.25 * eps + 0.75))
    Y_eps = 0.25 + 0.75 / eps
    KH = cond.K_A * K_v * K_Hbeta * K_Halpha
    KF = cond.K_A * K_v * K_Fbeta * K_Falpha
    sHG = mat.sigma_Hlim * cond.Z_LvR * cond.Z_W * cond.Z_X
    sFG = mat.sigma_Flim * cond.Y_ST * cond.Y_deltarelT * cond.Y_RrelT * cond.Y_X
    ratings = []
    for k, g in enumerate((g1, g2)):
        # inner point of single contact (Z_B / Z_D) and outer point (load point of Y_F), as
        # distances from this gear's base tangent point
        if k == 0:
            l_inner, l_outer = l1 - pb, l0 + pb
            Z_BD = max(1.0, _pitch_point_factor(me, l_inner))
            rho_outer, rho_tip = l_outer, l1
        else:
            l_inner = l0 + pb
            Z_BD = max(1.0, _pitch_point_factor(me, l_inner))
            rho_outer, rho_tip = L - (l1 - pb), L - l0
        d_en = 2.0 * math.hypot(g.rb, rho_outer)
        d_tip = 2.0 * math.hypot(g.rb, rho_tip)
        tf = tooth_form(g.z, g.x, m, alpha, t.haP0, t.rhoaP0, d_en)
        tf_a = tooth_form(g.z, g.x, m, alpha, t.haP0, t.rhoaP0, d_tip)
        h_t = g.ra - g.rf
        bore = (bores or {}).get(g.name, 0.0)
        s_R = g.rf - bore / 2.0 if bore > 0.0 else math.inf
        Y_B = rim_factor(s_R, h_t) if bore > 0.0 else 1.0
        sigma_H = Z_BD * sigma_H0 * math.sqrt(KH)
        sF0 = F_t / (b * m) * Y_B
        sigma_F = sF0 * tf.Y_F * tf.Y_S * KF
        sigma_F_tip = sF0 * tf_a.Y_F * tf_a.Y_S * Y_eps * KF
        sFG_life = sFG * (cond.Y_M_reversed if g.name in idlers else 1.0)
        ratings.append(GearRating(
            g.name, sigma_H, sigma_F, Z_BD, tf.Y_F, tf.Y_S, tf_a.Y_F, tf_a.Y_S, Y_B, sigma_F_tip,
            S_H=sHG / sigma_H if sigma_H > 0 else math.inf,
            S_F=sFG_life / sigma_F if sigma_F > 0 else math.inf,
            S_H_static=sHG * mat.Z_NT_static / sigma_H if sigma_H > 0 else math.inf,
            S_F_static=sFG * mat.Y_NT_static / sigma_F if sigma_F > 0 else math.inf,
            backup_ratio=s_R / h_t))
    return MeshRating(me.name, F_n, F_t, Z_H, Z_E, Z_eps, cond.K_A, K_v, K_Hbeta, K_Fbeta, K_Halpha, K_Falpha,
                      Y_eps, sigma_H0, c_prime, c_gamma, c_gamma * b_mm * 1e6, eps, tuple(ratings))


# ------------------------------------------------------------------ the differential
def nominal_mesh_forces(geo: DifferentialGeometry, T0: float) -> dict[str, float]:
    """Normal force per mesh and planet pair (N) for carrier torque ``T0`` (N m) split equally
    (no locking): ``F_A1 = T0 / (2 n r_b,sunA)``, ``F_B2 = T0 / (2 n r_b,sunB)``, ``F_12 = F_A1``
    (planet 1's moment balance: both its meshes act on its one base circle)."""
    n = geo.table.nPairs
    F_A1 = abs(T0) / (2.0 * n * geo.meshA1.rb1)
    F_B2 = abs(T0) / (2.0 * n * geo.meshB2.rb1)
    return {"A1": F_A1, "B2": F_B2, "12": F_A1}


@dataclass(frozen=True)
class CapacityReport:
    """The rating of the three meshes at given mesh forces, with the findings."""

    material: Material
    conditions: Conditions
    meshes: tuple[MeshRating, ...]
    findings: tuple[Finding, ...] = field(default_factory=tuple)

    def mesh(self, name: str) -> MeshRating:
        return next(r for r in self.meshes if r.mesh == name)

    @property
    def S_H(self) -> float:
        return min(g.S_H for r in self.meshes for g in r.gears)

    @property
    def S_F(self) -> float:
        return min(g.S_F for r in self.meshes for g in r.gears)

    @property
    def S_H_static(self) -> float:
        return min(g.S_H_static for r in self.meshes for g in r.gears)

    @property
    def S_F_static(self) -> float:
        return min(g.S_F_static for r in self.meshes for g in r.gears)

    def lines(self) -> list[str]:
        """The report as text lines (MPa, N)."""
        out = [f"material {self.material.name}: sigma_Hlim {self.material.sigma_Hlim / MPA:.0f} MPa, "
               f"sigma_Flim {self.material.sigma_Flim / MPA:.0f} MPa; K_A {self.conditions.K_A:g}, "
               f"grade {self.conditions.grade}, v {self.conditions.v:g} m/s"]
        for r in self.meshes:
            out.append(f"mesh {r.mesh}: F_n {r.F_n:.1f} N, Z_H {r.Z_H:.4f}, Z_E {r.Z_E / 1e3:.2f} sqrt(MPa), "
                       f"Z_eps {r.Z_eps:.4f}, K_v {r.K_v:.4f}, K_Hbeta {r.K_Hbeta:.4f}, K_Halpha {r.K_Halpha:.4f}, "
                       f"K_Fbeta {r.K_Fbeta:.4f}, K_Falpha {r.K_Falpha:.4f}, sigma_H0 {r.sigma_H0 / MPA:.0f} MPa, "
                       f"c' {r.c_prime:.2f}, c_gamma {r.c_gamma:.2f} N/(mm um), eps {r.eps_alpha:.3f}")
            for g in r.gears:
                out.append(f"  {g.gear:8s} sigma_H {g.sigma_H / MPA:7.0f} MPa (Z_B/D {g.Z_BD:.4f})  "
                           f"sigma_F {g.sigma_F / MPA:6.0f} MPa (Y_F {g.Y_F:.3f} Y_S {g.Y_S:.3f} Y_B {g.Y_B:.3f}; "
                           f"tip load {g.sigma_F_tip / MPA:.0f})  S_H {g.S_H:.3f} / static {g.S_H_static:.3f}  "
                           f"S_F {g.S_F:.3f} / static {g.S_F_static:.3f}")
        out += [str(f) for f in self.findings]
        return out


def capacity_report(geo: DifferentialGeometry, forces: dict[str, float], mat: Material | None = None,
                    cond: Conditions | None = None, bores: dict[str, float] | None = None) -> CapacityReport:
    """Rate the three meshes of ``geo`` at the normal forces ``forces`` (N per pair, keys A1, B2,
    12) and list a finding for every safety factor below 1: static (the gear breaks or its flank
    fails at the first load) an error, endurance (long life) a warning; a rim thinner than ISO
    6336-3's range (s_R / h_t < 0.5) a warning."""
    mat = mat or material()
    cond = cond or conditions()
    cond.validate()
    ratings = tuple(rate_mesh(me, geo.gears, geo.table, forces[me.name], mat, cond, bores) for me in geo.meshes)
    found: list[Finding] = []
    for r in ratings:
        for g in r.gears:
            for what, S, Ss, stress, lim in (
                    ("contact", g.S_H, g.S_H_static, g.sigma_H, mat.sigma_Hlim),
                    ("root", g.S_F, g.S_F_static, g.sigma_F, mat.sigma_Flim)):
                if Ss < 1.0:
                    found.append(Finding("error", f"capacity-{what}", f"{g.gear}.b",
                                         f"mesh {r.mesh} at F_n = {r.F_n:.0f} N: {g.gear} {what} stress "
                                         f"{stress / MPA:.0f} MPa exceeds the static strength ({what} safety "
                                         f"{Ss:.3f} < 1, {mat.name})"))
                elif S < 1.0:
                    found.append(Finding("warning", f"capacity-{what}", f"{g.gear}.b",
                                         f"mesh {r.mesh} at F_n = {r.F_n:.0f} N: {g.gear} {what} safety for long "
                                         f"life {S:.3f} < 1 ({what} stress {stress / MPA:.0f} MPa; "
                                         f"limit {lim / MPA:.0f} MPa, {mat.name}); static {Ss:.3f}"))
            if g.backup_ratio < 0.5:
                found.append(Finding("warning", "rim-thickness", f"{g.gear}.x",
                                     f"{g.gear}: rim under the teeth s_R / h_t = {g.backup_ratio:.2f} < 0.5, "
                                     f"outside ISO 6336-3's rim factor (recommended >= 1.2)"))
    # one rim finding per gear
    seen, unique = set(), []
    for f in found:
        key = (f.check, f.message) if f.check != "rim-thickness" else (f.check, f.parameter)
        if key not in seen:
            seen.add(key)
            unique.append(f)
    return CapacityReport(mat, cond, ratings, tuple(unique))


# ------------------------------------------------------------------ a run
class StressWatch:
    """The largest contact and root stress over a run from the mesh forces, and whether the static
    strength was exceeded (for the FMU: plain state, saved and restored with the model's).

    The load factors depend on the load (K_Hbeta and K_Halpha fall as it grows), so a run's stress
    is scaled from the rating at the reference forces ``forces`` (N per mesh, e.g. the nominal
    forces of the rated carrier torque): ``sigma_H = a_H sqrt(F)``, ``sigma_F = a_F F`` with
    ``a_H``, ``a_F`` of each mesh's more loaded gear there; exact at the reference forces,
    conservative above them.
    """

    def __init__(self, geo: DifferentialGeometry, forces: dict[str, float], mat: Material | None = None,
                 cond: Conditions | None = None, bores: dict[str, float] | None = None):
        mat = mat or material()
        cond = cond or conditions()
        self.geo, self.mat, self.cond, self.bores = geo, mat, cond, bores
        self.sigma_HG_static = mat.sigma_Hlim * cond.Z_LvR * cond.Z_W * cond.Z_X * mat.Z_NT_static
        self.sigma_FG_static = mat.sigma_Flim * cond.Y_ST * cond.Y_deltarelT * cond.Y_RrelT * cond.Y_X * mat.Y_NT_static
        self.calibrate(forces)
        self.sigma_H_max = 0.0
        self.sigma_F_max = 0.0
        self.exceeded = False
        self._F_max = (0.0, 0.0, 0.0)    # largest |force| booked per mesh

    def calibrate(self, forces: dict[str, float]) -> None:
        """Take the load factors at ``forces`` (N per mesh, each > 0); stresses scale from there."""
        for k, F in forces.items():
            if not (math.isfinite(F) and F > 0.0):
                raise ParameterError(f"capacity.F_{k}", F, "> 0 N (the reference force of the stress scaling)")
        rep = capacity_report(self.geo, forces, self.mat, self.cond, self.bores)
        self._aH = tuple(r.sigma_H / math.sqrt(r.F_n) if r.F_n > 0 else 0.0 for r in rep.meshes)
        self._aF = tuple(r.sigma_F / r.F_n if r.F_n > 0 else 0.0 for r in rep.meshes)

    def update(self, F_A1: float, F_B2: float, F_12: float) -> str | None:
        """Book the mesh forces of one instant; a message the first time a limit is exceeded.
        (On the FMU's per-step path: three comparisons unless a mesh's largest force grows.)"""
        a1 = F_A1 if F_A1 >= 0.0 else -F_A1
        a2 = F_B2 if F_B2 >= 0.0 else -F_B2
        a3 = F_12 if F_12 >= 0.0 else -F_12
        m1, m2, m3 = self._F_max
        if a1 <= m1 and a2 <= m2 and a3 <= m3:     # NaN too: never booked
            return None
        self._F_max = (a1 if a1 > m1 else m1), (a2 if a2 > m2 else m2), (a3 if a3 > m3 else m3)
        hA, hB, h12 = self._aH
        fA, fB, f12 = self._aF
        sH = max(hA * math.sqrt(a1), hB * math.sqrt(a2), h12 * math.sqrt(a3))
        sF = max(fA * a1, fB * a2, f12 * a3)
        if sH > self.sigma_H_max:
            self.sigma_H_max = sH
        if sF > self.sigma_F_max:
            self.sigma_F_max = sF
        if not self.exceeded and (sH > self.sigma_HG_static or sF > self.sigma_FG_static):
            self.exceeded = True
            return (f"the mesh forces ({F_A1:.0f}, {F_B2:.0f}, {F_12:.0f} N on meshes A1, B2, 12) exceed the "
                    f"static strength of {self.mat.name}: contact {sH / MPA:.0f} MPa (limit "
                    f"{self.sigma_HG_static / MPA:.0f}), root {sF / MPA:.0f} MPa (limit "
                    f"{self.sigma_FG_static / MPA:.0f}); the results beyond are those of hardware that "
                    f"would fail (ISO 6336, docs/capacity.md)")
        return None

    @property
    def exceeded_indicator(self) -> float:
        """1.0 once the static strength was exceeded, else 0.0 (an FMU output)."""
        return 1.0 if self.exceeded else 0.0

    def get_state(self) -> list:
        return [self.sigma_H_max, self.sigma_F_max, self.exceeded, list(self._F_max)]

    def set_state(self, s) -> None:
        self.sigma_H_max, self.sigma_F_max, self.exceeded = float(s[0]), float(s[1]), bool(s[2])
        self._F_max = tuple(float(f) for f in s[3])


__all__ = ["CapacityParams", "Material", "Conditions", "material", "conditions", "single_stiffness", "mesh_stiffness",
           "impact_equivalent", "impact_secant", "iso_contact_parameters", "stiffness_comparison", "StiffnessComparison", "tooth_form", "rim_factor", "rate_mesh", "nominal_mesh_forces",
           "capacity_report", "CapacityReport", "MeshRating", "GearRating", "StressWatch", "elasticity_factor"]
