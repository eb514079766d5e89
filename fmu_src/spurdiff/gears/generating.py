"""Where the involute of a rack-generated spur gear starts: the form radius, undercut included.

The gear is cut by a rack (hob or rack cutter) with the basic rack profile of the tool
(ISO 53 profile A, the counterpart of the gear's basic rack: tool addendum ``h_aP0 = 1.25 m``,
tool tip radius ``rho_aP0 = 0.38 m``; ISO 21771 / DIN 3960 names). The tool's datum line lies
``x m`` outside the gear's reference circle (radius ``r = m z / 2``) and the tool rolls on that
circle. The straight part of the tool flank ends ``h_FfP0 = h_aP0 - rho_aP0 (1 - sin(alpha))``
below the datum line; that point generates the involute at

    u = r sin(alpha) - (h_FfP0 - x) m / sin(alpha)      (along the line of action from the
                                                         base tangent point)

so without undercut (``u > 0``) the form radius is ``r_F = sqrt(r_b^2 + u^2)`` and below it the
fillet (trochoid of the tip rounding) joins the root. With ``u <= 0`` the tool tip reaches
inside the base circle's line of action: its rounding sweeps a trochoid that cuts into the
involute and removes its lower part (undercut). Then the form radius is where the trochoid
crosses the involute; :func:`form_radius` finds it by simulating the generation: an involute
point at radius ``R`` survives if no position of the rolling tool overlaps it; ``r_F`` is the
smallest surviving radius (bisection in ``R``; the overlap is the signed distance of the point
to the rounded tool tooth, maximised over the rolling angle). Plain Python floats and :mod:`math`
(no numpy): the operations of the former numpy version, in the same order, so the same numbers
(bit for bit in the tests' gear sets on Linux, where numpy's sin, cos and hypot are the C library's).
"""
from __future__ import annotations

import json
import math
from functools import lru_cache
from pathlib import Path

from spurdiff.datafile import package_bytes
from spurdiff.numerics import find_root, minimize_bounded

ISO53_TOOL_ADDENDUM = 1.25    # h_aP0 / m, ISO 53 profile A (= the gear's dedendum h_fP)
ISO53_TOOL_TIP_RADIUS = 0.38  # rho_aP0 / m, ISO 53 profile A (= the gear's root radius rho_fP)


def _inv(a: float) -> float:
    return math.tan(a) - a


def generating_shift(x: float, A_sn: float, m: float, alpha: float) -> float:
    """The generating profile shift ``x_E = x + A_sn / (2 m tan(alpha))`` of a gear thinned by the
    tooth-thickness allowance ``A_sn`` (m, <= 0, normal, at the reference circle): the tool is fed
    in by ``-A_sn / (2 tan(alpha))`` (ISO 21771)."""
    return x + A_sn / (2.0 * m * math.tan(alpha))


def thickness_allowances(alpha_w: dict, backlash: dict, alpha: float) -> dict:
    """Tooth-thickness allowances A_sn (m, <= 0) of the four gears that give each mesh its
    circumferential backlash ``backlash[k]`` at the operating pitch circle (keys A1, B2, 12; m):
    per mesh ``A_sn1 + A_sn2 = -j_t cos(alpha_w) / cos(alpha)`` (ISO 21771, no centre-distance
    deviation). Four gears, three meshes: mesh 12's share split equally between the planets, the
    rest of each sun mesh on its sun (a sun's share is then the larger: the planets, near their
    undercut limit, are thinned least)."""
    need = {k: -backlash[k] * math.cos(alpha_w[k]) / math.cos(alpha) for k in ("A1", "B2", "12")}
    p = 0.5 * need["12"]
    return {"planet1": p, "planet2": p, "sunA": min(need["A1"] - p, 0.0), "sunB": min(need["B2"] - p, 0.0)}


def straight_flank_reach(z: int, x: float, m: float, alpha: float, haP0: float, rhoaP0: float) -> float:
    """``u``: where the end of the tool's straight flank meets the line of action, measured from the
    base tangent point (m); ``u <= 0`` means undercut."""
    r = m * z / 2.0
    h_ffp0 = haP0 - rhoaP0 * (1.0 - math.sin(alpha))
    return r * math.sin(alpha) - (h_ffp0 - x) * m / math.sin(alpha)


def _depth(X: float, Y: float, p: float, a0: float, ym: float, ta: float, ca: float, sa: float,
           rho: float) -> float:
    """How far the point (X, Y) (rack frame) lies inside the nearest rounded tool tooth (m, < 0
    outside): ``rho`` minus the point's distance to the tooth shrunk by ``rho`` (``rho`` plus its
    depth in the shrunk tooth if inside). The shrunk tooth: half width ``a0`` at the rounding
    centres' line ``Y = ym``, flanks at the angle whose tangent, cosine and sine are ``ta``, ``ca``,
    ``sa``, pitch ``p``."""
    Xp = abs(X - p * round(X / p))                     # to the nearest tooth's axis (round: half to even)
    dy = Y - ym
    w = a0 + dy * ta                                   # the shrunk tooth's half width at Y
    if Y >= ym and Xp <= w:                            # inside the shrunk tooth
        return min(dy, (w - Xp) * ca) + rho
    if Y < ym and Xp <= a0:                            # below the rounding centres' line
        return rho - (ym - Y)
    dx = Xp - a0
    s = dx * sa + dy * ca                              # along the flank from the rounding centre
    n = dx * ca - dy * sa                              # outward normal of the flank
    if s >= 0.0 and n > 0.0:
        return rho - n
    # to the rounding centre: C's hypot (complex abs), the one numpy's hypot calls, so that the
    # results equal those of the former vectorised version bit for bit (math.hypot differs by an ulp)
    return rho - abs(complex(dx, dy))


class _Rack:
    """The generating rack in its own frame: X along the datum line, Y from the gear centre."""

    def __init__(self, z, x, m, alpha, haP0, rhoaP0):
        self.r = r = m * z / 2.0
        self.p = math.pi * m
        self.rho = rhoaP0 * m
        y_dat = r + x * m
        y_tip = y_dat - haP0 * m
        self.ym = y_tip + self.rho                     # tip rounding centres' line
        self.ta, self.ca, self.sa = math.tan(alpha), math.cos(alpha), math.sin(alpha)
        # half width of the tooth shrunk by rho, at y = ym (the rounding centre's abscissa)
        self.a0 = self.p / 4.0 + (self.ym - y_dat) * self.ta - self.rho / self.ca

    @property
    def shape(self) -> tuple:
        """The arguments of :func:`_depth` after the point."""
        return self.p, self.a0, self.ym, self.ta, self.ca, self.sa, self.rho



# The form radii an FMU's default gear set needs, computed by this function when the FMU was built
# (harness/build/fmu.py: form_radius_table), so that the default configuration starts without simulating
# the generation (some 25 ms per undercut gear, plain Python); any other gear set is simulated here.
# Keys: repr of the arguments; values: [r_F, undercut].
TABLE_FILE = Path(__file__).with_name("form_radius_table.json")
_TABLE: dict | None = None


def _known(key: str) -> tuple[float, bool] | None:
    global _TABLE
    if _TABLE is None:
        try:
            raw = package_bytes(f"gears/{TABLE_FILE.name}")      # from a folder or the FMU's archive
            _TABLE = {k: (float(v[0]), bool(v[1])) for k, v in json.loads(raw).items()}
        except (OSError, ValueError, TypeError, IndexError, AttributeError):
            _TABLE = {}
    return _TABLE.get(key)


@lru_cache(maxsize=256)
def form_radius(z: int, x: float, m: float, alpha: float, haP0: float, rhoaP0: float,
                r_tip: float) -> tuple[float, bool]:
    """(form radius r_F in m, undercut?) of a gear generated by the rack described above, with tip
    radius ``r_tip`` (the search stops there: ``r_F = r_tip`` means no involute is left)."""
    r = m * z / 2.0
    rb = r * math.cos(alpha)
    u = straight_flank_reach(z, x, m, alpha, haP0, rhoaP0)
    if u > 0.0:
        return math.hypot(rb, u), False
    known = _known(repr((z, x, m, alpha, haP0, rhoaP0, r_tip)))
    if known is not None:
        return known
    rack = _Rack(z, x, m, alpha, haP0, rhoaP0)
    shape = rack.shape
    p, a0, ym, ta, ca, sa, rho = shape
    psi_ref = (math.pi / 2.0 + 2.0 * x * math.tan(alpha)) / z + _inv(alpha)
    span = 4.0 * math.pi / z
    # the rolling angles: 1601 samples over [-span, span] (as numpy's linspace: i * step + start, the
    # last one the end itself)
    N = 1601
    step = (span - -span) / (N - 1)
    phis = [i * step + -span for i in range(N - 1)] + [span]
    dphi = phis[1] - phis[0]
    cphi, sphi = [math.cos(f) for f in phis], [math.sin(f) for f in phis]
    rphi = [r * f for f in phis]
    samples = list(zip(cphi, sphi, rphi))
    floor = -0.05 * m           # sampled maxima at or below this depth are not refined
    # The tool lies above its tip line y_tip = ym - rho, so a point's depth is at most its height above
    # that line, Y - y_tip: at Y <= low (a margin far above rounding) it is below ``floor``, neither a
    # maximum to refine nor, unless every sample is that deep, the largest depth (not evaluated then).
    low = (ym - rho) + floor - 1e-9 * m
    NEG_INF = -math.inf

    def point(R: float) -> tuple[float, float]:
        eta = math.pi / z - (psi_ref - _inv(math.acos(min(1.0, rb / R))))
        return R * math.sin(eta), R * math.cos(eta)

    def depth_at(px, py, phi):
        c, s = math.cos(phi), math.sin(phi)
        return _depth(px * c - py * s + r * phi, px * s + py * c, *shape)

    def reach(px: float, py: float) -> tuple[int, int]:
        """The samples ``i0 <= i <= i1`` outside which the point lies below ``low``: its height is
        ``Y = R cos(phi - theta)`` (``R, theta``: its polar radius and angle from the Y axis),
        above ``low`` where ``|phi - theta| < acos(low / R)``; two samples more on each side (the
        sample spacing is far above rounding). All the samples where ``|phi - theta|`` could pass pi
        (there Y would rise again; no gear has so few teeth)."""
        theta = math.atan2(px, py)
        if span + abs(theta) >= 0.9 * math.pi:
            return 0, N - 1
        A = math.acos(max(-1.0, min(1.0, low / math.hypot(px, py))))
        return (max(0, math.floor((theta - A + span) / step) - 2),
                min(N - 1, math.ceil((theta + A + span) / step) + 2))

    def depths(px: float, py: float, i0: int, i1: int, low: float) -> list[float]:
        """The point's depth at each sampled rolling angle (the rack frame: X = px c - py s + r phi,
        Y = px s + py c), -inf outside samples i0 to i1 and where Y <= low (there it is below floor);
        _depth written out (a call per sample would cost as much as its body)."""
        d = [NEG_INF] * i0
        app = d.append
        for c, s, rf in samples[i0:i1 + 1]:
            Y = px * s + py * c
            if Y <= low:
                app(NEG_INF)
                continue
            X = px * c - py * s + rf
            Xp = abs(X - p * round(X / p))
            dy = Y - ym
            w = a0 + dy * ta
            if Y >= ym and Xp <= w:
                app(min(dy, (w - Xp) * ca) + rho)
            elif Y < ym and Xp <= a0:
                app(rho - (ym - Y))
            else:
                dx = Xp - a0
                n = dx * ca - dy * sa
                if n > 0.0 and dx * sa + dy * ca >= 0.0:
                    app(rho - n)
                else:
                    app(rho - abs(complex(dx, dy)))
        d.extend([NEG_INF] * (N - 1 - i1))
        return d

    def max_depth(R: float) -> float:
        px, py = point(R)
        i0, i1 = reach(px, py)
        d = depths(px, py, i0, i1, low)
        if max(d) <= floor:     # every sample deeper than floor: the largest of all (and no maximum to refine)
            d = depths(px, py, 0, N - 1, NEG_INF)
        best = max(d)
        # refine every sampled local maximum near the surface (a corner's trochoid can graze the
        # point in a window narrower than the sampling, next to the flank's tangent contact)
        for k in range(max(1, i0), min(N - 2, i1) + 1):
            dk = d[k]
            if dk > floor and dk >= d[k - 1] and dk >= d[k + 1]:
                res = minimize_bounded(lambda f: -depth_at(px, py, f), phis[k] - dphi, phis[k] + dphi,
                                       xatol=1e-14)
                best = max(best, -float(res.fun))
        return best

    tol = 1e-9 * m
    R_top = r_tip * (1.0 - 1e-12)
    if max_depth(rb * (1.0 + 1e-12)) <= tol:      # nothing cut even at the base circle
        return rb, True
    if max_depth(R_top) > tol:                    # cut everywhere: no involute left
        return R_top, True
    rF = find_root(lambda R: max_depth(R) - tol, rb * (1.0 + 1e-12), R_top, xtol=1e-12 * m)
    return rF, True
