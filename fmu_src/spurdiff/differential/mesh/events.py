"""Events of the mesh model, found by the stepper (:mod:`spurdiff.differential.mesh.stepper`): a contact flank
opening or closing, a slipping planet reaching zero slip speed, a stuck planet's required friction
exceeding its capacity, a loaded flank leaving the interval of its held phase mode (single/double
contact; state events, located inside a step from its start, dense-output middle and end), and
the mesh-phase boundaries predicted from the rolling speeds (a step limit, so most steps end just
past a boundary without a located event)."""
from __future__ import annotations

import math

from spurdiff.differential.mesh.layout import PSI, VA, VB, W1, W2, relative_angles, rolls

STICK_RTOL = 1e-9  # relative margin of the stick test |M_i| <= c_pin |F_pin,i| (rounding only)
PHASE_RTOL = 1e-8  # a step may overrun a phase boundary by this fraction (the held mode's error there)
PHASE_PAST = 1e-9  # relative margin by which a step predicted or located to a phase boundary lands past it


def contact_flags(c, y) -> list[int]:
    """Contact flags (drive, coast) per mesh: 1 where the flank penetrates."""
    if not (c._bl or c._contact):
        return []
    out = []
    for m in c.md:
        d = float(y[m.d])
        out.append(1 if d > 0.0 else 0)
        out.append(1 if -(d + m.jn) > 0.0 else 0)
    return out


def crossing(g0: float, gm: float, g1: float, closed: bool) -> float:
    """Fraction of the step where g leaves its start side, from its values at the start, middle
    and end of the step (piecewise linear); 1.0 if it does not. ``closed``: g <= 0 counts as
    crossed (for g > 0 at the start), else only a change of the sign of g > 0."""
    if closed:
        if g0 > 0.0 and gm <= 0.0:
            return 0.5 * g0 / (g0 - gm)
        if g0 > 0.0 and g1 <= 0.0:
            return 0.5 + 0.5 * gm / (gm - g1) if gm != g1 else 1.0
        return 1.0
    p0, pm, p1 = g0 > 0.0, gm > 0.0, g1 > 0.0
    if pm != p0:
        return 0.5 * g0 / (g0 - gm)
    if p1 != pm:
        return 0.5 + 0.5 * gm / (gm - g1)
    return 1.0


def state_events(c, y0, ym, y1) -> float:
    """Smallest fraction of the step at which a contact flank opens/closes or a slipping planet
    reaches zero slip speed; 1.0 if none."""
    theta = 1.0
    if c._bl or c._contact:
        for m in c.md:
            idx = m.d
            a, mid, b = float(y0[idx]), float(ym[idx]), float(y1[idx])
            theta = min(theta, crossing(a, mid, b, False),
                        crossing(-(a + m.jn), -(mid + m.jn), -(b + m.jn), False))
    if c._pin:
        for i, idx in ((0, W1), (1, W2)):
            s = c.s[i]
            if s != 0:
                theta = min(theta, crossing(s * float(y0[idx]), s * float(ym[idx]), s * float(y1[idx]), True))
    return theta


def friction_margins(c, sv) -> tuple[float, float]:
    """Capacity minus required friction of each stuck planet (inf for a slipping one)."""
    out = []
    for i in (0, 1):
        if c._pin and c.s[i] == 0:
            out.append((sv.cap_2 if i else sv.cap_1) - abs(sv.M_2 if i else sv.M_1))
        else:
            out.append(math.inf)
    return out[0], out[1]


def breakaway(c, sv0, svm, sv1, theta: float) -> float:
    """Fraction of the step at which a stuck planet's required friction first exceeds its
    capacity (by the relative margin STICK_RTOL), if before ``theta``."""
    tolc = STICK_RTOL * (sv1.cap_1 + sv1.cap_2)
    for g0, gm, g1 in zip(friction_margins(c, sv0), friction_margins(c, svm), friction_margins(c, sv1)):
        if g0 != math.inf and g0 >= 0.0:
            theta = min(theta, crossing(g0 + tolc, gm + tolc, g1 + tolc, True))
    return theta


def phase_limit(c, y) -> float:
    """Step limit at the next mesh-phase boundary of the loaded flank of each mesh, from the
    current rolling speeds (inf if none). Boundaries: a pair entering or leaving contact
    (xi = 0 and xi = eps - 1: the stiffness wave and the friction arms jump) and, with flank
    friction, a pair passing the pitch point (xi = xip: the sliding velocity changes sign).
    The step ends just past the boundary; past a pitch point by the time the sliding speed
    needs to leave the stiction band (|v| > v_s), so the friction reversal is not inside a step."""
    best = math.inf
    yl = y
    rates = (c.rbA * yl[VA], c.rbB * yl[VB], c.rb1 * yl[W1])
    omegas = ((yl[VA], yl[W1]), (yl[VB], yl[W2]), (yl[W1], yl[W2]))
    unilateral = c._bl or c._contact
    flank = c.flank_obj
    v_s = flank.v_s if flank is not None else c.mesh.vStiction
    us = None
    for mi, m in enumerate(c.md):
        d = yl[m.d]
        if unilateral:
            if d > 0.0:
                sgn = -1.0          # drive flank: xi = frac(xi0 - sigma u / pb)
            elif -(d + m.jn) > 0.0:
                sgn = 1.0           # coast flank: xi = frac(xi0c + sigma u / pb)
            else:
                continue            # no contact: nothing switches
        else:
            sgn = -1.0 if d >= 0.0 else 1.0
        rate = sgn * m.sigma * rates[mi] / m.pb   # d xi / dt
        if rate == 0.0:
            continue
        if us is None:
            psiB, th1, _ = relative_angles(c, yl)
            us = (c.rbA * yl[PSI], c.rbB * psiB, c.rb1 * th1)
        z = (m.xi0 if sgn < 0.0 else m.xi0c) + sgn * m.sigma * us[mi] / m.pb
        xi = z % 1.0
        ar = abs(rate)
        bounds = (0.0, m.eps - 1.0, m.xip) if flank is not None else (0.0, m.eps - 1.0)
        for j, xb in enumerate(bounds):
            dist = (xb - xi) % 1.0 if rate > 0.0 else (xi - xb) % 1.0
            if dist == 0.0:
                dist = 1.0
            dt = dist / ar
            # just past: relative margin, the rounding of the phase (|z| ulps), at least 1e-12 s
            dt += PHASE_PAST * dt + 4e-16 * (abs(z) + 1.0) / ar
            if dt < 1e-12:
                dt = 1e-12
            if j == 2:
                o1, o2 = omegas[mi]
                grad = abs(o1 - o2) * ar * m.pb      # d|v|/dt of the sliding speed at the pitch
                if grad > 0.0:
                    dt += 1.5 * v_s / grad
            if dt < best:
                best = dt
    return best


def phase_mode(c, y) -> tuple:
    """The phase mode of each mesh at y (:meth:`spurdiff.differential.mesh.forces.MeshPhase.mode`:
    the tooth count and pairs in contact of its drive and coast flanks), held over the next step."""
    us = rolls(c, y)
    return tuple(c.phase_obj.mode(m, us[i]) for i, m in enumerate(c.md))


def phase_switches(c, y, old: tuple, new: tuple) -> int:
    """How many loaded flanks (at y) changed their phase mode from ``old`` to ``new``: the
    single/double contact boundaries an accepted step crossed (a diagnostic)."""
    unilateral = c._bl or c._contact
    count = 0
    for i, m in enumerate(c.md):
        d = float(y[m.d])
        if unilateral:
            drive, coast = d > 0.0, -(d + m.jn) > 0.0
        else:
            drive, coast = d >= 0.0, d < 0.0
        a, b = old[i], new[i]
        if drive and (a[0] != b[0] or a[1] != b[1]):
            count += 1
        if coast and (a[2] != b[2] or a[3] != b[3]):
            count += 1
    return count


def leave(x0: float, xm: float, x1: float, lo: float, hi: float) -> float:
    """Fraction of the step where x (at the start, middle and end of the step; piecewise linear)
    leaves [lo, hi); 1.0 if it does not."""
    if xm < lo:
        return 0.5 * (x0 - lo) / (x0 - xm)
    if xm >= hi:
        return 0.5 * (hi - x0) / (xm - x0)
    if x1 < lo:
        return 0.5 + 0.5 * (xm - lo) / (xm - x1)
    if x1 >= hi:
        return 0.5 + 0.5 * (hi - xm) / (x1 - xm)
    return 1.0


def phase_events(c, y0, ym, y1) -> float:
    """Smallest fraction of the step at which a loaded flank (at the start or the end of the
    step) leaves the interval of its held phase mode ``c._mode``: ``[0, eps - 1)`` (two pairs)
    or ``[eps - 1, 1)`` (one pair) of ``xi = z - k``; 1.0 if none."""
    mode = c._mode
    unilateral = c._bl or c._contact
    u0, um, u1 = rolls(c, y0), rolls(c, ym), rolls(c, y1)
    theta = 1.0
    for i, m in enumerate(c.md):
        a, b = float(y0[m.d]), float(y1[m.d])
        if unilateral:
            drive = a > 0.0 or b > 0.0
            coast = -(a + m.jn) > 0.0 or -(b + m.jn) > 0.0
        else:
            drive = a >= 0.0 or b >= 0.0
            coast = a < 0.0 or b < 0.0
        kp, np_, kn, nn = mode[i]
        e1 = m.eps - 1.0
        if drive:
            lo, hi = (0.0, e1) if np_ == 2 else (e1, 1.0)
            x0 = (m.xi0 - m.sigma * u0[i] / m.pb) - kp
            xm = (m.xi0 - m.sigma * um[i] / m.pb) - kp
            x1 = (m.xi0 - m.sigma * u1[i] / m.pb) - kp
            theta = min(theta, leave(x0, xm, x1, lo, hi))
        if coast:
            lo, hi = (0.0, e1) if nn == 2 else (e1, 1.0)
            x0 = (m.xi0c + m.sigma * u0[i] / m.pb) - kn
            xm = (m.xi0c + m.sigma * um[i] / m.pb) - kn
            x1 = (m.xi0c + m.sigma * u1[i] / m.pb) - kn
            theta = min(theta, leave(x0, xm, x1, lo, hi))
    return theta
