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

from typing import NamedTuple

from spurdiff.differential.mesh.laws import elasto_backlash, friction_coefficient, impact, impact_potential
from spurdiff.differential.mesh.layout import GEAR_1, GEAR_2, GEAR_A, GEAR_B, VA, VB, W1, W2, WC, MeshData, relative_angles, rolls


class MeshForce(NamedTuple):
    """Normal force of one pair (N), its partial derivatives by the deflection and its rate, its
    conservative part, and the phase of the flank in contact."""

    F: float
    dF_dd: float
    dF_dv: float
    Fc: float
    xi: float


class Phase(NamedTuple):
    """Phases of the drive and coast flanks and their stiffness factors (n_c / eps)."""

    xp: float
    xn: float
    kp: float
    kn: float


class FlankMoments(NamedTuple):
    """Flank friction of one pair: moments on gear 1 and 2, their derivatives by F and by the gear
    speeds, and the dissipated power."""

    M1: float
    M2: float
    dM1_dF: float
    dM2_dF: float
    d11: float
    d12: float
    d22: float
    P: float


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


NO_MOMENTS = FlankMoments(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


# ---------------------------------------------------------------- mesh laws
class BilateralSpring:
    """Compliant level without backlash: ``F = k d + c d'`` (both flanks touch at d = 0)."""

    def force(self, m: MeshData, d: float, dd: float, ph: Phase) -> MeshForce:
        if d >= 0.0:
            kk = m.k * ph.kp
            return MeshForce(kk * d + m.c * dd, kk, m.c, kk * d, ph.xp)
        kk = m.k * ph.kn
        return MeshForce(kk * d + m.c * dd, kk, m.c, kk * d, ph.xn)

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
            return MeshForce(F, dFp, dFv, Fc, ph.xp)
        pen = -(d + m.jn)
        if pen > 0.0:
            F, dFp, dFv, Fc = self.flank(m, pen, -dd, ph.kn)
            return MeshForce(-F, dFp, dFv, -Fc, ph.xn)
        return MeshForce(0.0, 0.0, 0.0, 0.0, ph.xp)


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
    ``frac(xi_0c + sigma u / p_b)``; with the stiffness wave the stiffness factor
    ``n_c / eps`` (two pairs for ``xi < eps - 1``). Without either phase effect the phases stay
    at their start values (nothing reads them)."""

    def __init__(self, wave: bool, tracked: bool):
        self.wave, self.tracked = wave, tracked

    def factor(self, m: MeshData, xi: float) -> float:
        if not self.wave:
            return 1.0
        return (2.0 if xi < m.eps - 1.0 else 1.0) / m.eps

    def phase(self, m: MeshData, u: float) -> Phase:
        if not self.tracked:
            return Phase(m.xi0, m.xi0c, 1.0, 1.0)
        r = m.sigma * u / m.pb
        xp = (m.xi0 - r) % 1.0
        xn = (m.xi0c + r) % 1.0
        if self.wave:
            e1 = m.eps - 1.0
            return Phase(xp, xn, (2.0 if xp < e1 else 1.0) / m.eps, (2.0 if xn < e1 else 1.0) / m.eps)
        return Phase(xp, xn, 1.0, 1.0)

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

    def moments(self, m: MeshData, F: float, xi: float, W1: float, W2: float) -> FlankMoments:
        if F == 0.0:
            return NO_MOMENTS
        mu_s, mu_d, v_s, v_d = self.mu_s, self.mu_d, self.v_s, self.v_d
        x0 = xi * m.pb
        nc = 2 if x0 + m.pb <= m.galpha else 1
        aF = abs(F)
        sF = 1.0 if F > 0.0 else -1.0
        share = aF / nc
        M1 = M2 = dM1F = dM2F = d11 = d12 = d22 = P = 0.0
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
            x += m.pb
        return FlankMoments(M1, M2, dM1F, dM2F, d11, d12, d22, P)


# ---------------------------------------------------------------- the right-hand side
def gear_meshes(md) -> tuple:
    """For each gear A, B, 1, 2: the meshes acting on it as (mesh index, side 1 or 2)."""
    return tuple(tuple((i, 1 if m.g1 == g else 2) for i, m in enumerate(md) if g in (m.g1, m.g2))
                 for g in (GEAR_A, GEAR_B, GEAR_1, GEAR_2))


def evaluate(c, y, f, J) -> SideValues:
    """f = y'(y) in the current friction modes; J = df/dy rows that depend on y (if J is given).

    ``c``: the model (constants, inputs, effects, friction modes ``s``; see
    :class:`spurdiff.differential.mesh.model.MeshDifferential`)."""
    yl = y.tolist()
    W = (yl[4], yl[5], yl[6], yl[7])        # gear speeds relative to the carrier: vA, vB, w1, w2
    n = c.n
    md = c.md
    if c._need_phase:
        psiB, th1, _ = relative_angles(c, yl)
        us = (c.rbA * yl[0], c.rbB * psiB, c.rb1 * th1)
    else:
        us = (0.0, 0.0, 0.0)
    law, phase = c.law_obj, c.phase_obj
    dds, mf = [], []
    for i, m in enumerate(md):
        dd = m.a1 * W[m.g1] + m.a2 * W[m.g2]
        dds.append(dd)
        mf.append(law.force(m, yl[m.d], dd, phase.phase(m, us[i])))
    fA, fB, f12 = mf
    FA, FB, F12 = fA.F, fB.F, f12.F
    P = n * ((FA - fA.Fc) * dds[0] + (FB - fB.Fc) * dds[1] + (F12 - f12.Fc) * dds[2])
    # generalised forces of the four gears and their coefficients on the mesh forces
    rbA, rb1, rbB, rb2 = c.rbA, c.rb1, c.rbB, c.rb2
    Q = [rbA * FA, rbB * FB, rb1 * (FA - F12), rb2 * (FB - F12)]
    C = [[rbA, 0.0, 0.0], [0.0, rbB, 0.0], [rb1, 0.0, -rb1], [0.0, rb2, -rb2]]
    G = None     # velocity coefficients of the flank friction, G[gear][gear]
    if c.flank_obj is not None:
        G = [[0.0] * 4 for _ in range(4)]
        Pf = 0.0
        for i, m in enumerate(md):
            fm = c.flank_obj.moments(m, mf[i].F, mf[i].xi, W[m.g1], W[m.g2])
            g1, g2 = m.g1, m.g2
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
            M1 = -s1 * cap1
            Q1 += M1
            C[2][0] -= s1 * cd * dp1S
            C[2][2] -= s1 * cd * dp112
            P += n * abs(M1 * W[2])
        if not stuck2:
            M2 = -s2 * cap2
            Q2 += M2
            C[3][1] -= s2 * cd * dp2S
            C[3][2] -= s2 * cd * dp212
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
        rows.append(r)
    gQA, gQB, gQ1, gQ2 = rows
    if c.speed_drive:
        gac = (0.0,) * 7
    else:
        acc = [gQA[k] + gQB[k] for k in range(7)]
        if not stuck1:
            for k in range(7):
                acc[k] += n * gQ1[k]
        if not stuck2:
            for k in range(7):
                acc[k] += n * gQ2[k]
        gac = tuple(-a / Jeff for a in acc)
        J[WC, 1:8] = gac
    iA, iB = 1.0 / c.JA, 1.0 / c.JB
    J[VA, 1:8] = [gQA[k] * iA - gac[k] for k in range(7)]
    J[VB, 1:8] = [gQB[k] * iB - gac[k] for k in range(7)]
    if stuck1:
        J[W1, 1:8] = 0.0
    else:
        i1 = 1.0 / J1_
        J[W1, 1:8] = [gQ1[k] * i1 - gac[k] for k in range(7)]
    if stuck2:
        J[W2, 1:8] = 0.0
    else:
        i2 = 1.0 / J2_
        J[W2, 1:8] = [gQ2[k] * i2 - gac[k] for k in range(7)]
    return sv


def potential(c, yl) -> float:
    """Elastic energy of all mesh springs of the n pairs (J)."""
    us = rolls(c, yl)
    total = 0.0
    for i, m in enumerate(c.md):
        kp, kn = c.phase_obj.factors(m, us[i])
        total += c.law_obj.potential(m, yl[m.d], kp, kn)
    return c.n * total
