"""ISO 6336 method B rating of the differential's spur meshes: contact (pitting) and root (bending)
stress and the safety factors of each gear of each mesh (factors: :mod:`.factors`).

Contact stress, ISO 6336-2:2006 method B (spur)::

    sigma_H0 = Z_H Z_E Z_eps sqrt(F_t / (d_1 b) (u + 1) / u)     F_t = F_n cos(alpha) (reference circle)
    sigma_H  = Z_B|Z_D sigma_H0 sqrt(K_A K_gamma K_v K_Hbeta K_Halpha)

Root stress, ISO 6336-3:2006 method B (load at the outer point of single tooth contact)::

    sigma_F = F_t / (b m) Y_F Y_S Y_B K_A K_gamma K_v K_Fbeta K_Falpha      (Y_beta = Y_DT = 1)

and, as a cross-check, the tip-load variant (``Y_Fa Y_Sa Y_eps``, ``Y_eps = 0.25 + 0.75 / eps_alpha``).
``K_gamma`` is the load-sharing factor of the planet pairs (the forces given are the mean per
pair); the load factors K_v, K_Hbeta, K_Halpha are taken at ``K_A K_gamma F_t``. ``b`` is the mesh's
own face width (the axial overlap, :func:`.loads.face_width`); ``v`` the pitch-line speed of the
run (no default: every caller says which).

Permissible: ``sigma_HG = sigma_Hlim Z_NT Z_L Z_v Z_R Z_W Z_X`` with ``Z_L Z_v Z_R`` the data's
(0.92) for long life and 1 for static stress (ISO 6336-2: the lubricant and roughness factors
do not apply to static stress); ``sigma_FG = sigma_Flim Y_ST Y_NT Y_deltarelT Y_RrelT Y_X``.
Long life: ``Z_NT = Y_NT = 1`` (the planets' root strength times ``Y_M = 0.7``: bent both ways);
static: ``Z_NT``, ``Y_NT`` of the material's static line. Long-life factors are reported, not
judged: a differential's planets turn only while cornering; the limited-life check of a duty cycle
is :mod:`.life`.
"""
from __future__ import annotations

import math
from dataclasses import field

from spurdiff.errors import ParameterError
from spurdiff.gears.capacity.data import MM, MPA, Conditions, Material, conditions, material
from spurdiff.gears.capacity.factors import (contact_ratio_factor, dynamic_factor, elasticity_factor,
                                             face_load_factors, rim_factor, single_contact_factor, tooth_form,
                                             transverse_load_factors, zone_factor)
from spurdiff.gears.capacity.loads import face_widths
from spurdiff.gears.capacity.stiffness import mesh_stiffness
from spurdiff.gears.geometry import DifferentialGeometry, Finding, GearGeometry, GearTable, MeshGeometry
from spurdiff.attrpath import record

IDLERS = ("planet1", "planet2")   # the differential's planets: each tooth loaded on both flanks


@record(frozen=True)
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
    S_H: float           # endurance (long life)
    S_F: float
    S_H_static: float
    S_F_static: float
    backup_ratio: float  # s_R / h_t (inf: solid)


@record(frozen=True)
class MeshRating:
    """ISO 6336 rating of one mesh at normal force F_n (N, mean per pair)."""

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
    K_gamma: float = 1.0
    v: float = 0.0       # pitch-line speed, m/s
    b: float = 0.0       # face width rated, m

    @property
    def sigma_H(self) -> float:
        return max(g.sigma_H for g in self.gears)

    @property
    def sigma_F(self) -> float:
        return max(g.sigma_F for g in self.gears)


def static_contact_strength(mat: Material, cond: Conditions) -> float:
    """sigma_HG for static stress (Pa): ``sigma_Hlim Z_NT,static Z_W Z_X`` (Z_L Z_v Z_R = 1)."""
    return mat.sigma_Hlim * mat.Z_NT_static * cond.Z_W * cond.Z_X


def static_root_strength(mat: Material, cond: Conditions) -> float:
    """sigma_FG for static stress (Pa): ``sigma_Flim Y_ST Y_NT,static Y_deltarelT Y_RrelT Y_X``."""
    return mat.sigma_Flim * cond.Y_ST * mat.Y_NT_static * cond.Y_deltarelT * cond.Y_RrelT * cond.Y_X


def rate_mesh(me: MeshGeometry, gg: dict[str, GearGeometry], t: GearTable, F_n: float, mat: Material,
              cond: Conditions, *, v: float, bores: dict[str, float] | None = None,
              idlers: tuple[str, ...] = IDLERS, b: float | None = None, K_gamma: float = 1.0) -> MeshRating:
    """ISO 6336 method B rating of mesh ``me`` under normal force ``F_n`` (N, per mesh, its sign
    ignored) at the pitch-line speed ``v`` (m/s, for K_v); ``b`` the face width (m; None: the
    narrower gear's); ``K_gamma`` the load-sharing factor; ``bores``: bore diameters (m) of gears that
    are rims on a pin (Y_B); ``idlers``: gears whose teeth are bent both ways (long-life root strength
    times ``Y_M_reversed``)."""
    if not (math.isfinite(v) and v >= 0.0):
        raise ParameterError("capacity.v", v, ">= 0 m/s (the pitch-line speed)")
    F_n = abs(float(F_n))
    g1, g2 = gg[me.gear1], gg[me.gear2]
    m, alpha = t.m, t.alpha
    b = me.b if b is None else b
    b_mm = b / MM
    aw = me.alpha_w
    eps = me.epsilon_usable
    L = me.a * math.sin(aw)
    l0, l1 = me.usable_path
    pb = me.pb
    Z_H = zone_factor(aw, alpha)
    Z_E = elasticity_factor(mat, mat)
    Z_eps = contact_ratio_factor(eps)
    F_t = F_n * math.cos(alpha)
    d1, d2 = 2.0 * g1.r, 2.0 * g2.r
    sigma_H0 = Z_H * Z_E * Z_eps * math.sqrt(F_t / b * (1.0 / d1 + 1.0 / d2))
    zp, zw = min(g1.z, g2.z), max(g1.z, g2.z)
    F_g = F_t * K_gamma                       # the most loaded pair's force: the load factors' load
    K_v = dynamic_factor(cond.grade, cond.K_A, F_g, b_mm, zp, zw / zp, v)
    c_prime, c_gamma = mesh_stiffness(me, gg, t, mat.E, eps)
    h_mm = max((g.ra - g.rf) for g in (g1, g2)) / MM
    K_Hbeta, K_Fbeta = face_load_factors(F_g, b_mm, h_mm, cond.K_A, K_v, c_gamma, cond.F_betay_um)
    K_Halpha, K_Falpha = transverse_load_factors(F_g, b_mm, cond.K_A, K_v, K_Hbeta, c_gamma, cond.f_pb_um, eps)
    Y_eps = 0.25 + 0.75 / eps
    KH = cond.K_A * K_gamma * K_v * K_Hbeta * K_Halpha
    KF = cond.K_A * K_gamma * K_v * K_Fbeta * K_Falpha
    sHG = mat.sigma_Hlim * cond.Z_LvR * cond.Z_W * cond.Z_X
    sFG = mat.sigma_Flim * cond.Y_ST * cond.Y_deltarelT * cond.Y_RrelT * cond.Y_X
    sHG_static = static_contact_strength(mat, cond)
    sFG_static = static_root_strength(mat, cond)
    ratings = []
    for k, g in enumerate((g1, g2)):
        # inner point of single contact (Z_B / Z_D) and outer point (load point of Y_F), as
        # distances from this gear's base tangent point
        if k == 0:
            l_inner, l_outer = l1 - pb, l0 + pb
            rho_outer, rho_tip = l_outer, l1
        else:
            l_inner = l0 + pb
            rho_outer, rho_tip = L - (l1 - pb), L - l0
        Z_BD = max(1.0, single_contact_factor(me, l_inner))
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
            S_H_static=sHG_static / sigma_H if sigma_H > 0 else math.inf,
            S_F_static=sFG_static / sigma_F if sigma_F > 0 else math.inf,
            backup_ratio=s_R / h_t))
    return MeshRating(me.name, F_n, F_t, Z_H, Z_E, Z_eps, cond.K_A, K_v, K_Hbeta, K_Fbeta, K_Halpha, K_Falpha,
                      Y_eps, sigma_H0, c_prime, c_gamma, c_gamma * b_mm * 1e6, eps, tuple(ratings),
                      K_gamma=K_gamma, v=v, b=b)


@record(frozen=True)
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
        r0 = self.meshes[0]
        out = [f"material {self.material.name}: sigma_Hlim {self.material.sigma_Hlim / MPA:.0f} MPa, "
               f"sigma_Flim {self.material.sigma_Flim / MPA:.0f} MPa; K_A {self.conditions.K_A:g}, "
               f"K_gamma {r0.K_gamma:g}, grade {self.conditions.grade}, pitch-line speed {r0.v:.4g} m/s"]
        for r in self.meshes:
            out.append(f"mesh {r.mesh}: F_n {r.F_n:.1f} N, b {r.b / MM:.2f} mm, Z_H {r.Z_H:.4f}, Z_E "
                       f"{r.Z_E / 1e3:.2f} sqrt(MPa), Z_eps {r.Z_eps:.4f}, K_v {r.K_v:.4f}, K_Hbeta {r.K_Hbeta:.4f}, "
                       f"K_Halpha {r.K_Halpha:.4f}, K_Fbeta {r.K_Fbeta:.4f}, K_Falpha {r.K_Falpha:.4f}, sigma_H0 "
                       f"{r.sigma_H0 / MPA:.0f} MPa, c' {r.c_prime:.2f}, c_gamma {r.c_gamma:.2f} N/(mm um), "
                       f"eps {r.eps_alpha:.3f}")
            for g in r.gears:
                out.append(f"  {g.gear:8s} sigma_H {g.sigma_H / MPA:7.0f} MPa (Z_B/D {g.Z_BD:.4f})  "
                           f"sigma_F {g.sigma_F / MPA:6.0f} MPa (Y_F {g.Y_F:.3f} Y_S {g.Y_S:.3f} Y_B {g.Y_B:.3f}; "
                           f"tip load {g.sigma_F_tip / MPA:.0f})  S_H static {g.S_H_static:.3f}, long life "
                           f"{g.S_H:.3f}  S_F static {g.S_F_static:.3f}, long life {g.S_F:.3f}")
        out += [str(f) for f in self.findings]
        return out


def capacity_report(geo: DifferentialGeometry, forces: dict[str, float], mat: Material | None = None,
                    cond: Conditions | None = None, bores: dict[str, float] | None = None, *,
                    v: float) -> CapacityReport:
    """Rate the three meshes of ``geo`` at the normal forces ``forces`` (N, mean per pair, keys A1,
    B2, 12) and the pitch-line speed ``v`` (m/s), each mesh with its own face width and the
    load-sharing factor of the conditions (0: the default for nPairs). Findings: a static safety
    factor below 1 (the gear breaks or its flank fails at the first load) an error; a rim thinner
    than ISO 6336-3's range (s_R / h_t < 0.5) a warning. Long-life factors are in the report, not
    findings (:mod:`.life` judges a duty cycle)."""
    mat = mat or material()
    cond = cond or conditions()
    cond.validate()
    Kg = cond.load_sharing(geo.table.nPairs)
    widths = face_widths(geo)
    ratings = tuple(rate_mesh(me, geo.gears, geo.table, forces[me.name], mat, cond, v=v, bores=bores,
                              b=widths[me.name], K_gamma=Kg) for me in geo.meshes)
    found: list[Finding] = []
    rims = set()
    for r in ratings:
        for g in r.gears:
            for what, Ss, stress in (("contact", g.S_H_static, g.sigma_H), ("root", g.S_F_static, g.sigma_F)):
                if Ss < 1.0:
                    found.append(Finding("error", f"capacity-{what}", f"{g.gear}.b",
                                         f"mesh {r.mesh} at F_n = {r.F_n:.0f} N (K_gamma {r.K_gamma:g}): {g.gear} "
                                         f"{what} stress {stress / MPA:.0f} MPa exceeds the static strength ({what} "
                                         f"safety {Ss:.3f} < 1, {mat.name})"))
            if g.backup_ratio < 0.5 and g.gear not in rims:
                rims.add(g.gear)
                found.append(Finding("warning", "rim-thickness", f"{g.gear}.x",
                                     f"{g.gear}: rim under the teeth s_R / h_t = {g.backup_ratio:.2f} < 0.5, "
                                     f"outside ISO 6336-3's rim factor (recommended >= 1.2)"))
    return CapacityReport(mat, cond, ratings, tuple(found))


__all__ = ["GearRating", "MeshRating", "rate_mesh", "CapacityReport", "capacity_report", "IDLERS",
           "static_contact_strength", "static_root_strength"]
