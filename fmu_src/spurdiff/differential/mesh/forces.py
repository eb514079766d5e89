"""Forces of the mesh model: each effect a small object, and the right-hand side / Jacobian as
one loop over the three meshes of a planet pair.

Effects and their interfaces:

* the mesh law (:class:`BilateralSpring` = compliant without backlash, :class:`ElastoBacklash` =
  compliant with backlash, :class:`Impact` = contact level): ``force(m, d, d', phase)`` returns a
  :class:`MeshForce`; ``potential(m, d, kp, kn)`` the elastic energy; ``deflection(m, F, kf)`` the
  static deflection. Damping is part of the law (``c`` of the compliant law, IMPACT's ``C``).
* the mesh phase (:class:`MeshPhase`): ``phase(m, u)`` gives the phases and stiffness factors of
  the drive and coast flanks (Kahraman and Singh's rectangular wave with
  ``meshStiffnessVariation``, else factor 1).
* flank friction (:class:`FlankFriction`): ``moments(m, F, xi, W1, W2)`` gives the
  :class:`FlankMoments` on the two gears of a mesh.
* pin friction: the capacity of each planet's pin from its bearing force
  (:class:`spurdiff.gears.layout.PinLayout`), its mode (stuck / slipping) kept by the model.

Equations and signs: :mod:`spurdiff.differential.mesh.model`.
"""
from __future__ import annotations

import math
from typing import NamedTuple

from spurdiff.differential.mesh.laws import elasto_backlash, friction_coefficient, impact, impact_potential
from spurdiff.differential.mesh.layout import GEAR_1, GEAR_2, GEAR_A, GEAR_B, VA, VB, W1, W2, WC, MeshData, relative_angles, rolls


class MeshForce(NamedTuple):
    """Normal force of one pair (N), its partial derivatives by the deflection and its rate, its
    conservative part, the phase of the flank in contact, its number of pairs in contact and
    ``sx = d(xi p_b)/du`` (-sigma on the drive flank, +sigma on the coast flank)."""

    F: float
    dF_dd: float
    dF_dv: float
    Fc: float
    xi: float
    nc: int
    sx: float


class Phase(NamedTuple):
    """Phases of the drive and coast flanks, their stiffness factors (n_c / eps) and their numbers
    of pairs in contact n_c."""

    xp: float
    xn: float
    kp: float
    kn: float
    np: int
    nn: int


class FlankMoments(NamedTuple):
    """Flank friction of one pair: moments on gear 1 and 2, their derivatives by F, by the gear
    speeds and by the contact position ``x = xi p_b`` (the lever arms), and the dissipated power."""

    M1: float
    M2: float
    dM1_dF: float
    dM2_dF: float
    d11: float
    d12: float
    d22: float
    P: float
    dM1_dx: float = 0.0
    dM2_dx: float = 0.0


class SideValues(NamedTuple):
    """What an evaluation leaves besides f and J: mesh forces, generalised forces, pin friction
    moments and capacities, dissipated power, carrier acceleration."""

    F_A1: float
    F_B2: float
    F_12: float
    Q_A: float
    Q_B: float
    Q_1: float
    Q_2: float
    M_1: float
    M_2: float
    cap_1: float
    cap_2: float
    P: float
    ac: float


NO_MOMENTS = FlankMoments(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


# ---------------------------------------------------------------- mesh laws
class BilateralSpring:
    """Compliant level without backlash: ``F = k d + c d'`` (both flanks touch at d = 0)."""

    def force(self, m: MeshData, d: float, dd: float, ph: Phase) -> MeshForce:
        if d >= 0.0:
            kk = m.k * ph.kp
            return MeshForce(kk * d + m.c * dd, kk, m.c, kk * d, ph.xp, ph.np, -m.sigma)
        kk = m.k * ph.kn
        return MeshForce(kk * d + m.c * dd, kk, m.c, kk * d, ph.xn, ph.nn, m.sigma)

    def potential(self, m: MeshData, d: float, kp: float, kn: float) -> float:
        return 0.5 * m.k * (kp if d >= 0.0 else kn) * d * d

    def penetration(self, m: MeshData, F: float, kf: float) -> float:
        return abs(F) / (m.k * kf)


class _Unilateral:
    """A law acting on each flank separately: penetration ``p = d`` on the drive flank and
    ``p = -(d + j_n)`` on the coast flank, no force in the clearance."""

    def force(self, m: MeshData, d: float, dd: float, ph: Phase) -> MeshForce:
        if d > 0.0:
            F, dFp, dFv, Fc = self.flank(m, d, dd, ph.kp)
            return MeshForce(F, dFp, dFv, Fc, ph.xp, ph.np, -m.sigma)
        pen = -(d + m.jn)
        if pen > 0.0:
            F, dFp, dFv, Fc = self.flank(m, pen, -dd, ph.kn)
            return MeshForce(-F, dFp, dFv, -Fc, ph.xn, ph.nn, m.sigma)
        return MeshForce(0.0, 0.0, 0.0, 0.0, ph.xp, ph.np, -m.sigma)


class ElastoBacklash(_Unilateral):
    """Compliant level with backlash: MSL ElastoBacklash on each flank."""

    def flank(self, m: MeshData, p: float, v: float, kf: float):
        return elasto_backlash(p, v, m.k * kf, m.c)

    def potential(self, m: MeshData, d: float, kp: float, kn: float) -> float:
        if d > 0.0:
            return 0.5 * m.k * kp * d * d
        pen = -(d + m.jn)
        return 0.5 * m.k * kn * pen * pen if pen > 0.0 else 0.0

    def penetration(self, m: MeshData, F: float, kf: float) -> float:
        return abs(F) / (m.k * kf)


class Impact(_Unilateral):
    """Contact level: ADAMS IMPACT on each flank (exponent e, damping C reached at depth d_max)."""

    def __init__(self, e: float, C: float, dmax: float):
        self.e, self.C, self.dmax = e, C, dmax

    def flank(self, m: MeshData, p: float, v: float, kf: float):
        return impact(p, v, m.K * kf, self.e, self.C, self.dmax)

    def potential(self, m: MeshData, d: float, kp: float, kn: float) -> float:
        if d > 0.0:
            return impact_potential(d, m.K * kp, self.e)
        return impact_potential(-(d + m.jn), m.K * kn, self.e)

    def penetration(self, m: MeshData, F: float, kf: float) -> float:
        return (abs(F) / (m.K * kf)) ** (1.0 / self.e)


# ---------------------------------------------------------------- mesh phase and stiffness wave
class MeshPhase:
    """Phase of the drive flanks ``xi = frac(xi_0 - sigma u / p_b)`` and of the coast flanks
    ``frac(xi_0c + sigma u / p_b)``; the number of pairs in contact (two for ``xi < eps - 1``)
    and with the stiffness wave the stiffness factor ``n_c / eps``. Without either phase effect
    the phases stay at their start values (nothing reads them).

    The phase mode of a flank (:meth:`mode`): the tooth count ``k = floor(z)`` of its unwrapped
    phase ``z`` (``xi = z - k``) and whether two pairs are in contact. Held over an internal step
    (``mode`` given to :meth:`phase`), the phase runs on continuously (``z - k``, it may leave
    [0, 1) by what the step overruns a boundary) and n_c and the stiffness factor stay: the
    right-hand side is smooth within the step; the stepper switches the mode at the located
    boundary (:func:`spurdiff.differential.mesh.events.phase_events`)."""

    def __init__(self, wave: bool, tracked: bool):
        self.wave, self.tracked = wave, tracked

    def factor(self, m: MeshData, xi: float) -> float:
        if not self.wave:
            return 1.0
        return (2.0 if xi < m.eps - 1.0 else 1.0) / m.eps

    def mode(self, m: MeshData, u: float) -> tuple[float, int, float, int]:
        """(k_p, n_c,p, k_n, n_c,n) of the drive and coast flanks at roll u."""
        r = m.sigma * u / m.pb
        zp = m.xi0 - r
        zn = m.xi0c + r
        kp = float(math.floor(zp))
        kn = float(math.floor(zn))
        e1 = m.eps - 1.0
        return kp, 2 if zp - kp < e1 else 1, kn, 2 if zn - kn < e1 else 1

    def phase(self, m: MeshData, u: float, mode=None) -> Phase:
        """Phases at roll u; in the phase mode ``mode`` (:meth:`mode`), else in the mode at u."""
        if not self.tracked:
            return Phase(m.xi0, m.xi0c, 1.0, 1.0, 1, 1)
        r = m.sigma * u / m.pb
        zp = m.xi0 - r
        zn = m.xi0c + r
        if mode is None:
            kp = float(math.floor(zp))
            kn = float(math.floor(zn))
            xp = zp - kp
            xn = zn - kn
            e1 = m.eps - 1.0
            np_ = 2 if xp < e1 else 1
            nn = 2 if xn < e1 else 1
        else:
            kp, np_, kn, nn = mode
            xp = zp - kp
            xn = zn - kn
        if self.wave:
            return Phase(xp, xn, (2.0 if np_ == 2 else 1.0) / m.eps, (2.0 if nn == 2 else 1.0) / m.eps, np_, nn)
        return Phase(xp, xn, 1.0, 1.0, np_, nn)

    def factors(self, m: MeshData, u: float) -> tuple[float, float]:
        """Stiffness factors of the drive and coast flanks at roll u (for the elastic energy)."""
        r = m.sigma * u / m.pb
        return self.factor(m, (m.xi0 - r) % 1.0), self.factor(m, (m.xi0c + r) % 1.0)


# ---------------------------------------------------------------- flank friction
class FlankFriction:
    """Sliding friction on each pair in contact: ``mu(v) |F| / n_c`` at distances ``l_1``, ``l_2``
    from the base tangent points, sliding velocity ``v = W_1 l_1 + W_2 l_2``."""

    def __init__(self, mu_s: float, mu_d: float, v_s: float, v_d: float):
        self.mu_s, self.mu_d, self.v_s, self.v_d = mu_s, mu_d, v_s, v_d

    def moments(self, m: MeshData, F: float, xi: float, W1: float, W2: float, nc: int = 0) -> FlankMoments:
        """The moments at phase xi with ``nc`` pairs in contact (0: from xi). The lever arms
        ``l_1 = l1min + x + j p_b``, ``l_2 = L - l_1`` move with the contact position ``x = xi p_b``:
        ``dM_1/dx = -share sum (mu + mu'(v) (W_1 - W_2) l_1)``,
        ``dM_2/dx = -share sum (mu'(v) (W_1 - W_2) l_2 - mu)``."""
        if F == 0.0:
            return NO_MOMENTS
        mu_s, mu_d, v_s, v_d = self.mu_s, self.mu_d, self.v_s, self.v_d
        x0 = xi * m.pb
        if nc == 0:
            nc = 2 if x0 + m.pb <= m.galpha else 1
        aF = abs(F)
        sF = 1.0 if F > 0.0 else -1.0
        share = aF / nc
        M1 = M2 = dM1F = dM2F = d11 = d12 = d22 = P = dM1x = dM2x = 0.0
        dW = W1 - W2
        x = x0
        for _ in range(nc):
            l1 = m.l1min + x
            l2 = m.L - l1
            v = W1 * l1 + W2 * l2
            mu, dmu = friction_coefficient(v, mu_s, mu_d, v_s, v_d)
            M1 -= mu * share * l1
            M2 -= mu * share * l2
            dM1F -= mu * sF / nc * l1
            dM2F -= mu * sF / nc * l2
            g = dmu * share
            d11 -= g * l1 * l1
            d12 -= g * l1 * l2
            d22 -= g * l2 * l2
            P += mu * share * v
            gx = g * dW
            dM1x -= gx * l1 + mu * share
            dM2x -= gx * l2 - mu * share
            x += m.pb
        return FlankMoments(M1, M2, dM1F, dM2F, d11, d12, d22, P, dM1x, dM2x)


# ---------------------------------------------------------------- the right-hand side
def gear_meshes(md) -> tuple:
    """For each gear A, B, 1, 2: the meshes acting on it as (mesh index, side 1 or 2)."""
    return tuple(tuple((i, 1 if m.g1 == g else 2) for i, m in enumerate(md) if g in (m.g1, m.g2))
                 for g in (GEAR_A, GEAR_B, GEAR_1, GEAR_2))


def _slipping_pin(C_planet: list, sun: int, s: int, cap: float, cd: float, dpS: float, dp12: float) -> float:
    """A slipping planet's pin friction moment ``-s cap`` (N m, s its slip direction); its derivatives
    by the sun mesh's force (column ``sun`` of the planet's row ``C_planet``) and by the planet mesh's
    (column 2) added to that row, at the sliding lever ``cd``."""
    C_planet[sun] -= s * cd * dpS
    C_planet[2] -= s * cd * dp12
    return -s * cap


_ZEROS7 = (0.0,) * 7


def evaluate(c, y, f, J) -> SideValues:
    """f = y'(y) in the current friction modes; J = df/dy rows that depend on y (if J is given).

    ``c``: the model (constants, inputs, effects, friction modes ``s``; see
    :class:`spurdiff.differential.mesh.model.MeshDifferential`)."""
    yl = y if type(y) is list else list(y)
    W = (yl[4], yl[5], yl[6], yl[7])        # gear speeds relative to the carrier: vA, vB, w1, w2
    n = c.n
    md = c.md
    if c._need_phase:
        psiB, th1, _ = relative_angles(c, yl)
        us = (c.rbA * yl[0], c.rbB * psiB, c.rb1 * th1)
    else:
        us = (0.0, 0.0, 0.0)
    law, phase = c.law_obj, c.phase_obj
    mode = c._mode                          # the phase modes held over an internal step, or None
    dds, mf = [], []
    for i, m in enumerate(md):
        dd = m.a1 * W[m.g1] + m.a2 * W[m.g2]
        dds.append(dd)
        mf.append(law.force(m, yl[m.d], dd, phase.phase(m, us[i], mode[i] if mode is not None else None)))
    fA, fB, f12 = mf
    FA, FB, F12 = fA.F, fB.F, f12.F
    P = n * ((FA - fA.Fc) * dds[0] + (FB - fB.Fc) * dds[1] + (F12 - f12.Fc) * dds[2])
    # generalised forces of the four gears and their coefficients on the mesh forces
    rbA, rb1, rbB, rb2 = c.rbA, c.rb1, c.rbB, c.rb2
    Q = [rbA * FA, rbB * FB, rb1 * (FA - F12), rb2 * (FB - F12)]
    C = [[rbA, 0.0, 0.0], [0.0, rbB, 0.0], [rb1, 0.0, -rb1], [0.0, rb2, -rb2]]
    G = None     # velocity coefficients of the flank friction, G[gear][gear]
    Lx = None    # its lever arms' coefficients on (psi_A, d_A1, d_B2, d_12), Lx[gear]
    if c.flank_obj is not None:
        G = [[0.0] * 4 for _ in range(4)]
        Lx = [[0.0] * 4 for _ in range(4)]
        Pf = 0.0
        for i, m in enumerate(md):
            fi = mf[i]
            fm = c.flank_obj.moments(m, fi.F, fi.xi, W[m.g1], W[m.g2], fi.nc)
            g1, g2 = m.g1, m.g2
            # the contact position x = xi p_b moves with the roll u of the mesh (dx/du = sx), and
            # u is linear in (psi_A, d_A1, d_B2, d_12) (c._du, layout.roll_gradients)
            a1, a2 = fm.dM1_dx * fi.sx, fm.dM2_dx * fi.sx
            du = c._du[i]
            L1, L2 = Lx[g1], Lx[g2]
            for k in range(4):
                L1[k] += a1 * du[k]
                L2[k] += a2 * du[k]
            Q[g1] += fm.M1
            Q[g2] += fm.M2
            C[g1][i] += fm.dM1_dF
            C[g2][i] += fm.dM2_dF
            G[g1][g1] += fm.d11
            G[g1][g2] += fm.d12
            G[g2][g1] += fm.d12
            G[g2][g2] += fm.d22
            Pf = Pf + fm.P if i else fm.P
        P += n * Pf
    QA, QB, Q1, Q2 = n * Q[0], n * Q[1], Q[2], Q[3]
    # pin friction
    s1, s2 = c.s
    pin = c._pin
    if pin:
        cp, cd = c.c_pin, c.c_pin_slide
        Fp1, dp1S, dp112 = c._pin_force(0, FA, F12)
        Fp2, dp2S, dp212 = c._pin_force(1, FB, F12)
        stuck1, stuck2 = s1 == 0, s2 == 0
        # the limit of each pin's friction in its mode: static (c_pin) stuck, sliding (c_pin_slide) slipping
        cap1, cap2 = (cp if stuck1 else cd) * Fp1 + c._M01, (cp if stuck2 else cd) * Fp2 + c._M02
    else:
        cap1 = cap2 = 0.0
        stuck1 = stuck2 = False
    Q1nf, Q2nf = Q1, Q2  # without pin friction
    M1 = M2 = 0.0
    if pin:
        if not stuck1:
            M1 = _slipping_pin(C[2], 0, s1, cap1, cd, dp1S, dp112)
            Q1 += M1
            P += n * abs(M1 * W[2])
        if not stuck2:
            M2 = _slipping_pin(C[3], 1, s2, cap2, cd, dp2S, dp212)
            Q2 += M2
            P += n * abs(M2 * W[3])
    # carrier acceleration
    J1_, J2_ = c.J1, c.J2
    if c.speed_drive:
        ac = c._ac
    else:
        Jeff = c.Jc
        Qs = QA + QB
        if stuck1:
            Jeff += n * J1_
        else:
            Qs += n * Q1
        if stuck2:
            Jeff += n * J2_
        else:
            Qs += n * Q2
        ac = (c.tau_c - Qs) / Jeff
    if stuck1:
        M1 = J1_ * ac - Q1nf
        Q1 = J1_ * ac
    if stuck2:
        M2 = J2_ * ac - Q2nf
        Q2 = J2_ * ac
    f[0] = W[0]
    f[1] = dds[0]
    f[2] = dds[1]
    f[3] = dds[2]
    f[4] = (c.tau_L + QA) / c.JA - ac
    f[5] = (c.tau_R + QB) / c.JB - ac
    f[6] = 0.0 if stuck1 else Q1 / J1_ - ac
    f[7] = 0.0 if stuck2 else Q2 / J2_ - ac
    if not c.speed_drive:
        f[8] = ac
        f[9] = yl[WC]
    sv = SideValues(FA, FB, F12, QA, QB, Q1, Q2, M1, M2, cap1, cap2, P, ac)
    if J is None:
        return sv
    # rows of dQ/dy over the columns (dA, dB, d12, vA, vB, w1, w2): through the mesh forces
    # (dF/dd on the mesh's deflection, dF/dd' a on the speeds of its gears) and the flank friction
    rows = []
    rpsi = []
    for g, touching in enumerate(c.gear_meshes):
        sc = n if g < 2 else 1            # the suns carry the n pairs
        r = [0.0] * 7
        for i, _ in touching:
            m = md[i]
            coef = C[g][i]
            r[m.d - 1] = sc * coef * mf[i].dF_dd
            dv = mf[i].dF_dv
            r[m.g1 + 3] += coef * (dv * m.a1)
            r[m.g2 + 3] += coef * (dv * m.a2)
        for k in range(3, 7):
            r[k] = sc * (r[k] + G[g][k - 3]) if G is not None else sc * r[k]
        if Lx is not None:
            lx = Lx[g]
            r[0] += sc * lx[1]
            r[1] += sc * lx[2]
            r[2] += sc * lx[3]
            rpsi.append(sc * lx[0])
        rows.append(r)
    gQA, gQB, gQ1, gQ2 = rows
    if c.speed_drive:
        gac = (0.0,) * 7
        gacp = 0.0
    else:
        acc = [gQA[k] + gQB[k] for k in range(7)]
        if not stuck1:
            for k in range(7):
                acc[k] += n * gQ1[k]
        if not stuck2:
            for k in range(7):
                acc[k] += n * gQ2[k]
        gac = tuple(-a / Jeff for a in acc)
        J[WC][1:8] = gac
        if Lx is not None:
            accp = rpsi[0] + rpsi[1]
            if not stuck1:
                accp += n * rpsi[2]
            if not stuck2:
                accp += n * rpsi[3]
            gacp = -accp / Jeff
            J[WC][0] = gacp
    if Lx is not None:       # the column of psi_A (only the lever arms depend on it)
        J[VA][0] = rpsi[0] * (1.0 / c.JA) - gacp
        J[VB][0] = rpsi[1] * (1.0 / c.JB) - gacp
        J[W1][0] = 0.0 if stuck1 else rpsi[2] * (1.0 / J1_) - gacp
        J[W2][0] = 0.0 if stuck2 else rpsi[3] * (1.0 / J2_) - gacp
    iA, iB = 1.0 / c.JA, 1.0 / c.JB
    J[VA][1:8] = [gQA[k] * iA - gac[k] for k in range(7)]
    J[VB][1:8] = [gQB[k] * iB - gac[k] for k in range(7)]
    if stuck1:
        J[W1][1:8] = _ZEROS7
    else:
        i1 = 1.0 / J1_
        J[W1][1:8] = [gQ1[k] * i1 - gac[k] for k in range(7)]
    if stuck2:
        J[W2][1:8] = _ZEROS7
    else:
        i2 = 1.0 / J2_
        J[W2][1:8] = [gQ2[k] * i2 - gac[k] for k in range(7)]
    return sv


def potential(c, yl) -> float:
    """Elastic energy of all mesh springs of the n pairs (J)."""
    us = rolls(c, yl)
    total = 0.0
    for i, m in enumerate(c.md):
        kp, kn = c.phase_obj.factors(m, us[i])
        total += c.law_obj.potential(m, yl[m.d], kp, kn)
    return c.n * total
