"""The pin-load locking law of the rigid level (``lockingLaw = pinFriction``), apart from the model.

A mixin of :class:`spurdiff.differential.rigid.RigidDifferential` (whose module docstring states the law and the
equations): the constants of the pin-load Newton (:meth:`PinLoadLaw._pin_constants`), the solve of
the planets' moment balances while the differential slips (:meth:`PinLoadLaw._slip_exact`, the
rigid level's hot path, also in C: :mod:`spurdiff.differential.rigid_kernel`), the interval of ``F_12`` each
planet holds while stuck, in closed form (:meth:`PinLoadLaw._planet_interval`,
:meth:`PinLoadLaw._stuck_exact`), and the mode choice with them
(:meth:`PinLoadLaw._accelerations_exact`). The methods read the model's parameters and state
(``pf``, ``J_A`` ... ``rho2``, ``tau_*``, ``wd``), set in :meth:`spurdiff.differential.rigid.RigidDifferential.initialize`.
"""
from __future__ import annotations

import math


class PinLoadLaw:
    """The pin-load law's solves, mixed into :class:`spurdiff.differential.rigid.RigidDifferential`."""

    def _pin_constants(self) -> None:
        """What the pin-load Newton needs that depends on the parameters only (set once, in
        :meth:`initialize`): the pins' unit force parts (:class:`spurdiff.gears.layout.PinLayout`) with
        their sums and differences (the derivative of ``|F_pin|`` for either sign of a mesh force),
        the lever, the preloads and the mesh-force divisors ``n r_b``."""
        pf = self.pf
        rbA, rb1, rbB, rb2 = pf.rb

        def consts(c):
            tx, ty, rx, ry, ux, uy, qx, qy = c
            return (tx, ty, rx, ry, ux, uy, qx, qy,
                    tx + rx, ty + ry, tx - rx, ty - ry,      # d|F_pin|/dFs for Fs >= 0, < 0
                    ux + qx, uy + qy, ux - qx, uy - qy)      # d|F_pin|/dF12 for F12 >= 0, < 0

        # the journal's two ends (spurdiff.gears.layout.PinLayout.ends): end 0 with the inertial
        # loads' share w0, end L with wL; a planar planet has end 0 = the whole force, end L = 0
        ends = pf.layout.ends
        self._pin1, self._pin2 = consts(ends[0][0]), consts(ends[1][0])
        self._pin1L, self._pin2L = consts(ends[0][2]), consts(ends[1][2])
        self._wpin = (ends[0][1], ends[0][3], ends[1][1], ends[1][3])
        self._planar = tuple(e[3] == 0.0 and not any(e[2]) for e in ends)
        self._nrbA, self._nrbB = pf.n * rbA, pf.n * rbB

    def _capacity(self, i: int, Fs: float, F12: float) -> float:
        """Static (break-away) friction capacity of planet i's pin (N m): ``c |F_mesh + g_i + h_i| + M_0,i``
        with the planet's centrifugal and tangential forces ``g_i``, ``h_i`` (:meth:`_set_speed_loads`)."""
        return self.pf.c * self._pin_load(i, Fs, F12)[0] + self.pf.M0[i]

    def _pin_load(self, i: int, Fs: float, F12: float) -> tuple[float, float]:
        """Planet i's pin friction load ``|R_0| + |R_L|`` (N; planar: ``|F_pin|``) with its inertial
        forces, and its derivative by F12."""
        aS, a12 = abs(Fs), abs(F12)
        gx, gy = self._g[2 * i], self._g[2 * i + 1]
        hx, hy = self._gt[2 * i], self._gt[2 * i + 1]
        tot = d12 = 0.0
        for e, c in enumerate((self._pin1, self._pin1L) if i == 0 else (self._pin2, self._pin2L)):
            w = self._wpin[2 * i + e]
            fx = Fs * c[0] + aS * c[2] + F12 * c[4] + a12 * c[6] + w * gx + w * hx
            fy = Fs * c[1] + aS * c[3] + F12 * c[5] + a12 * c[7] + w * gy + w * hy
            mag = math.sqrt(fx * fx + fy * fy)
            if mag != 0.0:
                tot = tot + mag
                d12 = d12 + ((fx * c[12] + fy * c[13]) / mag if F12 >= 0.0 else (fx * c[14] + fy * c[15]) / mag)
        return tot, d12

    def _set_speed_loads(self, wc: float, alpha: float) -> None:
        """The planets' inertial pin loads at the carrier speed ``wc`` and acceleration ``alpha``
        (held over a step; zero without ``pinSpeedLoads``): centrifugal ``m_i a_i w_c^2 e_r,i`` and
        tangential ``-m_i a_i alpha_c e_t,i`` (:mod:`spurdiff.differential.speed_law`). A change
        drops the cached slip solve (its key holds both)."""
        if wc == self._g_wc and alpha == self._g_ac:
            return
        if wc != self._g_wc:
            w2 = wc * wc
            (c1x, c1y), (c2x, c2y) = self._cf
            self._g = (c1x * w2, c1y * w2, c2x * w2, c2y * w2)
            self._g_wc = wc
        if alpha != self._g_ac:
            (t1x, t1y), (t2x, t2y) = self._ct
            self._gt = (t1x * alpha, t1y * alpha, t2x * alpha, t2y * alpha)
            self._g_ac = alpha
        if self._rk is not None:
            self._rk.set_speed_loads(self._g, self._gt)

    def _sun_forces(self, ac: float, ad: float) -> tuple[float, float]:
        """Normal mesh forces per pair of the sun meshes from the sun torques."""
        n = self.pf.n
        rbA, _, rbB, _ = self.pf.rb
        return ((self.J_A * (ac + ad) - self.tau_L) / (n * rbA),
                (self.J_B * (ac + self.lam * ad) - self.tau_R) / (n * rbB))

    def _slip_exact(self, ac_given: float | None, s: float, lever: float | None = None) -> tuple[float, float, float]:
        """Slipping in direction s with the pin-load law: solve the planets' moment balances
        for (a_d, F_12) by Newton, the pins at the sliding lever ``c_slide`` (``mu_pinDynamic``;
        ``lever`` given: that lever instead, the break-away lever ``c_break``);
        returns (ac, ad, Q_f) and leaves F12, cap (the sliding friction) set.

        The hot path of the rigid level (one solve per inner step): the sun forces
        (:meth:`_sun_forces`) and the pin capacities (:meth:`spurdiff.differential.locking.PinFriction.capacity`)
        are written out here with the constants of :meth:`_pin_constants`, the same arithmetic in
        the same order, so the result is bit for bit that of the two calls. With the compiled
        kernel (:mod:`spurdiff.differential.rigid_kernel`) the same solve runs in C, bit for bit."""
        rk = self._rk
        if rk is not None:
            io = rk.io
            ad0 = self._ad_guess
            if ac_given is None:
                io[0:8] = (s, 0.0, 0.0, self.tau_c, self.tau_L, self.tau_R, 0.0 if ad0 is None else ad0, self.F12)
            else:
                io[0:8] = (s, 1.0, ac_given, self.tau_c, self.tau_L, self.tau_R, 0.0 if ad0 is None else ad0,
                           self.F12)
            if lever is None or lever == self.c_slide:
                rk.fn(rk.const, io)
            else:                           # the kernel's lever (constant 53) for this solve only
                k = rk.const
                k[53] = lever
                try:
                    rk.fn(k, io)
                finally:
                    k[53] = self.c_slide
            ac, ad, self.F12, cap = io[8:12]
            self.cap = cap
            return ac, ad, -s * cap
        pf = self.pf
        n = pf.n
        _, rb1, _, rb2 = pf.rb
        nrbA, nrbB = self._nrbA, self._nrbB
        cpin = self.c_slide if lever is None else lever   # sliding: the dynamic lever (mu_pinDynamic)
        M01, M02 = pf.M0
        (t1x, t1y, r1x, r1y, u1x, u1y, q1x, q1y, p1x, p1y, m1x, m1y, P1x, P1y, N1x, N1y) = self._pin1
        (t2x, t2y, r2x, r2y, u2x, u2y, q2x, q2y, p2x, p2y, m2x, m2y, P2x, P2y, N2x, N2y) = self._pin2
        # the journals' far ends (planar planets: all zero, adding nothing; spurdiff.gears.layout.PinLayout.ends)
        (T1x, T1y, R1x, R1y, U1x, U1y, Q1x, Q1y, pL1x, pL1y, mL1x, mL1y, PL1x, PL1y, NL1x, NL1y) = self._pin1L
        (T2x, T2y, R2x, R2y, U2x, U2y, Q2x, Q2y, pL2x, pL2y, mL2x, mL2y, PL2x, PL2y, NL2x, NL2y) = self._pin2L
        w01, wL1, w02, wL2 = self._wpin
        J_A, J_B, lam = self.J_A, self.J_B, self.lam
        J1, J2 = self.J_1, self.J_2
        g1x, g1y, g2x, g2y = self._g
        h1x, h1y, h2x, h2y = self._gt
        G1x, G1y, G2x, G2y = wL1 * g1x, wL1 * g1y, wL2 * g2x, wL2 * g2y     # the far ends' inertial shares
        H1x, H1y, H2x, H2y = wL1 * h1x, wL1 * h1y, wL2 * h2x, wL2 * h2y
        g1x, g1y, g2x, g2y = w01 * g1x, w01 * g1y, w02 * g2x, w02 * g2y     # (planar: times 1, unchanged)
        h1x, h1y, h2x, h2y = w01 * h1x, w01 * h1y, w02 * h2x, w02 * h2y
        rho1, rho2 = self.rho1, self.rho2
        tau_L, tau_R = self.tau_L, self.tau_R
        Mcd, Mcc = self.Mcd, self.Mcc
        sg1 = math.copysign(1.0, rho1) * s
        sg2 = math.copysign(1.0, rho2) * s
        Qc = self.tau_c + tau_L + tau_R
        given = ac_given is not None
        g = 0.0 if given else -Mcd / Mcc
        sqrt = math.sqrt

        # start: the last solution (or 0) for a_d, the last F_12 (or the mean sun force)
        ad = self._ad_guess if self._ad_guess is not None else 0.0
        F12 = self.F12
        if F12 != F12:
            ac = ac_given if given else (Qc - Mcd * ad) / Mcc
            F12 = 0.5 * ((J_A * (ac + ad) - tau_L) / nrbA + (J_B * (ac + lam * ad) - tau_R) / nrbB)
        dFA = J_A * (g + 1.0) / nrbA
        dFB = J_B * (g + lam) / nrbB
        a11_0 = J1 * (g + rho1)
        a21_0 = J2 * (g + rho2)
        final = False    # True: the Newton step fell below rounding, this pass evaluates the pins at the new iterate
        for it in range(51):
            ac = ac_given if given else (Qc - Mcd * ad) / Mcc
            FA = (J_A * (ac + ad) - tau_L) / nrbA
            FB = (J_B * (ac + lam * ad) - tau_R) / nrbB
            aA, aB, a12 = abs(FA), abs(FB), abs(F12)
            # pin force of planet 1 (sun A mesh FA, planet mesh F12) and of planet 2 (FB, F12)
            f1x = FA * t1x + aA * r1x + F12 * u1x + a12 * q1x + g1x + h1x
            f1y = FA * t1y + aA * r1y + F12 * u1y + a12 * q1y + g1y + h1y
            f2x = FB * t2x + aB * r2x + F12 * u2x + a12 * q2x + g2x + h2x
            f2y = FB * t2y + aB * r2y + F12 * u2y + a12 * q2y + g2y + h2y
            e1x = FA * T1x + aA * R1x + F12 * U1x + a12 * Q1x + G1x + H1x
            e1y = FA * T1y + aA * R1y + F12 * U1y + a12 * Q1y + G1y + H1y
            e2x = FB * T2x + aB * R2x + F12 * U2x + a12 * Q2x + G2x + H2x
            e2y = FB * T2y + aB * R2y + F12 * U2y + a12 * Q2y + G2y + H2y
            mag1 = sqrt(f1x * f1x + f1y * f1y)
            mag2 = sqrt(f2x * f2x + f2y * f2y)
            mL1 = sqrt(e1x * e1x + e1y * e1y)
            mL2 = sqrt(e2x * e2x + e2y * e2y)
            c1 = cpin * (mag1 + mL1) + M01
            c2 = cpin * (mag2 + mL2) + M02
            if final:
                break
            r1 = rb1 * (FA - F12) - sg1 * c1 - J1 * (ac + rho1 * ad)
            r2 = rb2 * (FB - F12) - sg2 * c2 - J2 * (ac + rho2 * ad)
            # moment residuals at rounding level of the largest moment: converged
            if abs(r1) + abs(r2) <= 1e-14 * (rb1 * (aA + a12) + rb2 * (aB + a12)) + 1e-300:
                break
            if mag1 == 0.0:
                c1S = c112 = 0.0
            else:
                c1S = cpin * ((f1x * p1x + f1y * p1y) / mag1 if FA >= 0.0 else (f1x * m1x + f1y * m1y) / mag1)
                c112 = cpin * ((f1x * P1x + f1y * P1y) / mag1 if F12 >= 0.0 else (f1x * N1x + f1y * N1y) / mag1)
            if mag2 == 0.0:
                c2S = c212 = 0.0
            else:
                c2S = cpin * ((f2x * p2x + f2y * p2y) / mag2 if FB >= 0.0 else (f2x * m2x + f2y * m2y) / mag2)
                c212 = cpin * ((f2x * P2x + f2y * P2y) / mag2 if F12 >= 0.0 else (f2x * N2x + f2y * N2y) / mag2)
            if mL1 != 0.0:       # the far end of planet 1's journal
                c1S += cpin * ((e1x * pL1x + e1y * pL1y) / mL1 if FA >= 0.0 else (e1x * mL1x + e1y * mL1y) / mL1)
                c112 += cpin * ((e1x * PL1x + e1y * PL1y) / mL1 if F12 >= 0.0 else (e1x * NL1x + e1y * NL1y) / mL1)
            if mL2 != 0.0:
                c2S += cpin * ((e2x * pL2x + e2y * pL2y) / mL2 if FB >= 0.0 else (e2x * mL2x + e2y * mL2y) / mL2)
                c212 += cpin * ((e2x * PL2x + e2y * PL2y) / mL2 if F12 >= 0.0 else (e2x * NL2x + e2y * NL2y) / mL2)
            a11 = (rb1 - sg1 * c1S) * dFA - a11_0
            a12_ = -rb1 - sg1 * c112
            a21 = (rb2 - sg2 * c2S) * dFB - a21_0
            a22 = -rb2 - sg2 * c212
            det = a11 * a22 - a12_ * a21     # spurdiff.numerics.solve_2x2, written out (no call per iteration)
            d_ad = (r1 * a22 - a12_ * r2) / det
            d_F = (a11 * r2 - a21 * r1) / det
            ad -= d_ad
            F12 -= d_F
            scale = aA + aB + abs(F12) + 1e-300
            final = abs(d_F) <= 1e-15 * scale and abs(d_ad) * (abs(dFA) + abs(dFB)) <= 1e-15 * scale
            if it == 49 and not final:
                break   # 50 Newton steps: the pins as at the last step's start (the C kernel's limit too)
        self.F12 = F12
        self.cap = n * (abs(rho1) * c1 + abs(rho2) * c2)
        return ac, ad, -s * self.cap

    def _planet_interval(self, i: int, Fs: float, ac: float) -> tuple[float, float]:
        """F_12 interval in which planet i holds stuck: |r_bi (F_12 - F*)| <= M_i,max(F_12).

        Closed form. Both ends solve ``r_b (F - F*) -+ (c |P(F)| + M_0) = 0``, with the pin force
        ``P(F) = a + F u + |F| q`` (``a`` from the sun mesh force, :class:`spurdiff.gears.layout.PinLayout`):
        for F of one sign, ``P = a + F v`` with ``v = u + q`` (F >= 0) or ``u - q`` (F < 0), ``|v| = 1``.
        Each left side increases strictly in F (slope >= r_b - c > 0), so each end is the one root;
        the sign of the left side at F = 0 tells which side of 0 it lies on, and there, squared,
        ``(r_b F - k)^2 = c^2 |a + F v|^2`` (``k = r_b F* +- M_0``) is a quadratic whose larger root
        is the upper end (``r_b F - k = +c |P|``) and whose smaller root is the lower end."""
        pf = self.pf
        if not self._planar[i]:
            return self._planet_interval_3d(i, Fs, ac)
        if i == 0:
            rb, J, M0 = pf.rb[1], self.J_1, pf.M0[0]
            tx, ty, rx, ry, _, _, _, _, _, _, _, _, Px, Py, Nx, Ny = self._pin1
        else:
            rb, J, M0 = pf.rb[3], self.J_2, pf.M0[1]
            tx, ty, rx, ry, _, _, _, _, _, _, _, _, Px, Py, Nx, Ny = self._pin2
        c = pf.c
        Fstar = Fs - J * ac / rb
        cap0 = self._capacity(i, Fs, Fstar)
        if cap0 <= 0.0:
            return Fstar, Fstar
        aS = abs(Fs)
        gx, gy = self._g[2 * i], self._g[2 * i + 1]
        hx, hy = self._gt[2 * i], self._gt[2 * i + 1]
        ax, ay = Fs * tx + aS * rx + gx + hx, Fs * ty + aS * ry + gy + hy   # P(0), with the inertial forces
        c_a0 = c * math.sqrt(ax * ax + ay * ay)             # c |P(0)|
        ends = []
        for sign in (1.0, -1.0):                            # upper end, lower end
            k = rb * Fstar + sign * M0
            if c == 0.0:
                ends.append(k / rb)
                continue
            # which side of F = 0: the left side at 0 is -k -+ c |P(0)|
            vx, vy = (Px, Py) if -rb * Fstar - sign * (c_a0 + M0) <= 0.0 else (Nx, Ny)
            # (rb^2 - c^2 |v|^2) F^2 - 2 beta F + (k^2 - c^2 |a|^2) = 0, discriminant written
            # without cancellation: beta^2 - alpha gamma = c^2 (|rb a + k v|^2 - c^2 (a x v)^2)
            vv = vx * vx + vy * vy
            alpha = rb * rb - c * c * vv
            beta = rb * k + c * c * (ax * vx + ay * vy)
            gamma = k * k - c * c * (ax * ax + ay * ay)
            wx, wy = rb * ax + k * vx, rb * ay + k * vy
            cross = ax * vy - ay * vx
            disc = c * c * (wx * wx + wy * wy - c * c * cross * cross)
            root = math.sqrt(disc) if disc > 0.0 else 0.0
            q = beta + math.copysign(root, beta)
            if q == 0.0:
                ends.append(0.0)
                continue
            r1, r2 = q / alpha, gamma / q                   # the two roots, stably
            ends.append(max(r1, r2) if sign > 0.0 else min(r1, r2))
        return ends[1], ends[0]

    def _planet_interval_3d(self, i: int, Fs: float, ac: float) -> tuple[float, float]:
        """:meth:`_planet_interval` for a planet whose pin carries a couple (its loads in two planes):
        each end solves ``h(F) = r_b (F - F*) -+ (c P(F) + M_0) = 0`` with ``P = |R_0| + |R_L|``,
        strictly increasing (``|dP/dF| <= 1``: the planet mesh's unit force is shared between the
        ends with weights summing to 1, so the slope is >= r_b - c > 0). The root lies between
        ``F*`` and ``F* +- (c P(F*) + M_0) / (r_b - c)`` (``P(F) <= P(F*) + |F - F*|``); Newton
        inside that bracket, bisection where a Newton step would leave it (the C transcription in
        shaft_kernel.c does the same operations)."""
        pf = self.pf
        rb, J, M0 = (pf.rb[1], self.J_1, pf.M0[0]) if i == 0 else (pf.rb[3], self.J_2, pf.M0[1])
        c = pf.c
        Fstar = Fs - J * ac / rb
        cap0 = c * self._pin_load(i, Fs, Fstar)[0] + M0
        if cap0 <= 0.0:
            return Fstar, Fstar
        width = cap0 / (rb - c)
        ends = []
        for sign in (1.0, -1.0):                            # upper end, lower end
            lo, hi = (Fstar, Fstar + width) if sign > 0.0 else (Fstar - width, Fstar)
            F = Fstar + sign * cap0 / rb                    # first order
            for _ in range(100):
                P, dP = self._pin_load(i, Fs, F)
                h = rb * (F - Fstar) - sign * (c * P + M0)
                if h == 0.0:
                    break
                if h > 0.0:
                    hi = F
                else:
                    lo = F
                step = h / (rb - sign * c * dP)
                Fn = F - step
                if not lo < Fn < hi:
                    Fn = 0.5 * (lo + hi)
                if abs(Fn - F) <= 1e-15 * (abs(F) + abs(Fstar)) + 1e-300:
                    F = Fn
                    break
                F = Fn
            ends.append(F)
        return ends[1], ends[0]

    def _stuck_exact(self, ac: float) -> bool:
        """Can both planets hold (a_d = 0)? Sets F12 and cap to the reported stuck values."""
        pf = self.pf
        rb1, rb2 = pf.rb[1], pf.rb[3]
        FA, FB = self._sun_forces(ac, 0.0)
        lo1, hi1 = self._planet_interval(0, FA, ac)
        lo2, hi2 = self._planet_interval(1, FB, ac)
        lo, hi = max(lo1, lo2), min(hi1, hi2)
        tol = 1e-10 * (abs(FA) + abs(FB) + abs(hi) + abs(lo)) + 1e-300
        if lo > hi + tol:
            return False
        # the frictionless compromise (least squares of the two friction moments), clipped to the overlap
        F1s, F2s = FA - self.J_1 * ac / rb1, FB - self.J_2 * ac / rb2
        F12 = (rb1 * rb1 * F1s + rb2 * rb2 * F2s) / (rb1 * rb1 + rb2 * rb2)
        F12 = min(max(F12, lo), hi) if lo <= hi else 0.5 * (lo + hi)
        self.F12 = F12
        self.cap = pf.n * (abs(self.rho1) * self._capacity(0, FA, F12) + abs(self.rho2) * self._capacity(1, FB, F12))
        return True

    def _accelerations_exact(self, ac_given: float | None) -> tuple[float, float, float, float]:
        """As :meth:`_accelerations`, with the pin-load law."""
        if self.wd != 0.0:
            s = math.copysign(1.0, self.wd)
            key = (s, ac_given, self.tau_c, self.tau_L, self.tau_R, self._g_wc, self._g_ac)
            if key == self._slip_key:          # same mode and inputs: same accelerations
                ac, ad, Qf, s, self.F12, self.cap = self._slip_val
                return ac, ad, Qf, s
            ac, ad, Qf = self._slip_exact(ac_given, s)
            self._ad_guess = ad
            self._slip_key, self._slip_val = key, (ac, ad, Qf, s, self.F12, self.cap)
            return ac, ad, Qf, s
        Fd = self.tau_L + self.lam * self.tau_R
        ac = ac_given if ac_given is not None else (self.tau_c + self.tau_L + self.tau_R) / self.Mcc
        Q_req = self.Mcd * ac - Fd
        F12_prev = self.F12
        if self._stuck_exact(ac):
            return ac, 0.0, Q_req, 0.0
        s = -math.copysign(1.0, Q_req)
        self._ad_guess = 0.0
        # breaking away: the sliding lever, or with c_break the static one (the shafted model's
        # break-away sub-step, rigid.py's docstring); not cached (the next solve slides)
        ac_s, ad_s, Qf = self._slip_exact(ac_given, s, self.c_break)
        if ad_s * s > 0.0:
            self._ad_guess = ad_s
            return ac_s, ad_s, Qf, s
        # no consistent break-away: stay stuck at capacity (as the paper law does)
        self.F12 = F12_prev if F12_prev == F12_prev else self.F12
        return ac, 0.0, math.copysign(self.cap, Q_req), 0.0
