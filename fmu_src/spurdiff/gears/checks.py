"""The design checks of the differential's gear set, a gear engineer's list: each a
:class:`spurdiff.gears.geometry.Finding` (error or warning) with the numbers and the parameter to change,
run by :func:`spurdiff.gears.design.derive` on the derived geometry (equations in :mod:`spurdiff.gears.geometry`).

* undercut: ``x >= h_a - z sin^2(alpha) / 2`` (rack-generated gear, no undercut)
* pointed tip: normal tip thickness ``s_a = d_a ((pi/2 + 2 x tan(alpha)) / z + inv(alpha) -
  inv(alpha_a))``; error if ``s_a <= 0``, warning below ``0.25 m``
* tip interference: a tip that reaches past the mating gear's base tangent point (involute
  interference) is a warning that names the interference-free tip diameter (the set works only
  with tip relief to that diameter); contact below the generated involute (trochoid) is a warning
* contact ratio: the usable ratio (tips limited to the interference-free diameter) below 1.0 is an
  error (no continuous action), below 1.1 a warning
* form circle: the involute starts at the form radius from the generating rack (tool addendum
  ``h_aP0`` and tip radius ``rho_aP0``, ISO 53 defaults; undercut by a simulated generation,
  :mod:`spurdiff.gears.generating`); the start of active profile (where the mating tip meets the gear)
  must lie on the involute, else a tip-interference warning with the interference-free tip
* usable contact ratio: the path of contact from form circle to tip on both gears; below 1.1 a
  warning with the numbers, below 1.0 an error
* tip clearance: tip to mating root circle >= the basic rack's bottom clearance 0.25 m (warning;
  ``DesignLimits.clearance``), > 0 (error)
* tooth-thickness allowances: the backlash of each mesh (``DesignLimits.backlash``, default the FMU's
  ``mesh*.backlash`` of differential.toml) comes from thinning the teeth: ``A_sn1 + A_sn2 =
  -j_t cos(alpha_w) / cos(alpha)`` (ISO 21771, no centre-distance deviation), split equally between
  the planets on mesh 12, the rest on the suns; the tool then cuts at the generating shift
  ``x_E = x + A_sn / (2 m tan(alpha))`` (:func:`spurdiff.gears.generating.generating_shift`), and the
  undercut margin is ``x_E - x_min >= DesignLimits.undercut_margin`` (warning ``undercut-margin``)
* specific sliding at both ends of each usable path of contact,
  ``zeta_1 = 1 - (r_b1 rho_2) / (r_b2 rho_1)`` (and 2 with 1): below ``-DesignLimits.sliding`` a
  warning (``specific-sliding``; scuffing and wear concentrate at the start of contact)
* symmetry: the kinematics ``w_A + w_B = 2 w_c`` need equal sun tooth counts only (the planets'
  ratios cancel along the chain sun A - planet 1 - planet 2 - sun B; with equal planets the
  paper's ``r_a / r_1 = r_b / r_2`` follows, printed as ``r_a/r_b = r_2/r_1``, a typo)
* assembly: the three centre distances must close a triangle; planet 2 (which spans both mesh
  planes) must clear sun A's tip circle; neighbouring planet pairs must not touch
  (this is what limits ``nPairs``: the paper's gear set fits 3 pairs, not 6); equally spaced
  pairs assemble only if ``(z_A + z_B) / n`` is an integer (derived in docs/paper-reproduction.md)
* mesh phasing (:mod:`spurdiff.gears.phasing`): ``z_sun / n`` not an integer is a warning.
"""
from __future__ import annotations

import math

from spurdiff.datafile import differential_default
from spurdiff.errors import ParameterError
from spurdiff.gears.generating import generating_shift, thickness_allowances
from spurdiff.gears.geometry import MM, Finding, GearGeometry, GearTable, MeshGeometry
from spurdiff.attrpath import record

MIN_TIP_CLEARANCE = 0.25  # smallest tip-to-root clearance, in modules: the basic rack's c_P = 0.25 m (ISO 53)
DEFAULT_BACKLASH = {k: differential_default(f"mesh{k}.backlash") for k in ("A1", "B2", "12")}


@record(frozen=True)
class DesignLimits:
    """The margins the design checks want (each an argument of ``spurdiff design``):
    ``undercut_margin`` (in x) between the generating shift and the undercut limit; ``clearance``
    the least tip-to-root clearance in modules (the basic rack's 0.25); ``sliding`` the largest
    magnitude of specific sliding; ``backlash`` the circumferential backlash of each mesh at its
    operating pitch circle (m; None: differential.toml's ``mesh*.backlash``, what the FMU simulates).
    The sliding limit 4.0 is assumed (a design guideline, not a standard's value; the 13-tooth
    planets against 36-tooth suns leave little room below it)."""

    undercut_margin: float = 0.02
    clearance: float = MIN_TIP_CLEARANCE
    sliding: float = 4.0
    backlash: dict | None = None

    def validate(self) -> None:
        for name, v, lo, hi in (("undercut_margin", self.undercut_margin, 0.0, 0.5),
                                ("clearance", self.clearance, 0.0, 0.5), ("sliding", self.sliding, 0.5, 100.0)):
            if not (math.isfinite(v) and lo <= v <= hi):
                raise ParameterError(f"design.{name}", v, f"between {lo:g} and {hi:g}")
        for k, v in self.backlash_of().items():
            if not (math.isfinite(v) and 0.0 <= v <= 0.002):
                raise ParameterError(f"mesh{k}.backlash", v, "between 0 and 0.002 m")

    def backlash_of(self) -> dict:
        return dict(DEFAULT_BACKLASH) if self.backlash is None else dict(self.backlash)


def specific_sliding(me: MeshGeometry, l: float) -> tuple[float, float]:
    """(zeta_1, zeta_2) at distance ``l`` from gear 1's base tangent point on the line of action:
    ``zeta_1 = 1 - (r_b1 rho_2) / (r_b2 rho_1)``, ``zeta_2 = 1 - (r_b2 rho_1) / (r_b1 rho_2)``,
    ``rho_1 = l``, ``rho_2 = a sin(alpha_w) - l``."""
    r1, r2 = l, me.a * math.sin(me.alpha_w) - l
    z1 = 1.0 - (me.rb1 * r2) / (me.rb2 * r1) if r1 > 0.0 else -math.inf
    z2 = 1.0 - (me.rb2 * r1) / (me.rb1 * r2) if r2 > 0.0 else -math.inf
    return z1, z2


def _mm(v: float) -> str:
    return f"{v / MM:.3f} mm"


def design_checks(t: GearTable, gg: dict[str, GearGeometry], meshes: tuple[MeshGeometry, ...],
                  limits: DesignLimits | None = None):
    """The findings for the gear table ``t``, its gears' and its three meshes' geometry (a generator),
    with the margins of ``limits`` (default :class:`DesignLimits`)."""
    lim = limits or DesignLimits()
    lim.validate()
    m, alpha = t.m, t.alpha
    clear_min = lim.clearance
    mesh_of = {me.name: me for me in meshes}
    allowance = (thickness_allowances({k: mesh_of[k].alpha_w for k in mesh_of}, lim.backlash_of(), alpha)
                 if set(mesh_of) == {"A1", "B2", "12"} else {})
    h_ffp0 = t.haP0 - t.rhoaP0 * (1.0 - math.sin(alpha))   # end of the tool's straight flank
    for name, g in gg.items():
        x_min = h_ffp0 - g.z * math.sin(alpha) ** 2 / 2.0
        if g.x < x_min - 1e-9:
            yield Finding("warning", "undercut", f"{name}.x",
                          f"{name} (z = {g.z}) is undercut: x = {g.x:+.4f} < x_min = {x_min:+.4f}; its involute "
                          f"starts at the form diameter d_F = {2 * g.rF / MM:.3f} mm, above the base circle "
                          f"d_b = {2 * g.rb / MM:.3f} mm (generating tool h_aP0 = {t.haP0:g} m, "
                          f"rho_aP0 = {t.rhoaP0:g} m)")
        elif name in allowance:
            xE = generating_shift(g.x, allowance[name], m, alpha)
            if xE < x_min + lim.undercut_margin - 1e-12:
                yield Finding("warning", "undercut-margin", f"{name}.x",
                              f"{name} (z = {g.z}): thinned for the backlash (A_sn = {allowance[name] / MM * 1e3:.1f} um) "
                              f"the tool cuts at x_E = {xE:+.4f}, {xE - x_min:+.4f} from the undercut limit "
                              f"x_min = {x_min:+.4f}; margin wanted {lim.undercut_margin:g}")
        if g.ra <= g.rb or g.sa <= 0.0:
            yield Finding("error", "pointed-tip", f"{name}.x",
                          f"{name} has no tooth left at its tip (tip thickness {g.sa / MM:.3f} mm)")
        elif g.sa < 0.25 * m:
            yield Finding("warning", "pointed-tip", f"{name}.x",
                          f"{name} tip thickness {g.sa / MM:.3f} mm < 0.25 m = {0.25 * m / MM:.3f} mm")
        if g.ra <= g.rf:
            yield Finding("error", "tip-below-root", f"{name}.da",
                          f"{name} tip radius {_mm(g.ra)} is not above its root radius {_mm(g.rf)}")
        elif g.ra > g.rb and g.rF >= g.ra * (1.0 - 1e-9):
            yield Finding("error", "undercut", f"{name}.x",
                          f"{name}: the generating tool cuts the whole involute away (no flank left below "
                          f"the tip, d_a = {2 * g.ra / MM:.3f} mm)")
    for me in meshes:
        g1, g2 = gg[me.gear1], gg[me.gear2]
        clear_root_1 = me.a - g2.ra - g1.rf
        clear_root_2 = me.a - g1.ra - g2.rf
        for gear, other, clr in ((g1, g2, clear_root_1), (g2, g1, clear_root_2)):
            if clr < 0.0:
                yield Finding("error", "tip-root-clash", f"{other.name}.da",
                              f"mesh {me.name}: {other.name}'s tip cuts into {gear.name}'s root by {_mm(-clr)}")
            elif clr < clear_min * m - 1e-6:     # 1 um: below what a tip diameter is made to
                yield Finding("warning", "tip-clearance", f"{other.name}.da",
                              f"mesh {me.name}: {other.name}'s tip clears {gear.name}'s root circle by only "
                              f"{clr / MM:.4f} mm = {clr / m:.4f} m < {clear_min:g} m = {_mm(clear_min * m)} (basic rack: "
                              f"{t.hf - t.ha:g} m)")
        for gear, other in ((g1, g2), (g2, g1)):
            # start of active profile on `gear` (from the other's tip) against gear's form circle
            l_sap = me.sap_distance(gear.name)
            l_form = math.sqrt(max(gear.rF ** 2 - gear.rb ** 2, 0.0))
            if l_sap < l_form - 1e-12:
                r_limit = me.tip_limit(other.name)
                if l_sap < 0.0:
                    where = (f"reaches {_mm(-l_sap)} past {gear.name}'s base tangent point (involute "
                             f"interference)")
                else:
                    where = (f"meets {gear.name} at d = {2 * math.hypot(gear.rb, l_sap) / MM:.3f} mm, on the "
                             f"{'trochoid of its undercut' if gear.undercut else 'fillet'}")
                yield Finding("warning", "tip-interference", f"{other.name}.da",
                              f"mesh {me.name}: {other.name}'s tip (d_a = {2 * other.ra / MM:.3f} mm) {where}, "
                              f"below {gear.name}'s form diameter d_F = {2 * gear.rF / MM:.3f} mm "
                              f"(base circle {2 * gear.rb / MM:.3f} mm); interference-free d_a <= "
                              f"{2 * r_limit / MM:.3f} mm, i.e. tip relief assumed; usable contact ratio "
                              f"{me.epsilon_usable:.3f}")
        l0, l1 = me.usable_path
        for gear, zeta in ((g1, specific_sliding(me, l0)[0]), (g2, specific_sliding(me, l1)[1])):
            if zeta < -lim.sliding:
                yield Finding("warning", "specific-sliding", f"{(g2 if gear is g1 else g1).name}.da",
                              f"mesh {me.name}: specific sliding {zeta:.2f} at {gear.name}'s start of active profile "
                              f"(limit -{lim.sliding:g}); a smaller mating tip lowers it")
        eps_u = me.epsilon_usable
        detail = (f"mesh {me.name}: usable transverse contact ratio {eps_u:.3f} (involute to tip on both gears, form "
                  f"diameters {2 * g1.rF / MM:.3f} / {2 * g2.rF / MM:.3f} mm) against {me.epsilon_alpha:.3f} with the "
                  f"tips as given")
        if eps_u < 1.0:
            yield Finding("error", "contact-ratio", f"{me.gear1}.da",
                          f"{detail}: < 1.0, no continuous action")
        elif eps_u < 1.1:
            yield Finding("warning", "contact-ratio", f"{me.gear1}.da", f"{detail}: < 1.1")
    mA1, mB2, m12 = meshes
    # symmetry: w_B - w_c = -(z_A / z_B)(w_A - w_c) whatever the planets (their ratios cancel along
    # sun A -> planet 1 -> planet 2 -> sun B), so only the suns must be equal
    if t.sunA.z != t.sunB.z:
        yield Finding("error", "symmetry", "sunB.z",
                      f"sun tooth counts differ ({t.sunA.z} vs {t.sunB.z}): w_B - w_c = -(z_A/z_B)(w_A - w_c), "
                      f"so w_A + w_B = 2 w_c does not hold")
    # Planet pair triangle: planet 1 at radius a_A, planet 2 at a_B, a_12 apart.
    aA, aB, a12 = mA1.a, mB2.a, m12.a
    if not abs(aA - aB) < a12 < aA + aB:
        yield Finding("error", "assembly", "planet2.x",
                      f"centre distances a_A1 = {_mm(aA)}, a_B2 = {_mm(aB)}, a_12 = {_mm(a12)} do not form a triangle")
        return
    ga, g1, gb, g2 = gg["sunA"], gg["planet1"], gg["sunB"], gg["planet2"]
    # Planet 2 spans both mesh planes, so it must clear sun A's tip circle (the paper's trick).
    clr = aB - g2.ra - ga.ra
    if clr <= 0.0:
        yield Finding("error", "planet2-sunA-clearance", "sunA.x",
                      f"planet 2 tip circle overlaps sun A tip circle by {_mm(-clr)}")
    elif clr < 0.1 * m:
        yield Finding("warning", "planet2-sunA-clearance", "sunA.x",
                      f"planet 2 clears sun A's tip circle by only {_mm(clr)} (< 0.1 m)")
    # Planet 1 lies in sun A's plane only; if the faces overlap axially it must clear sun B's tip too.
    # (Not modelled: axial layout; the paper's layout keeps planet 1 out of sun B's plane.)
    n = t.nPairs
    theta = math.acos((aA ** 2 + aB ** 2 - a12 ** 2) / (2.0 * aA * aB))  # angle planet1 -> planet2
    pitch = 2.0 * math.pi / n
    pairs = [
        ("planet 2 of one pair and planet 1 of the next", aA, aB, pitch - theta, g1.ra + g2.ra),
        ("planet 1 of neighbouring pairs", aA, aA, pitch, 2.0 * g1.ra),
        ("planet 2 of neighbouring pairs", aB, aB, pitch, 2.0 * g2.ra),
    ]
    if n > 1:
        for what, r1, r2, ang, need in pairs:
            d = math.sqrt(r1 ** 2 + r2 ** 2 - 2.0 * r1 * r2 * math.cos(ang))
            if d <= need:
                yield Finding("error", "neighbour-clearance", "nPairs",
                              f"nPairs = {n}: {what} overlap (centres {_mm(d)} apart, tips need {_mm(need)})")
    # assembly of n equally spaced pairs with two suns that turn independently: a pair ties the
    # tooth phases of the two suns at its place, p_A + p_B = const (turning the pair's gear train
    # moves p_A and p_B by opposite amounts); pair j sits 2 pi j / n further on, where the phases
    # are p_A + z_A j / n and p_B + z_B j / n; so (z_A + z_B) j / n must be an integer for every j
    if (t.sunA.z + t.sunB.z) % n:
        yield Finding("error", "assembly", "nPairs",
                      f"(z_A + z_B) / nPairs = ({t.sunA.z} + {t.sunB.z}) / {n} is not an integer: {n} equally "
                      f"spaced planet pairs cannot be assembled (each pair ties the tooth phases of the two suns)")


__all__ = ["design_checks", "DesignLimits", "specific_sliding", "MIN_TIP_CLEARANCE", "DEFAULT_BACKLASH"]
