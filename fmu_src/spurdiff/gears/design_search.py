"""A gear set that works: profile shifts and tip diameters for given tooth counts and centre
distances, with no undercut, no tip interference, a usable contact ratio of at least 1.2 on every
mesh, and assembly and clearance satisfied (the checks of :mod:`spurdiff.gears.checks`).

The three centre distances fix the three shift sums (ISO 21771):
``x_1 + x_2 = (z_1 + z_2) (inv(alpha_w) - inv(alpha)) / (2 tan(alpha))`` with
``cos(alpha_w) = m (z_1 + z_2) cos(alpha) / (2 a)``; four gears on three meshes leave one free
shift, planet 1's ``t``: ``x_planet2 = S_12 - t``, ``x_sunA = S_A1 - t``, ``x_sunB = S_B2 - S_12 + t``.
No undercut with margins bounds ``t``: every gear, thinned for its mesh's backlash (tooth-thickness
allowance ``A_sn``, :func:`spurdiff.gears.generating.thickness_allowances`), is cut at the generating
shift ``x_E = x + A_sn / (2 m tan(alpha)) >= x_min + x_margin`` with ``x_min = h_FfP0 - z sin^2(alpha) / 2``.
For each ``t`` every tip is made as large as allowed: untrimmed ``m (z + 2 h_a + 2 x)``, at most the
interference-free diameter against each mating gear's form circle (:meth:`MeshGeometry.tip_limit`),
a tip clearance of ``c_min m`` to each mating root circle (the basic rack's 0.25 m), a tip thickness
of ``s_min m``, a reach that keeps the mating flank's specific sliding above ``-zeta_max`` at its
start of active profile (``rho_mate = r_b,mate L / (r_b,mate + (1 + zeta_max) r_b,tip)`` on the line
of action of length ``L``), and planet 2's tip clear of sun A's by ``c_min m`` (planet 2 spans both
planes; sun A's tip gives way, its mesh has the most contact ratio to spare). ``t`` is chosen to maximise the smallest usable contact ratio
(a grid, then golden-section refinement, :func:`spurdiff.numerics.minimize_bounded`); tips are
rounded down to 1 um. The result is derived again with :func:`spurdiff.gears.design.derive` and
must show none of the findings above.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

from spurdiff.errors import ParameterError
from spurdiff.gears.checks import DesignLimits
from spurdiff.gears.design import derive
from spurdiff.gears.generating import thickness_allowances
from spurdiff.gears.geometry import (DifferentialGeometry, Gear, GearTable, gear_geometry, inv, inv_inverse,
                                     mesh_geometry)
from spurdiff.numerics import find_root, minimize_bounded

X_MARGIN = 1e-9   # kept beyond the undercut margin (rounding)
GEARS = ("sunA", "planet1", "sunB", "planet2")
MESHES = {"A1": ("sunA", "planet1"), "B2": ("sunB", "planet2"), "12": ("planet1", "planet2")}
# findings a working set must not have (mesh-phasing is a note on the lumped model, not a defect)
BLOCKING = ("undercut", "undercut-margin", "specific-sliding", "pointed-tip", "tip-below-root", "tip-root-clash", "tip-clearance", "tip-interference",
            "contact-ratio", "symmetry", "assembly", "planet2-sunA-clearance", "neighbour-clearance")


@dataclass(frozen=True)
class Targets:
    """What the proposed set must meet (in modules where a length)."""

    eps_min: float = 1.1     # usable transverse contact ratio on every mesh (checks.py warns below 1.1)
    s_min: float = 0.3       # tip thickness, m (checks.py warns below 0.25 m)
    c_min: float = 0.25      # tip-to-root clearance and planet 2 / sun A tip clearance, m (basic rack 0.25)
    x_margin: float = 0.02   # generating shift (thinned for the backlash) beyond the undercut limit
    zeta_max: float = 4.0    # largest magnitude of specific sliding at a start of active profile
    backlash: dict | None = None   # per mesh, m (None: differential.toml's mesh*.backlash)

    def limits(self) -> DesignLimits:
        """The design checks' limits that hold what this search proposes."""
        return DesignLimits(undercut_margin=self.x_margin, clearance=self.c_min, sliding=self.zeta_max,
                            backlash=self.backlash)


def shift_sum(z1: int, z2: int, a: float, m: float, alpha: float, name: str) -> float:
    """x_1 + x_2 of the mesh of z_1 and z_2 teeth at centre distance ``a`` (m)."""
    a0 = m * (z1 + z2) / 2.0
    c = a0 * math.cos(alpha) / a
    lo = a0 * math.cos(alpha) / math.cos(math.radians(35.0))
    if not 0.0 < c < 1.0 or a > lo:
        raise ParameterError(name, round(a, 12), f"a centre distance between {a0 * math.cos(alpha):.6f} and {lo:.6f} m "
                                      f"(operating pressure angle 0 .. 35 deg for z = {z1} + {z2}, m = {m * 1e3:g} mm)")
    aw = math.acos(c)
    if aw < math.radians(12.0):
        hi = a0 * math.cos(alpha) / math.cos(math.radians(12.0))
        raise ParameterError(name, round(a, 12), f"a centre distance of at least {hi:.6f} m (operating pressure angle "
                                      f">= 12 deg; below, the shift sum drives the teeth into undercut)")
    return (z1 + z2) * (inv(aw) - inv(alpha)) / (2.0 * math.tan(alpha))


def _x_min(z: int, t: GearTable) -> float:
    h_ffp0 = t.haP0 - t.rhoaP0 * (1.0 - math.sin(t.alpha))
    return h_ffp0 - z * math.sin(t.alpha) ** 2 / 2.0


def _tip_for_thickness(g, t: GearTable, s: float) -> float:
    """Tip radius at which the tooth of gear geometry ``g`` is ``s`` thick (m)."""
    def thick(ra):
        return 2.0 * ra * ((math.pi / 2.0 + 2.0 * g.x * math.tan(t.alpha)) / g.z + inv(t.alpha)
                           - inv(math.acos(g.rb / ra))) - s
    hi = g.rb * 1.6
    if thick(hi) > 0.0:
        return hi
    return find_root(thick, g.rb * (1.0 + 1e-9), hi, xtol=1e-12)


@dataclass(frozen=True)
class Candidate:
    t: float
    table: GearTable
    eps: dict
    limits: dict          # gear -> what set its tip


def _shifts(t: float, S: dict) -> dict:
    return {"planet1": t, "planet2": S["12"] - t, "sunA": S["A1"] - t, "sunB": S["B2"] - S["12"] + t}


def _candidate(t: float, base: GearTable, S: dict, tg: Targets, round_tips: bool = False) -> Candidate:
    xs = _shifts(t, S)
    tab = base
    for n in GEARS:
        tab = tab.with_gear(n, x=xs[n], da=0.0)
    m = tab.m
    gg = {n: gear_geometry(n, g, tab) for n, g in tab.gears().items()}
    me = {k: mesh_geometry(k, gg[a], gg[b], tab) for k, (a, b) in MESHES.items()}
    ra, why = {}, {}
    for n, g in gg.items():
        lim = {"untrimmed": g.ra, "tip thickness": _tip_for_thickness(g, tab, tg.s_min * m)}
        for k, (a, b) in MESHES.items():
            if n in (a, b):
                mate = gg[b if n == a else a]
                lim[f"interference {k}"] = me[k].tip_limit(n)
                lim[f"root clearance {k}"] = me[k].a - mate.rf - tg.c_min * m
                L = me[k].a * math.sin(me[k].alpha_w)
                rho_mate = mate.rb * L / (mate.rb + (1.0 + tg.zeta_max) * g.rb)
                lim[f"specific sliding {k}"] = math.hypot(g.rb, L - rho_mate)
        why[n] = min(lim, key=lim.get)
        ra[n] = lim[why[n]]
    # planet 2 spans both planes: sun A's tip gives way
    room = me["B2"].a - ra["planet2"] - tg.c_min * m
    if ra["sunA"] > room:
        ra["sunA"], why["sunA"] = room, "planet 2 clearance"
    for n in GEARS:
        da = 2.0 * ra[n]
        if round_tips:
            da = math.floor(da * 1e6 * (1.0 - 1e-12)) / 1e6
        tab = tab.with_gear(n, da=da)
    gg = {n: gear_geometry(n, g, tab) for n, g in tab.gears().items()}
    eps = {k: mesh_geometry(k, gg[a], gg[b], tab).epsilon_usable for k, (a, b) in MESHES.items()}
    return Candidate(t, tab, eps, why)


@dataclass(frozen=True)
class Proposal:
    """The proposed set, its derived geometry and the input set's, and what changed."""

    table: GearTable
    geometry: DifferentialGeometry
    before: DifferentialGeometry
    tip_limits: dict
    centre_distances: dict

    @property
    def blocking(self) -> list:
        return [f for f in self.geometry.findings if f.check in BLOCKING]

    def changes(self) -> list[str]:
        """What changed against the input set, one line per gear and mesh."""
        out = []
        for n in GEARS:
            g0, g1 = getattr(self.before.table, n), getattr(self.table, n)
            r0, r1 = self.before.gears[n], self.geometry.gears[n]
            out.append(f"{n:8s} z {g1.z:3d}  x {g0.x:+.4f} -> {g1.x:+.4f}  d_a {2 * r0.ra * 1e3:8.3f} -> "
                       f"{2 * r1.ra * 1e3:8.3f} mm ({self.tip_limits[n]})  d_F {2 * r0.rF * 1e3:7.3f} -> "
                       f"{2 * r1.rF * 1e3:7.3f} mm")
        for m0, m1 in zip(self.before.meshes, self.geometry.meshes):
            out.append(f"mesh {m1.name:2s}  a {m0.a * 1e3:8.4f} -> {m1.a * 1e3:8.4f} mm  alpha_w "
                       f"{math.degrees(m0.alpha_w):7.4f} -> {math.degrees(m1.alpha_w):7.4f} deg  usable contact "
                       f"ratio {m0.epsilon_usable:.3f} -> {m1.epsilon_usable:.3f}")
        return out


def propose(z: dict, a: dict, base: GearTable | None = None, targets: Targets | None = None) -> Proposal:
    """The proposed set for tooth counts ``z`` (keys sunA, planet1, sunB, planet2) and centre
    distances ``a`` (m; keys A1, B2, 12), on the module, rack, tool, face widths and nPairs of
    ``base`` (default: the paper's table, which is also the set the changes are shown against).
    ParameterError (naming the parameter and its allowed range) when no such set exists."""
    base = base or GearTable()
    tg = targets or Targets()
    for n in GEARS:
        v = z[n]
        if isinstance(v, bool) or int(v) != v or not 6 <= v <= 400:
            raise ParameterError(f"{n}.z", v, "an integer from 6 to 400")
    for k in MESHES:
        v = a[k]
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0.0):
            raise ParameterError(f"a{k}", v, "a centre distance > 0 m")
    if z["sunA"] != z["sunB"]:
        raise ParameterError("sunB.z", z["sunB"], f"= sunA.z = {z['sunA']} (equal suns: w_A + w_B = 2 w_c)")
    tab = base
    for n in GEARS:
        tab = tab.with_gear(n, z=int(z[n]))
    tab.validate()
    S = {k: shift_sum(tab.gears()[g1].z, tab.gears()[g2].z, a[k], tab.m, tab.alpha, f"a{k}")
         for k, (g1, g2) in MESHES.items()}
    # undercut bounds on t = x_planet1: each gear's generating shift, thinned for the backlash, at
    # least x_margin beyond its undercut limit
    lim = tg.limits()
    lim.validate()
    aw = {k: math.acos(tab.m * (tab.gears()[g1].z + tab.gears()[g2].z) / 2.0 * math.cos(tab.alpha) / a[k])
          for k, (g1, g2) in MESHES.items()}
    A_sn = thickness_allowances(aw, lim.backlash_of(), tab.alpha)
    xm = {n: _x_min(g.z, tab) + tg.x_margin - A_sn[n] / (2.0 * tab.m * math.tan(tab.alpha))
          for n, g in tab.gears().items()}
    lo = max(xm["planet1"], xm["sunB"] - S["B2"] + S["12"]) + X_MARGIN
    hi = min(S["12"] - xm["planet2"], S["A1"] - xm["sunA"]) - X_MARGIN
    if lo > hi:
        need = xm["planet1"] + xm["planet2"] + 2 * X_MARGIN
        a_need = _a_of_sum(tab.planet1.z, tab.planet2.z, need, tab)
        if S["12"] < need:
            raise ParameterError("a12", round(a["12"], 12), f">= {a_need:.6f} m: planets of {tab.planet1.z} and "
                                 f"{tab.planet2.z} teeth need x_1 + x_2 >= {need:.4f} to avoid undercut with the "
                                 f"margins (x_min {xm['planet1']:+.4f}, {xm['planet2']:+.4f} with the undercut "
                                 f"margin {tg.x_margin:g} and the thinning for the backlash), a12 gives {S['12']:+.4f}")
        raise ParameterError("aB2", round(a["B2"], 12), f"a centre distance for which the shifts avoid undercut on all four "
                             f"gears (x_planet1 would need {lo:+.4f} .. {hi:+.4f}); shift sums A1 {S['A1']:+.4f}, "
                             f"B2 {S['B2']:+.4f}, 12 {S['12']:+.4f}")

    def score(t):
        c = _candidate(t, tab, S, tg)
        return -min(c.eps.values())

    n = 200
    grid = [lo + (hi - lo) * i / n for i in range(n + 1)]
    vals = [score(t) for t in grid]
    k = min(range(len(grid)), key=vals.__getitem__)
    t_best = grid[k]
    if 0 < k < n:
        res = minimize_bounded(score, grid[k - 1], grid[k + 1], xatol=1e-7)
        if res.fun < vals[k]:
            t_best = float(res.x)
    best = _candidate(t_best, tab, S, tg, round_tips=True)
    eps_min = min(best.eps.values())
    if eps_min < tg.eps_min:
        worst = min(best.eps, key=best.eps.get)
        raise ParameterError(f"a{worst}", round(a[worst], 12), f"centre distances giving a usable contact ratio >= "
                             f"{tg.eps_min:g} on every mesh: the best shifts give {eps_min:.3f} on mesh {worst} "
                             f"(tips limited by {', '.join(sorted(set(best.limits.values())))})")
    geo = derive(best.table, lim)
    prop = Proposal(best.table, geo, derive(base, lim), best.limits, dict(a))
    if prop.blocking:
        f = prop.blocking[0]
        raise ParameterError(f.parameter, None, "a set without design findings", f"proposed set still has: {f.message}")
    return prop


def _a_of_sum(z1: int, z2: int, xsum: float, t: GearTable) -> float:
    aw = inv_inverse(2.0 * math.tan(t.alpha) * xsum / (z1 + z2) + inv(t.alpha))
    return t.m * (z1 + z2) / 2.0 * math.cos(t.alpha) / math.cos(aw)


def to_toml(p: Proposal, header: str) -> str:
    """The proposed set as a data file with the keys of differential.toml's gear sections."""
    t = p.table
    lines = [header.rstrip(), "", f"nPairs = {t.nPairs}", "", "[gearing]",
             f"m = {t.m!r}", f"alpha = {t.alpha!r}", f"ha = {t.ha!r}", f"hf = {t.hf!r}", f"haP0 = {t.haP0!r}",
             f"rhoaP0 = {t.rhoaP0!r}"]
    for n in GEARS:
        g = getattr(t, n)
        lines += ["", f"[{n}]", f"z = {g.z}", f"x = {g.x!r}", f"b = {g.b!r}", f"da = {g.da!r}",
                  f"axialStart = {g.axialStart!r}"]
    lines += ["", "[carrier]", f"wallB = {t.carrier.wallB!r}", f"axialClearance = {t.carrier.axialClearance!r}"]
    return "\n".join(lines) + "\n"


__all__ = ["Targets", "Proposal", "propose", "shift_sum", "to_toml", "BLOCKING", "GEARS", "MESHES"]
