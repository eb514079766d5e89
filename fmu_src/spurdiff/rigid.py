"""Rigid (kinematic) dynamic model of the differential with pin-bushing friction locking.

Degrees of freedom: the carrier speed ``w_c`` and the differential speed ``w_d = w_A - w_c``
(sun A = left flange). The kinematics of :mod:`spurdiff.statics` give ``w_B = w_c + lam w_d``
(``lam = -1`` for equal suns) and the planet spins relative to the carrier ``w_1 = rho_1 w_d``,
``w_2 = rho_2 w_d``. With ``n`` planet pairs the kinetic energy is ``1/2 q' M q`` with
``q = (w_c, w_d)`` and

    M_cc = J_c + n (m_1 a_A^2 + m_2 a_B^2) + J_A + J_B + n (J_1 + J_2)
    M_cd = J_A + lam J_B + n (J_1 rho_1 + J_2 rho_2)
    M_dd = J_A + lam^2 J_B + n (J_1 rho_1^2 + J_2 rho_2^2)

Equations of motion (``tau_L``, ``tau_R``: external torques on the flanges, Modelica sign; ``tau_c``
on the carrier; ``Q_f``: friction on the relative motion):

    M_cc dw_c + M_cd dw_d = tau_c + tau_L + tau_R
    M_cd dw_c + M_dd dw_d = tau_L + lam tau_R + Q_f

Pin-bushing friction (the locking), two laws (:mod:`spurdiff.locking`):

* ``lockingLaw = "pinFriction"``: each planet's friction moment ``M_i`` has the capacity
  ``mu r_d |F_pin,i| + M_0,i`` from its actual pin load. The mesh forces per pair are
  ``F_A1 = T_A / (n r_bA)``, ``F_B2 = T_B / (n r_bB)`` from the sun torques
  (``T_A = J_A dw_A - tau_L``, each sun on its own, not only their sum) and ``F_12`` from the
  planets' moment balances ``J_i (a_c + rho_i a_d) = r_bi (F_s,i - F_12) + M_i``; the friction on
  the differential coordinate is ``Q_f = n (rho_1 M_1 + rho_2 M_2)``. Slipping:
  ``M_i = -sgn(w_i) M_i,max`` and the two balances are solved for ``a_d`` and ``F_12`` (Newton,
  analytic derivatives; :math:`F_{12}` only decides how the pins are loaded). Stuck (``a_d = 0``):
  each planet holds for ``F_12`` in an interval ``|r_bi (F_12 - F*_i)| <= M_i,max(F_12)``; the
  differential stays stuck while the two intervals overlap (``F_12`` is then statically
  indeterminate: the point of the overlap nearest the frictionless compromise is reported).
* ``lockingLaw = "paper"``: Coulomb friction on the relative motion with the capacity
  ``|Q_f| <= K |T_0| + T_pre``, ``K`` the paper's locking coefficient and ``T_0 = T_A + T_B``.
  ``T_0`` depends on the accelerations, so each mode is solved as a small linear system with
  the sign of ``T_0`` checked afterwards (after Pelchen, Schweiger and Otter 2002, as in
  Modelica's LossyGear).

Stick-slip is exact, with no regularisation: in the stuck mode ``w_d`` is exactly 0 and the
friction is whatever holds it (``dw_d = 0``) as long as that stays within the capacity; above it
the differential breaks away in the direction the excess pushes. While slipping, ``Q_f = -s C``
with ``s`` the sign of ``w_d``. Inputs are held constant over a step (the carrier speed target is
reached linearly over the step), so within a mode every acceleration is constant: the model is
integrated exactly, mode switches (``w_d`` reaching 0) are located exactly, and work, kinetic
energy and friction loss balance to rounding error.
"""
from __future__ import annotations

import math
import operator

from . import rigid_kernel
from .errors import StepError, require_finite, require_positive
from .geometry import DifferentialGeometry
from .inertia import MassProperties, mass_properties
from .params import DifferentialParams
from .locking import locking_coefficients, paper_locking_coefficient, pin_friction
from .model_base import DifferentialModel
from .statics import MeshForces, kinematics, mesh_forces_for

_STATE_KEYS = (
    "t", "wc", "wd", "phic", "phid", "ac", "ad", "Qf", "slip_dir", "F12", "cap", "_ad_guess", "_slip_key", "_slip_val",
    "work_in", "energy_loss", "loss_last_step", "n_mode_switches", "n_steps",
)
_get_state_values = operator.itemgetter(*_STATE_KEYS)
_TUPLE_KEYS = ("_slip_key", "_slip_val")   # the only state entries that are not numbers or None


class RigidDifferential(DifferentialModel):
    """Rigid differential; see the module docstring for the equations.

    Inputs (attributes, SI): ``w_ref`` carrier speed target (speed drive), ``tau_c`` carrier torque
    (torque drive), ``tau_L``, ``tau_R`` external torques on the left (sun A) and right (sun B)
    flanges. Call :meth:`initialize`, then :meth:`do_step` per communication step; read the
    outputs from the properties.
    """

    mesh_model = "rigid"

    def __init__(self, params: DifferentialParams | None = None):
        self.params = params or DifferentialParams()
        # inputs
        self.w_ref = 0.0
        self.tau_c = 0.0
        self.tau_L = 0.0
        self.tau_R = 0.0
        # start values
        self.w_start_carrier = 0.0
        self.w_start_left = float("nan")  # nan: same as the carrier
        # implementation of the pin-load solve (``solver.kernel``): auto (the compiled kernel,
        # spurdiff.rigid_kernel, if it loads, else the Python reference) | compiled | python
        self.kernel = "auto"
        self._ready = False

    # ------------------------------------------------------------------ setup
    def initialize(self, t0: float = 0.0) -> None:
        """Validate parameters and start values, set the initial state, compute outputs at t0."""
        p = self.params
        geo: DifferentialGeometry = p.validate()
        self.geometry = geo
        self.mass: MassProperties = mass_properties(p, geo)
        kin = kinematics(geo)
        self.lam = kin.sunB_per_sunA
        self.rho1 = kin.planet1_per_sunA
        self.rho2 = kin.planet2_per_sunA
        mp = self.mass
        n = mp.n_pairs
        self.J_A, self.J_B = mp.J_sunA, mp.J_sunB
        self.J_1, self.J_2 = mp.J_planet1, mp.J_planet2
        self._ad_guess = None
        self._slip_key = self._slip_val = None
        self.Mcc = mp.J_carrier_total + mp.J_sunA + mp.J_sunB + n * (mp.J_planet1 + mp.J_planet2)
        self.Mcd = mp.J_sunA + self.lam * mp.J_sunB + n * (mp.J_planet1 * self.rho1 + mp.J_planet2 * self.rho2)
        self.Mdd = (mp.J_sunA + self.lam ** 2 * mp.J_sunB
                    + n * (mp.J_planet1 * self.rho1 ** 2 + mp.J_planet2 * self.rho2 ** 2))
        self.law = p.lockingLaw
        self.preload = float(p.lockingPreload)
        self.pf = pin_friction(geo, p.mu_pin, p.r_collar, self.preload, self.law)
        self.K_paper = paper_locking_coefficient(p.mu_pin, p.r_collar, n, geo.r_a, geo.r_1, geo.r_b, geo.r_2)
        if self.law == "paper":
            self.K = self.K_coast = self.K_paper
        else:
            self.K, self.K_coast = locking_coefficients(self.pf)
        # the exact pin law (pinFriction with friction or preload), else the paper's linear capacity
        self._exact = self.law == "pinFriction" and (self.pf.c > 0.0 or self.preload > 0.0)
        self._pin_constants()
        self._rk, self.kernel_note = (rigid_kernel.choose(self) if self._exact
                                      else (None, "none (no pin-load solve)"))
        self.F12 = float("nan")
        self.cap = 0.0
        self.speed_drive = p.carrierDrive == "speed"
        self._check_inputs()
        wc0 = self.w_ref if self.speed_drive else require_finite("carrier.w_start", self.w_start_carrier)
        wl0 = self.w_start_left
        wd0 = 0.0 if wl0 != wl0 else require_finite("left.w_start", wl0) - wc0
        self.t = float(t0)
        self.wc, self.wd = float(wc0), float(wd0)
        self.phic = self.phid = 0.0
        self.work_in = self.energy_loss = self.loss_last_step = 0.0
        self.n_mode_switches = 0
        self.n_steps = 0
        self.slip_dir = 0.0 if wd0 == 0.0 else math.copysign(1.0, wd0)
        ac = 0.0 if self.speed_drive else None
        self.ac, self.ad, self.Qf, self.slip_dir = self._accelerations(ac)
        self._ready = True

    def _pin_constants(self) -> None:
        """What the pin-load Newton needs that depends on the parameters only (set once, in
        :meth:`initialize`): the pins' unit force parts (:class:`spurdiff.locking.PinLayout`) with
        their sums and differences (the derivative of ``|F_pin|`` for either sign of a mesh force),
        the lever, the preloads and the mesh-force divisors ``n r_b``."""
        pf = self.pf
        rbA, rb1, rbB, rb2 = pf.rb
        planets = []
        for i in (0, 1):
            tx, ty, rx, ry, ux, uy, qx, qy = pf.layout._flat[i]
            planets.append((tx, ty, rx, ry, ux, uy, qx, qy,
                            tx + rx, ty + ry, tx - rx, ty - ry,      # d|F_pin|/dFs for Fs >= 0, < 0
                            ux + qx, uy + qy, ux - qx, uy - qy))     # d|F_pin|/dF12 for F12 >= 0, < 0
        self._pin1, self._pin2 = planets
        self._nrbA, self._nrbB = pf.n * rbA, pf.n * rbB

    def _check_inputs(self) -> None:
        isfinite = math.isfinite
        if isfinite(self.w_ref) and isfinite(self.tau_c) and isfinite(self.tau_L) and isfinite(self.tau_R):
            return
        require_finite("carrier.w_ref", self.w_ref)
        require_finite("carrier.tau", self.tau_c)
        require_finite("left.tau", self.tau_L)
        require_finite("right.tau", self.tau_R)

    # ------------------------------------------------------------------ mode solution
    def _T0(self, ac: float, ad: float) -> float:
        return (self.J_A * (ac + ad) - self.tau_L) + (self.J_B * (ac + self.lam * ad) - self.tau_R)

    def _solve_slip(self, ac_given: float | None, s: float, sigma: float) -> tuple[float, float]:
        """Accelerations with Q_f = -s K sigma T0(ac, ad) (sigma = assumed sign of T0)."""
        kf = s * self.K * sigma
        Fd = self.tau_L + self.lam * self.tau_R - s * self.preload
        alpha0 = -self.tau_L - self.tau_R
        alpha_c = self.J_A + self.J_B
        beta = self.J_A + self.lam * self.J_B
        if ac_given is not None:
            ac = ac_given
            ad = (Fd - self.Mcd * ac - kf * (alpha0 + alpha_c * ac)) / (self.Mdd + kf * beta)
            return ac, ad
        Qc = self.tau_c + self.tau_L + self.tau_R
        a11, a12, b1 = self.Mcc, self.Mcd, Qc
        a21, a22, b2 = self.Mcd + kf * alpha_c, self.Mdd + kf * beta, Fd - kf * alpha0
        det = a11 * a22 - a12 * a21
        return (b1 * a22 - a12 * b2) / det, (a11 * b2 - a21 * b1) / det

    def _slip_accelerations(self, ac_given: float | None, s: float) -> tuple[float, float, float]:
        """Accelerations and Q_f while slipping in direction s, with a consistent sign of T0."""
        for sigma in (1.0, -1.0):
            ac, ad = self._solve_slip(ac_given, s, sigma)
            T0 = self._T0(ac, ad)
            if T0 * sigma >= 0.0:
                return ac, ad, -s * (self.K * abs(T0) + self.preload)
        ac, ad = self._solve_slip(ac_given, s, 0.0)  # T0 changes sign with the friction: preload only
        return ac, ad, -s * self.preload

    # ------------------------------------------------------------------ the pin-load law
    def _sun_forces(self, ac: float, ad: float) -> tuple[float, float]:
        """Normal mesh forces per pair of the sun meshes from the sun torques."""
        n = self.pf.n
        rbA, _, rbB, _ = self.pf.rb
        return ((self.J_A * (ac + ad) - self.tau_L) / (n * rbA),
                (self.J_B * (ac + self.lam * ad) - self.tau_R) / (n * rbB))

    def _slip_exact(self, ac_given: float | None, s: float) -> tuple[float, float, float]:
        """Slipping in direction s with the pin-load law: solve the planets' moment balances
        for (a_d, F_12) by Newton; returns (ac, ad, Q_f) and leaves F12, cap set.

        The hot path of the rigid level (one solve per inner step): the sun forces
        (:meth:`_sun_forces`) and the pin capacities (:meth:`spurdiff.locking.PinFriction.capacity`)
        are written out here with the constants of :meth:`_pin_constants`, the same arithmetic in
        the same order, so the result is bit for bit that of the two calls. With the compiled
        kernel (:mod:`spurdiff.rigid_kernel`) the same solve runs in C, bit for bit."""
        rk = self._rk
        if rk is not None:
            io = rk.io
            ad0 = self._ad_guess
            if ac_given is None:
                io[0:8] = (s, 0.0, 0.0, self.tau_c, self.tau_L, self.tau_R, 0.0 if ad0 is None else ad0, self.F12)
            else:
                io[0:8] = (s, 1.0, ac_given, self.tau_c, self.tau_L, self.tau_R, 0.0 if ad0 is None else ad0,
                           self.F12)
            rk.fn(rk.const, io)
            ac, ad, self.F12, cap = io[8:12]
            self.cap = cap
            return ac, ad, -s * cap
        pf = self.pf
        n = pf.n
        _, rb1, _, rb2 = pf.rb
        nrbA, nrbB = self._nrbA, self._nrbB
        cpin = pf.c
        M01, M02 = pf.M0
        (t1x, t1y, r1x, r1y, u1x, u1y, q1x, q1y, p1x, p1y, m1x, m1y, P1x, P1y, N1x, N1y) = self._pin1
        (t2x, t2y, r2x, r2y, u2x, u2y, q2x, q2y, p2x, p2y, m2x, m2y, P2x, P2y, N2x, N2y) = self._pin2
        J_A, J_B, lam = self.J_A, self.J_B, self.lam
        J1, J2 = self.J_1, self.J_2
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
        for _ in range(50):
            ac = ac_given if given else (Qc - Mcd * ad) / Mcc
            FA = (J_A * (ac + ad) - tau_L) / nrbA
            FB = (J_B * (ac + lam * ad) - tau_R) / nrbB
            aA, aB, a12 = abs(FA), abs(FB), abs(F12)
            # pin force of planet 1 (sun A mesh FA, planet mesh F12) and of planet 2 (FB, F12)
            f1x = FA * t1x + aA * r1x + F12 * u1x + a12 * q1x
            f1y = FA * t1y + aA * r1y + F12 * u1y + a12 * q1y
            f2x = FB * t2x + aB * r2x + F12 * u2x + a12 * q2x
            f2y = FB * t2y + aB * r2y + F12 * u2y + a12 * q2y
            mag1 = sqrt(f1x * f1x + f1y * f1y)
            mag2 = sqrt(f2x * f2x + f2y * f2y)
            c1 = cpin * mag1 + M01
            c2 = cpin * mag2 + M02
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
            a11 = (rb1 - sg1 * c1S) * dFA - a11_0
            a12_ = -rb1 - sg1 * c112
            a21 = (rb2 - sg2 * c2S) * dFB - a21_0
            a22 = -rb2 - sg2 * c212
            det = a11 * a22 - a12_ * a21
            d_ad = (r1 * a22 - a12_ * r2) / det
            d_F = (a11 * r2 - a21 * r1) / det
            ad -= d_ad
            F12 -= d_F
            scale = aA + aB + abs(F12) + 1e-300
            if abs(d_F) <= 1e-15 * scale and abs(d_ad) * (abs(dFA) + abs(dFB)) <= 1e-15 * scale:
                ac = ac_given if given else (Qc - Mcd * ad) / Mcc
                FA = (J_A * (ac + ad) - tau_L) / nrbA
                FB = (J_B * (ac + lam * ad) - tau_R) / nrbB
                aA, aB, a12 = abs(FA), abs(FB), abs(F12)
                f1x = FA * t1x + aA * r1x + F12 * u1x + a12 * q1x
                f1y = FA * t1y + aA * r1y + F12 * u1y + a12 * q1y
                f2x = FB * t2x + aB * r2x + F12 * u2x + a12 * q2x
                f2y = FB * t2y + aB * r2y + F12 * u2y + a12 * q2y
                c1 = cpin * sqrt(f1x * f1x + f1y * f1y) + M01
                c2 = cpin * sqrt(f2x * f2x + f2y * f2y) + M02
                break
        self.F12 = F12
        self.cap = n * (abs(rho1) * c1 + abs(rho2) * c2)
        return ac, ad, -s * self.cap

    def _planet_interval(self, i: int, Fs: float, ac: float) -> tuple[float, float]:
        """F_12 interval in which planet i holds stuck: |r_bi (F_12 - F*)| <= M_i,max(F_12).

        Closed form. Both ends solve ``r_b (F - F*) -+ (c |P(F)| + M_0) = 0``, with the pin force
        ``P(F) = a + F u + |F| q`` (``a`` from the sun mesh force, :class:`spurdiff.locking.PinLayout`):
        for F of one sign, ``P = a + F v`` with ``v = u + q`` (F >= 0) or ``u - q`` (F < 0), ``|v| = 1``.
        Each left side increases strictly in F (slope >= r_b - c > 0), so each end is the one root;
        the sign of the left side at F = 0 tells which side of 0 it lies on, and there, squared,
        ``(r_b F - k)^2 = c^2 |a + F v|^2`` (``k = r_b F* +- M_0``) is a quadratic whose larger root
        is the upper end (``r_b F - k = +c |P|``) and whose smaller root is the lower end."""
        pf = self.pf
        if i == 0:
            rb, J, M0 = pf.rb[1], self.J_1, pf.M0[0]
            tx, ty, rx, ry, _, _, _, _, _, _, _, _, Px, Py, Nx, Ny = self._pin1
        else:
            rb, J, M0 = pf.rb[3], self.J_2, pf.M0[1]
            tx, ty, rx, ry, _, _, _, _, _, _, _, _, Px, Py, Nx, Ny = self._pin2
        c = pf.c
        Fstar = Fs - J * ac / rb
        cap0 = pf.capacity(i, Fs, Fstar)[0]
        if cap0 <= 0.0:
            return Fstar, Fstar
        aS = abs(Fs)
        ax, ay = Fs * tx + aS * rx, Fs * ty + aS * ry      # P(0)
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
        self.cap = pf.n * (abs(self.rho1) * pf.capacity(0, FA, F12)[0]
                           + abs(self.rho2) * pf.capacity(1, FB, F12)[0])
        return True

    def _accelerations(self, ac_given: float | None) -> tuple[float, float, float, float]:
        """(ac, ad, Q_f, slip direction) in the current state (direction 0: stuck)."""
        if self._exact:
            return self._accelerations_exact(ac_given)
        if self.wd != 0.0:
            s = math.copysign(1.0, self.wd)
            ac, ad, Qf = self._slip_accelerations(ac_given, s)
            return ac, ad, Qf, s
        # stuck: dw_d = 0
        Fd = self.tau_L + self.lam * self.tau_R
        ac = ac_given if ac_given is not None else (self.tau_c + self.tau_L + self.tau_R) / self.Mcc
        Q_req = self.Mcd * ac - Fd
        cap = self.K * abs(self._T0(ac, 0.0)) + self.preload
        if abs(Q_req) <= cap * (1.0 + 1e-12):
            return ac, 0.0, Q_req, 0.0
        s = -math.copysign(1.0, Q_req)
        ac_s, ad_s, Qf = self._slip_accelerations(ac_given, s)
        if ad_s * s > 0.0:
            return ac_s, ad_s, Qf, s
        # no consistent break-away (capacity grows with the motion it would cause): stay stuck at capacity
        return ac, 0.0, math.copysign(cap, Q_req), 0.0

    def _accelerations_exact(self, ac_given: float | None) -> tuple[float, float, float, float]:
        """As :meth:`_accelerations`, with the pin-load law."""
        if self.wd != 0.0:
            s = math.copysign(1.0, self.wd)
            key = (s, ac_given, self.tau_c, self.tau_L, self.tau_R)
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
        ac_s, ad_s, Qf = self._slip_exact(ac_given, s)
        if ad_s * s > 0.0:
            self._ad_guess = ad_s
            return ac_s, ad_s, Qf, s
        # no consistent break-away: stay stuck at capacity (as the paper law does)
        self.F12 = F12_prev if F12_prev == F12_prev else self.F12
        return ac, 0.0, math.copysign(self.cap, Q_req), 0.0

    # ------------------------------------------------------------------ stepping
    def do_step(self, t: float, h: float) -> None:
        """Advance from t to t + h with the inputs held; raises ParameterError / StepError."""
        if not self._ready:
            raise StepError("do_step called before initialize")
        if not (h.__class__ is float and 0.0 < h < math.inf):
            h = require_positive("communicationStepSize", h)
        self._check_inputs()
        rk = self._rk
        if rk is not None and self.wd != 0.0 and not self.speed_drive and self._step_compiled(rk, t, h):
            return
        ac_given = (self.w_ref - self.wc) / h if self.speed_drive else None
        remaining = h
        loss0 = self.energy_loss
        for _ in range(16):
            ac, ad, Qf, s = self._accelerations(ac_given)
            dt = remaining
            crossing = False
            if self.wd != 0.0 and ad * self.wd < 0.0:
                t_cross = -self.wd / ad
                if t_cross < remaining:
                    dt, crossing = t_cross, True
            self._advance(dt, ac, ad, Qf)
            if crossing:
                self.wd = 0.0
                self.n_mode_switches += 1
            elif s != 0.0 and self.slip_dir == 0.0:
                self.n_mode_switches += 1
            self.slip_dir = s if not crossing else 0.0
            remaining -= dt
            if remaining <= 1e-15 * h:
                break
        else:
            raise StepError(f"more than 16 stick-slip mode switches in one step at t = {t:.6g} s")
        if self.speed_drive:
            self.wc = self.w_ref  # exact target; removes rounding drift of the ramp
        self.t = t + h
        self.loss_last_step = self.energy_loss - loss0
        self.n_steps += 1
        # accelerations at the end of the step, for the outputs
        self.ac, self.ad, self.Qf, self.slip_dir = self._accelerations(0.0 if self.speed_drive else None)
        self._last_h = h

    def _step_compiled(self, rk, t: float, h: float) -> bool:
        """The step in C (:mod:`spurdiff.rigid_kernel`) when it is the usual one of a carrier
        torque-driven model slipping throughout: a new solve (inputs other than the cached ones),
        no mode switch. The same operations as :meth:`do_step`'s loop, one pass, and its
        end-of-step accelerations (those of the solve: the same key). False: not that kind of
        step, nothing changed (the Python path runs it)."""
        s = math.copysign(1.0, self.wd)
        tau_c, tau_L, tau_R = self.tau_c, self.tau_L, self.tau_R
        key = (s, None, tau_c, tau_L, tau_R)
        if key == self._slip_key:
            return False
        io = rk.sio
        ad0 = self._ad_guess
        loss0 = self.energy_loss
        io[0:13] = (s, tau_c, tau_L, tau_R, 0.0 if ad0 is None else ad0, self.F12, self.wc, self.wd, self.phic,
                    self.phid, self.work_in, loss0, h)
        if rk.step(rk.const, io):
            return False
        ac, ad, F12, cap, Qf, self.wc, self.wd, self.phic, self.phid, self.work_in, loss = io[13:24]
        self.energy_loss = loss
        self.F12, self.cap, self._ad_guess = F12, cap, ad
        self._slip_key, self._slip_val = key, (ac, ad, Qf, s, F12, cap)
        if self.slip_dir == 0.0:
            self.n_mode_switches += 1
        self.t = t + h
        self.loss_last_step = loss - loss0
        self.n_steps += 1
        self.ac, self.ad, self.Qf, self.slip_dir = ac, ad, Qf, s
        self._last_h = h
        return True

    def _advance(self, dt: float, ac: float, ad: float, Qf: float) -> None:
        if dt <= 0.0:
            return
        wc0, wd0 = self.wc, self.wd
        wc1, wd1 = wc0 + ac * dt, wd0 + ad * dt
        self.phic += 0.5 * (wc0 + wc1) * dt
        self.phid += 0.5 * (wd0 + wd1) * dt
        # work of the external torques and the drive (forces constant, speeds linear in time)
        tau_drive = self.Mcc * ac + self.Mcd * ad - self.tau_L - self.tau_R if self.speed_drive else self.tau_c
        mean_wc, mean_wd = 0.5 * (wc0 + wc1), 0.5 * (wd0 + wd1)
        self.work_in += dt * (tau_drive * mean_wc + self.tau_L * (mean_wc + mean_wd)
                              + self.tau_R * (mean_wc + self.lam * mean_wd))
        self.energy_loss += dt * abs(Qf * mean_wd)
        self.wc, self.wd = wc1, wd1

    # ------------------------------------------------------------------ outputs
    @property
    def w_L(self) -> float:
        return self.wc + self.wd

    @property
    def w_R(self) -> float:
        return self.wc + self.lam * self.wd

    @property
    def phi_L(self) -> float:
        return self.phic + self.phid

    @property
    def phi_R(self) -> float:
        return self.phic + self.lam * self.phid

    @property
    def tau_drive(self) -> float:
        """Torque the carrier drive delivers (speed drive: what holds the speed)."""
        if self.speed_drive:
            return self.Mcc * self.ac + self.Mcd * self.ad - self.tau_L - self.tau_R
        return self.tau_c

    @property
    def tau_mesh_L(self) -> float:
        """Torque the meshes deliver to sun A (N m)."""
        return self.J_A * (self.ac + self.ad) - self.tau_L

    @property
    def tau_mesh_R(self) -> float:
        return self.J_B * (self.ac + self.lam * self.ad) - self.tau_R

    @property
    def mesh_forces(self):
        if not self._exact:
            return mesh_forces_for(self.geometry, self.tau_mesh_L, self.tau_mesh_R)
        FA, FB = self._sun_forces(self.ac, self.ad)
        return MeshForces(FA, FB, self.F12)

    @property
    def locking_torque(self) -> float:
        """Friction torque on the relative motion (N m), as a sun-torque difference."""
        return self.Qf

    @property
    def locking_capacity(self) -> float:
        """Largest torque difference the friction can hold now (N m): the paper law's
        ``K |T_A + T_B| + T_pre``, or ``n sum_i |rho_i| M_i,max`` from the pin loads."""
        if self._exact:
            return self.cap
        return self.K * abs(self.tau_mesh_L + self.tau_mesh_R) + self.preload

    @property
    def power_loss(self) -> float:
        """Mean friction power over the last step (W), >= 0."""
        h = getattr(self, "_last_h", 0.0)
        return self.loss_last_step / h if h > 0.0 else abs(self.Qf * self.wd)

    @property
    def kinetic_energy(self) -> float:
        return 0.5 * (self.Mcc * self.wc ** 2 + 2.0 * self.Mcd * self.wc * self.wd + self.Mdd * self.wd ** 2)

    @property
    def stuck(self) -> bool:
        return self.wd == 0.0 and self.ad == 0.0

    @property
    def n_internal_steps(self) -> int:
        """Internal steps: one per communication step (the rigid level integrates exactly)."""
        return self.n_steps

    # ------------------------------------------------------------------ state
    # the state is plain attributes (no properties among them): read and written through the
    # instance dictionary in one C-level call each (the shafted differential copies it per inner step)
    def get_state(self) -> dict:
        d = self.__dict__
        s = dict(zip(_STATE_KEYS, _get_state_values(d)))
        s["w_ref"], s["tau_c"], s["tau_L"], s["tau_R"] = d["w_ref"], d["tau_c"], d["tau_L"], d["tau_R"]
        s["last_h"] = d.get("_last_h", 0.0)
        return s

    def set_state(self, state: dict) -> None:
        d = self.__dict__
        d.update(zip(_STATE_KEYS, _get_state_values(state)))
        for k in _TUPLE_KEYS:      # a deserialized (JSON) state holds lists
            v = d[k]
            if v.__class__ is list:
                d[k] = tuple(v)
        d["w_ref"], d["tau_c"], d["tau_L"], d["tau_R"] = state["w_ref"], state["tau_c"], state["tau_L"], state["tau_R"]
        d["_last_h"] = state["last_h"]

