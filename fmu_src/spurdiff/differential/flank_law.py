"""Flank friction in the locking law: the quasi-static break-away with Coulomb friction on the
tooth flanks as well as on the pins (the locking coefficient "with flank friction").

Each mesh of a planet pair carries the normal force ``F`` (per pair) on ``n_c`` tooth pairs (two
while the phase ``xi < eps - 1``, else one), shared equally. A pair in contact at distance ``l_1``
from gear 1's base tangent point (``l_2 = L - l_1`` from gear 2's, ``L = a sin(alpha_w)``) slides
at ``v = W_1 l_1 + W_2 l_2`` (``W``: the gears' speeds relative to the carrier; ``v`` changes
sign at the pitch point). Coulomb friction ``mu |F| / n_c`` opposes ``v``, perpendicular to the
line of action, so its moments about the two gear axes are ``-mu sgn(v) |F| l_1 / n_c`` and
``-mu sgn(v) |F| l_2 / n_c``: arms along the line of action, the same contact-path conventions
as the mesh levels' :class:`spurdiff.differential.mesh.forces.FlankFriction` (which regularises
``sgn``; this module is its Coulomb limit, written from the gear geometry alone).

At break-away the differential moves in one direction ``s`` (sun A ahead of the carrier:
``s = +1``); every gear's speed relative to the carrier is then ``s (1, lam, rho_1, rho_2)``
times the differential speed, so each flank-friction moment is ``m_g |F|`` with a fixed arm
``m_g`` per gear and mesh (:func:`flank_arms`). With planet inertia 0 the balances are

    T_A = n (r_bA F_A1 + m_A |F_A1|),      T_B = n (r_bB F_B2 + m_B |F_B2|)
    r_b1 (F_A1 - F_12) + m_1A |F_A1| + m_1,12 |F_12| + M_1 = 0
    r_b2 (F_B2 - F_12) + m_2B |F_B2| + m_2,12 |F_12| + M_2 = 0

with the pin moments ``M_i = -sgn(rho_i s) M_i,max`` of :mod:`spurdiff.differential.locking`.
Given ``T_A + T_B = T_0`` they fix ``F_A1, F_B2, F_12`` and ``K = |T_A - T_B| / |T_0|``.
The arms depend on the mesh phases: :func:`locking_coefficients_flank` gives ``K`` with the
mesh-cycle average of each mesh's arms (what a differential turning many mesh cycles sees, and
what the rigid level carries), at the mesh levels' start phases (what a slow ramp from rest
breaks away at), and the range over one joint cycle of the three meshes.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from spurdiff.differential.locking import PinFriction, breakaway
from spurdiff.gears.geometry import DifferentialGeometry
from spurdiff.gears.layout import kinematics
from spurdiff.gears.phasing import mesh_phases
from spurdiff.numerics import solve_system

# mesh order A1, B2, 12: gears (0 sun A, 1 sun B, 2 planet 1, 3 planet 2) and the roll sign
_GEARS = ((0, 2), (1, 3), (2, 3))
_SIGMA = (1.0, 1.0, -1.0)


@dataclass(frozen=True)
class MeshPath:
    """The contact path of one mesh (m): base pitch, start ``l1min`` and length of the usable
    path from gear 1's base tangent point, tangent-point distance ``L``, start phases."""

    pb: float
    l1min: float
    galpha: float
    L: float
    xi_drive: float
    xi_coast: float


def mesh_paths(geo: DifferentialGeometry) -> tuple[MeshPath, MeshPath, MeshPath]:
    phases = mesh_phases(geo)
    out = []
    for name, me in zip(("A1", "B2", "12"), geo.meshes):
        l0, l1 = me.usable_path
        out.append(MeshPath(me.pb, l0, l1 - l0, me.a * math.sin(me.alpha_w), phases[name].drive,
                            phases[name].coast))
    return tuple(out)


def _arms_at(p: MeshPath, xi: float, W1: float, W2: float) -> tuple[float, float]:
    """Coulomb flank-friction moments on gears 1 and 2 per unit |F| and unit mu at phase xi."""
    x = xi * p.pb
    nc = 2 if x + p.pb <= p.galpha else 1
    m1 = m2 = 0.0
    for _ in range(nc):
        l1 = p.l1min + x
        l2 = p.L - l1
        v = W1 * l1 + W2 * l2
        # at the pitch point (rolling, v = 0 to rounding) Coulomb friction is undetermined: 0
        tol = 1e-9 * (abs(W1) + abs(W2)) * p.L
        sg = (v > tol) - (v < -tol)
        m1 -= sg * l1 / nc
        m2 -= sg * l2 / nc
        x += p.pb
    return m1, m2


def _speeds(geo: DifferentialGeometry, s: float) -> tuple[float, float, float, float]:
    kin = kinematics(geo)
    return s, s * kin.sunB_per_sunA, s * kin.planet1_per_sunA, s * kin.planet2_per_sunA


def flank_arms(geo: DifferentialGeometry, s: float, flank: float, phases=None,
               samples: int = 720) -> tuple[tuple[float, float], ...]:
    """Arms ``(m_g1, m_g2)`` per mesh (A1, B2, 12) per unit mu and unit |F|, differential motion
    in direction ``s``, on the drive (``flank = +1``) or coast (-1) flanks; at the given phases
    (one per mesh), else averaged over each mesh's cycle (``samples`` phases, midpoint rule)."""
    W = _speeds(geo, s)
    out = []
    for k, p in enumerate(mesh_paths(geo)):
        g1, g2 = _GEARS[k]
        if phases is not None:
            out.append(_arms_at(p, phases[k], W[g1], W[g2]))
            continue
        a1 = a2 = 0.0
        for j in range(samples):
            m1, m2 = _arms_at(p, (j + 0.5) / samples, W[g1], W[g2])
            a1 += m1
            a2 += m2
        out.append((a1 / samples, a2 / samples))
    return tuple(out)


def start_phases(geo: DifferentialGeometry, flank: float, roll_A: float = 0.0) -> tuple[float, float, float]:
    """Phases of the loaded flanks of the three meshes when sun A has rolled ``roll_A`` (m, on its
    base circle) from the mesh levels' start, the planets and sun B following rigidly."""
    kin = kinematics(geo)
    mA, mB, m12 = geo.meshes
    psiA = roll_A / mA.rb1
    rolls = (roll_A, mB.rb1 * kin.sunB_per_sunA * psiA, mA.rb2 * kin.planet1_per_sunA * psiA)
    out = []
    for k, p in enumerate(mesh_paths(geo)):
        r = _SIGMA[k] * rolls[k] / p.pb
        out.append((p.xi_drive - r) % 1.0 if flank > 0.0 else (p.xi_coast + r) % 1.0)
    return tuple(out)


@dataclass(frozen=True)
class FlankBreakaway:
    T_A: float
    T_B: float
    F_A1: float
    F_B2: float
    F_12: float

    @property
    def K(self) -> float:
        return abs(self.T_A - self.T_B) / abs(self.T_A + self.T_B)


def breakaway_flank(pf: PinFriction, mu: float, arms, T0: float, s: float) -> FlankBreakaway:
    """Break-away (pins and flanks at their Coulomb limits) under ``T0 = T_A + T_B`` (N m),
    direction ``s``, with the flank arms ``arms`` of :func:`flank_arms` (per unit mu)."""
    rbA, rb1, rbB, rb2 = pf.rb
    n = pf.n
    (mA, m1A), (mB, m2B), (m1_12, m2_12) = [(mu * a, mu * b) for a, b in arms]
    sg1 = math.copysign(1.0, pf.rho[0]) * s
    sg2 = math.copysign(1.0, pf.rho[1]) * s
    scale = abs(T0) / (n * (rbA + rbB))

    def res(x):
        FA, FB, F12 = x[0] * scale, x[1] * scale, x[2] * scale
        TA = n * (rbA * FA + mA * abs(FA))
        TB = n * (rbB * FB + mB * abs(FB))
        M1 = -sg1 * pf.capacity(0, FA, F12)[0]
        M2 = -sg2 * pf.capacity(1, FB, F12)[0]
        return [(rb1 * (FA - F12) + m1A * abs(FA) + m1_12 * abs(F12) + M1) / (rb1 * scale),
                (rb2 * (FB - F12) + m2B * abs(FB) + m2_12 * abs(F12) + M2) / (rb2 * scale),
                (TA + TB - T0) / abs(T0)]

    b = breakaway(pf, T0, s)
    x0 = [b.F_A1 / scale, b.F_B2 / scale, b.F_12 / scale]
    sol = solve_system(res, x0, xtol=1e-14)
    if not sol.success:
        raise ArithmeticError(f"flank-friction break-away did not converge: {sol.message}")
    FA, FB, F12 = (float(v) * scale for v in sol.x)
    return FlankBreakaway(n * (rbA * FA + mA * abs(FA)), n * (rbB * FB + mB * abs(FB)), FA, FB, F12)


def _pin_only(pf: PinFriction) -> PinFriction:
    return PinFriction(pf.layout, pf.c, (0.0, 0.0), pf.rho, pf.rb, pf.n)


def locking_coefficient_flank(geo: DifferentialGeometry, pf: PinFriction, mu: float, sign: float,
                              phases=None) -> float:
    """K with flank friction ``mu`` (static coefficient at break-away) in drive (``sign = +1``)
    or coast: the smaller of the two directions of motion, as
    :func:`spurdiff.differential.locking.locking_coefficients`; mesh-cycle average of the arms
    unless ``phases`` are given (a function of the flank sign returning the three phases)."""
    pf0 = _pin_only(pf)
    out = []
    for s in (1.0, -1.0):
        ph = phases(sign, s) if callable(phases) else phases
        arms = flank_arms(geo, s, sign, ph)
        out.append(breakaway_flank(pf0, mu, arms, sign * 1000.0, s).K)
    return min(out)


@dataclass(frozen=True)
class FlankLocking:
    """Locking coefficients with flank friction (drive, coast): mesh-cycle average, at the
    mesh levels' start phases, and the range over one joint cycle."""

    mu: float
    average: tuple
    start: tuple
    lo: tuple
    hi: tuple


def locking_coefficients_flank(geo: DifferentialGeometry, pf: PinFriction, mu: float,
                               cycle_samples: int = 60) -> FlankLocking:
    avg = tuple(locking_coefficient_flank(geo, pf, mu, sg) for sg in (1.0, -1.0))
    st = tuple(locking_coefficient_flank(geo, pf, mu, sg, start_phases(geo, sg)) for sg in (1.0, -1.0))
    # one joint cycle: sun A rolls one base pitch of mesh A1 times the planets' tooth count
    # (the three phases repeat together after z_planet1 pitches of A1; sampled)
    pbA = geo.meshA1.pb
    span = pbA * geo.table.planet1.z
    lo, hi = [], []
    for sg in (1.0, -1.0):
        ks = [locking_coefficient_flank(geo, pf, mu, sg, start_phases(geo, sg, span * j / cycle_samples))
              for j in range(cycle_samples)]
        lo.append(min(ks))
        hi.append(max(ks))
    return FlankLocking(mu, avg, st, tuple(lo), tuple(hi))
