"""The locking law of the differential: pin-bushing friction from the actual pin loads.

Two laws (the FMU's structural parameter ``lockingLaw``):

``pinFriction`` (default), derived from first principles
    Each planet i turns on its pin with a Coulomb friction moment of capacity

        M_i,max = mu r_d |F_pin,i| + M_0,i

    where ``F_pin,i`` is the bearing force of the planet: the vector sum of its two normal mesh
    forces (sun mesh and planet-planet mesh), each along its own line of action, with its
    tangential part ``F cos(alpha_w)`` and its separating radial part ``|F| sin(alpha_w)`` (the
    layout of the pins from the three centre distances, :class:`PinLayout`). ``mu`` and ``r_d``
    are used as given, nothing is calibrated. ``M_0,i`` is an optional spring preload
    (``lockingPreload``, clutch-type limited-slip differentials), split so that each planet set
    holds half of it on the differential motion: ``n |rho_i| M_0,i = T_pre / 2``.

    Power balance. With the differential speed ``dw = w_A - w_c`` the planets spin relative to
    the carrier at ``w_i = rho_i dw`` with ``|rho_i| = z_sun / z_planet,i`` (36/13 for the
    paper's set), and the friction of the ``n`` pairs dissipates

        (T_B - T_A) dw = n sum_i M_i |w_i| = n sum_i M_i (z_sun / z_i) |dw|,

    i.e. the sun torques differ by ``n sum_i |rho_i| M_i`` (the slower sun gets more torque).

    Mesh forces per pair: ``F_A1 = T_A / (n r_bA)``, ``F_B2 = T_B / (n r_bB)`` (base radii), and
    ``F_12`` from the moment balances of the two planets about their pins (planet inertia
    ``J_i`` kept in the dynamic models)

        r_b1 (F_A1 - F_12) + M_1 = J_1 (a_c + rho_1 a_d)
        r_b2 (F_B2 - F_12) + M_2 = J_2 (a_c + rho_2 a_d)

    ``F_12`` drops out of the torque balance (``rho_1 r_b1 + rho_2 r_b2 = 0``), but it decides
    how the two pins are loaded. At break-away both planets slip, ``M_i = -sgn(w_i) M_i,max``,
    and the two balances fix ``F_12`` and the torque difference. Without preload the solution
    is homogeneous in the torque, so ``|T_A - T_B| = K |T_A + T_B|`` with a locking coefficient
    that depends on the sign of the torque (drive ``T_A + T_B > 0``: the load on the drive flanks,
    the carrier driving the suns; coast: on the coast flanks, the suns driving the carrier) and
    in principle on which sun runs ahead (for the paper's set the two agree to 7 digits without
    flank friction; with it they do not, :mod:`spurdiff.differential.flank_law`); it does not depend on ``n`` (the mesh forces scale with ``1/n``, the
    number of pins with ``n``). :func:`breakaway` solves it exactly; :func:`first_order_K` is
    its linearisation with equal mesh forces ``F = T_0 / (n (r_bA + r_bB))``:

        K_1 = mu r_d (|rho_1| p_1 + |rho_2| p_2) / (r_bA + r_bB),   p_i = |F_pin,i| / F.

    The rigid level uses the same balances (:class:`spurdiff.differential.rigid.RigidDifferential`), so it
    breaks away where the compliant and contact levels do; the pins stay loaded with opposite
    sun torques and ``T_A + T_B = 0``, where the paper's law has no capacity at all.

The lever ``mu r_d``: ``r_d`` is the journal radius of the pin (the pin load of a spur-gear planet
is radial), ``mu`` the bushing's coefficient, with the friction-circle correction where the data set
has it (:mod:`spurdiff.differential.bushing`, ``spurdiff/data/pin_bushing.toml``). K is a break-away
value (the static coefficient, ``mu_pin``); the dynamics slip with the lever of ``mu_pinDynamic``,
whose K (the same law with that lever) is the sliding K. Not in this law:
flank friction (:mod:`spurdiff.differential.flank_law`) and the planets' centrifugal pin loads
(:mod:`spurdiff.differential.speed_law`); docs/locking-law.md.

``paper``, the paper's formula as published (with ``n`` planet pairs)
    ``K = (mu r_d / n) (1/(r_a + r_1) + 1/(r_b + r_2))``, capacity ``K |T_A + T_B| + T_pre``;
    the mesh levels scale the pin friction so that their drive capacity is this K.

Sign conventions: drive means positive normal forces on the drive flanks (the carrier drives
the suns in the positive sense of rotation); planet 2 leads planet 1 in that sense (the
mirrored assembly swaps the drive and coast values).
"""
from __future__ import annotations

import math

from spurdiff.gears.geometry import DifferentialGeometry
from spurdiff.gears.layout import PinLayout, kinematics
from spurdiff.numerics import solve_2x2
from spurdiff.attrpath import record

LOCKING_LAWS = ("pinFriction", "paper")


def paper_locking_coefficient(mu: float, r_d: float, n_pairs: int, r_a: float, r_1: float, r_b: float,
                              r_2: float) -> float:
    """The paper's K = (mu r_d / n) (1/(r_a + r_1) + 1/(r_b + r_2)), dimensionless."""
    return mu * r_d / n_pairs * (1.0 / (r_a + r_1) + 1.0 / (r_b + r_2))


@record(frozen=True)
class PinFriction:
    """Constants of the pin-friction law of one gear set (see the module docstring)."""

    layout: PinLayout
    c: float            # friction lever mu r_d of the pins (m); paper law: calibrated lever
    M0: tuple           # preload moment per planet (N m)
    rho: tuple          # planet spin per differential speed, (rho_1, rho_2)
    rb: tuple           # base radii (sun A, planet 1, sun B, planet 2)
    n: int

    def capacity(self, i: int, Fs: float, F12: float) -> tuple[float, float, float]:
        """Friction capacity of planet i's pin (N m) and its derivatives by Fs and F12."""
        p, dS, d12 = self.layout.pin_force(i, Fs, F12)
        return self.c * p + self.M0[i], self.c * dS, self.c * d12


def pin_friction(geo: DifferentialGeometry, mu: float, r_d: float, preload: float = 0.0,
                 law: str = "pinFriction", pin_model: str = "endReactions",
                 handedness: str = "leading", factor: float = 1.0) -> PinFriction:
    """The pin-friction constants for ``law``: lever ``mu r_d`` (pinFriction), or the lever that
    gives the paper's K in drive with equal mesh forces (paper, always with the planar pins); preload
    split equally between the two planet sets on the differential motion. ``pin_model``: how a
    pin carries its planet's loads along the journal (:class:`PinLayout`: endReactions,
    linearPressure, planar), ``handedness``: planet 2 leading or trailing planet 1, ``factor`` the
    journal's friction moment per ``mu r |F|`` (``pinContactFactor``: 1 the friction circle, 4/pi a
    run-in bushing; docs/locking-law.md)."""
    kin = kinematics(geo)
    rho = (kin.planet1_per_sunA, kin.planet2_per_sunA)
    n = geo.table.nPairs
    layout = PinLayout.of(geo, "planar" if law == "paper" else pin_model, handedness)
    rbA, rb1, rbB, rb2 = geo.meshA1.rb1, geo.meshA1.rb2, geo.meshB2.rb1, geo.meshB2.rb2
    if law == "paper":
        K = paper_locking_coefficient(mu, r_d, n, geo.r_a, geo.r_1, geo.r_b, geo.r_2)
        p1, p2 = layout.unit_pin_loads(1.0)
        denom = abs(rho[0]) * p1 + abs(rho[1]) * p2
        # quasi-static: n c (|rho1| Fp1 + |rho2| Fp2) = K (T_A + T_B) = K n (rb_A + rb_B) F
        c = K * (rbA + rbB) / denom if denom > 0.0 else 0.0
    else:
        c = mu * r_d if factor == 1.0 else mu * r_d * factor
    M0 = tuple(preload / (2.0 * n * abs(r)) for r in rho)
    return PinFriction(layout, c, M0, rho, (rbA, rb1, rbB, rb2), n)


def dynamic_pin_model(p) -> tuple[str, str, float]:
    """(pinModel, pairHandedness, pinContactFactor) of the parameters ``p`` for the dynamic levels, which carry the
    planar and the end-reaction pins (Python and C alike); ``linearPressure`` is the quasi-static
    law's alone (spurdiff info, the statics): a ParameterError there."""
    if p.pinModel == "linearPressure" and p.lockingLaw == "pinFriction":
        from spurdiff.errors import ParameterError
        raise ParameterError("pinModel", p.pinModel, "endReactions | planar in the simulation",
                             "linearPressure is computed by the quasi-static law only (spurdiff info, the statics)")
    return p.pinModel, p.pairHandedness, p.pinContactFactor


def first_order_K(pf: PinFriction, sign: float = 1.0) -> float:
    """Locking coefficient linearised with equal mesh forces (the review's estimate):
    ``K_1 = c (|rho_1| p_1 + |rho_2| p_2) / (r_bA + r_bB)`` with ``p_i`` the unit pin loads."""
    p1, p2 = pf.layout.unit_pin_loads(sign)
    rbA, _, rbB, _ = pf.rb
    return pf.c * (abs(pf.rho[0]) * p1 + abs(pf.rho[1]) * p2) / (rbA + rbB)


@record(frozen=True)
class Breakaway:
    """Quasi-static break-away state (planet inertia 0): sun torques and mesh forces per pair."""

    T_A: float
    T_B: float
    F_A1: float
    F_B2: float
    F_12: float
    F_pin: tuple        # the pins' friction loads (N): |F_pin| planar, |R_0| + |R_L| with the end reactions
    M: tuple
    R: tuple = ()       # the journals' end reactions per planet (R_0x, R_0y, R_Lx, R_Ly), N

    @property
    def K(self) -> float:
        """|T_A - T_B| / |T_A + T_B| (without preload: the locking coefficient)."""
        return abs(self.T_A - self.T_B) / abs(self.T_A + self.T_B)


def breakaway(pf: PinFriction, T0: float, s: float) -> Breakaway:
    """Sun torques at which the differential breaks away (both planets at their friction limit)
    under the total sun torque ``T0 = T_A + T_B`` (N m, > 0 drive, < 0 coast), sun A running
    ahead of the carrier (``s = +1``) or behind it (``s = -1``).

    Unknowns ``D = T_A - T_B`` and ``F_12``; equations: the two planet moment balances with
    ``M_i = -sgn(rho_i s) M_i,max`` (Newton with the analytic derivatives)."""
    rbA, rb1, rbB, rb2 = pf.rb
    n = pf.n
    sg1 = math.copysign(1.0, pf.rho[0]) * s
    sg2 = math.copysign(1.0, pf.rho[1]) * s
    # T_A = (T0 + D) / 2, T_B = (T0 - D) / 2
    D = -s * first_order_K(pf, math.copysign(1.0, T0)) * abs(T0)
    F12 = T0 / (n * (rbA + rbB))
    for _ in range(60):
        FA, FB = (T0 + D) / (2 * n * rbA), (T0 - D) / (2 * n * rbB)
        c1, c1S, c112 = pf.capacity(0, FA, F12)
        c2, c2S, c212 = pf.capacity(1, FB, F12)
        r1 = rb1 * (FA - F12) - sg1 * c1
        r2 = rb2 * (FB - F12) - sg2 * c2
        a11 = (rb1 - sg1 * c1S) / (2 * n * rbA)
        a12 = -rb1 - sg1 * c112
        a21 = -(rb2 - sg2 * c2S) / (2 * n * rbB)
        a22 = -rb2 - sg2 * c212
        dD, dF = solve_2x2(a11, a12, a21, a22, r1, r2)
        D -= dD
        F12 -= dF
        if abs(dD) <= 1e-14 * abs(T0) and abs(dF) <= 1e-14 * abs(F12) + 1e-300:
            break
    FA, FB = (T0 + D) / (2 * n * rbA), (T0 - D) / (2 * n * rbB)
    p1 = pf.layout.pin_force(0, FA, F12)[0]
    p2 = pf.layout.pin_force(1, FB, F12)[0]
    M1 = -sg1 * pf.capacity(0, FA, F12)[0]
    M2 = -sg2 * pf.capacity(1, FB, F12)[0]
    R = (pf.layout.end_reactions(0, FA, F12), pf.layout.end_reactions(1, FB, F12))
    return Breakaway(n * rbA * FA, n * rbB * FB, FA, FB, F12, (p1, p2), (M1, M2), R)


LEADING_SUNS = ("either", "A", "B")


def locking_coefficients(pf: PinFriction, leading: str = "either") -> tuple[float, float]:
    """(K_drive, K_coast) without preload: the break-away coefficient with sun A running ahead of
    the carrier (``leading = "A"``), sun B ahead (``"B"``), or the smaller of the two (``"either"``,
    the differential breaks away the easier way). With planar pins the two directions agree to
    rounding for the paper's set (tests/physics/test_locking_law_doc.py); with planet 2's couple
    they do not (docs/locking-law.md)."""
    pf0 = PinFriction(pf.layout, pf.c, (0.0, 0.0), pf.rho, pf.rb, pf.n)
    if pf.c == 0.0:
        return 0.0, 0.0
    if leading not in LEADING_SUNS:
        raise ValueError(f"leadingSun {leading!r}: one of {', '.join(LEADING_SUNS)}")
    dirs = {"either": (1.0, -1.0), "A": (1.0,), "B": (-1.0,)}[leading]
    out = []
    for sign in (1.0, -1.0):
        out.append(min(breakaway(pf0, sign * 1000.0, s).K for s in dirs))
    return out[0], out[1]


def torque_bias_ratio(K: float) -> float:
    """Largest ratio of the two sun torques the locking friction allows: (1 + K) / (1 - K)."""
    return (1.0 + K) / (1.0 - K) if K < 1.0 else math.inf
