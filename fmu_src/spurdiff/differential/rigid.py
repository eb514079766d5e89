"""Rigid (kinematic) dynamic model of the differential with pin-bushing friction locking.

Degrees of freedom: the carrier speed ``w_c`` and the differential speed ``w_d = w_A - w_c``
(sun A = left flange). The kinematics of :mod:`spurdiff.differential.statics` give ``w_B = w_c + lam w_d``
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

Pin-bushing friction (the locking), two laws (:mod:`spurdiff.differential.locking`):

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

Static and dynamic coefficients: the capacities of the stuck mode and the break-away use the
static lever ``pf.c`` (``mu_pin``); the slipping mode uses the sliding lever ``c_slide``
(``mu_pinDynamic``; the paper law: ``K_slide``). A slip that stops re-sticks with the static one;
since ``c_slide <= pf.c`` a re-stuck differential holds the loads it stopped under (no chattering).

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
from dataclasses import replace

from spurdiff.differential import rigid_kernel
from spurdiff.errors import StepError, require_finite, require_positive
from spurdiff.gears.geometry import DifferentialGeometry
from spurdiff.differential.inertia import MassProperties, mass_properties
from spurdiff.differential.params import DifferentialParams
from spurdiff.differential.locking import (dynamic_pin_model, locking_coefficients, paper_locking_coefficient,
                                           pin_friction)
from spurdiff.differential.model_base import DifferentialModel
from spurdiff.differential.rigid_pinload import PinLoadLaw
from spurdiff.differential.statics import MeshForces, mesh_forces_for
from spurdiff.gears.layout import kinematics
from spurdiff.numerics import solve_2x2

_STATE_KEYS = (
    "t", "wc", "wd", "phic", "phid", "ac", "ad", "Qf", "slip_dir", "F12", "cap", "_ad_guess", "_slip_key", "_slip_val",
    "work_in", "energy_loss", "loss_last_step", "n_mode_switches", "n_steps", "_g", "_g_wc", "_gt", "_g_ac",
)
_get_state_values = operator.itemgetter(*_STATE_KEYS)
_TUPLE_KEYS = ("_slip_key", "_slip_val", "_g", "_gt")   # the only state entries that are not numbers or None


class RigidDifferential(PinLoadLaw, DifferentialModel):
    """Rigid differential; see the module docstring for the equations.

    Inputs (attributes, SI): ``w_ref`` carrier speed target (speed drive), ``tau_c`` carrier torque
    (torque drive), ``tau_L``, ``tau_R`` external torques on the left (sun A) and right (sun B)
    flanges. Call :meth:`initialize`, then :meth:`do_step` per communication step; read the
    outputs from the properties.
    """

    mesh_model = "rigid"

    def __init__(self, params: DifferentialParams | None = None):
        super().__init__(params or DifferentialParams())    # the inputs and start values
        # implementation of the pin-load solve (``solver.kernel``): auto (the compiled kernel,
        # spurdiff.differential.rigid_kernel, if it loads, else the Python reference) | compiled | python
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
        self.pf = pin_friction(geo, p.mu_pin, p.r_collar, self.preload, self.law, *dynamic_pin_model(p))
        self.K_paper = paper_locking_coefficient(p.mu_pin, p.r_collar, n, geo.r_a, geo.r_1, geo.r_b, geo.r_2)
        # the static / dynamic split: pf.c (mu_pin) holds while stuck and decides the break-away;
        # c_slide (mu_pinDynamic, equal to mu_pin where that is 0) acts while slipping
        mu_d = p.mu_sliding
        self.c_slide = pf_d_c = pin_friction(geo, mu_d, p.r_collar, self.preload, self.law, *dynamic_pin_model(p)).c
        # the lever (paper law: coefficient) of the slip solve at a break-away from stuck: the sliding
        # one; a shafted model (spurdiff.differential.shafts) sets the static ones after initialize
        self.c_break = pf_d_c
        if self.law == "paper":
            self.K = self.K_coast = self.K_paper
            self.K_slide = self.K_slide_coast = paper_locking_coefficient(mu_d, p.r_collar, n, geo.r_a, geo.r_1,
                                                                          geo.r_b, geo.r_2)
        else:
            self.K, self.K_coast = locking_coefficients(self.pf, p.leadingSun)
            self.K_slide, self.K_slide_coast = (
                (self.K, self.K_coast) if pf_d_c == self.pf.c
                else locking_coefficients(replace(self.pf, c=pf_d_c), p.leadingSun))
        self.K_break = self.K_slide
        # the exact pin law (pinFriction with friction or preload), else the paper's linear capacity
        self._exact = self.law == "pinFriction" and (self.pf.c > 0.0 or self.preload > 0.0)
        self._pin_constants()
        # the planets' centrifugal pin loads per unit w_c^2 (pinSpeedLoads; spurdiff.differential.speed_law)
        th = self.pf.layout.theta
        speed = bool(p.pinSpeedLoads) and self._exact
        self._cf = ((mp.m_planet1 * geo.meshA1.a, 0.0),
                    (mp.m_planet2 * geo.meshB2.a * math.cos(th), mp.m_planet2 * geo.meshB2.a * math.sin(th))) \
            if speed else ((0.0, 0.0), (0.0, 0.0))
        # and their tangential (carrier-acceleration) pin loads -m_i a_i alpha_c e_t,i per unit alpha_c
        self._ct = ((0.0, -mp.m_planet1 * geo.meshA1.a),
                    (mp.m_planet2 * geo.meshB2.a * math.sin(th), -mp.m_planet2 * geo.meshB2.a * math.cos(th))) \
            if speed else ((0.0, 0.0), (0.0, 0.0))
        self._g, self._g_wc = (0.0, 0.0, 0.0, 0.0), 0.0
        self._gt, self._g_ac = (0.0, 0.0, 0.0, 0.0), 0.0
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
        self._set_speed_loads(self.wc, 0.0)
        ac = 0.0 if self.speed_drive else None
        self.ac, self.ad, self.Qf, self.slip_dir = self._accelerations(ac)
        self._ready = True

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

    def _solve_slip(self, ac_given: float | None, s: float, sigma: float, K: float) -> tuple[float, float]:
        """Accelerations with Q_f = -s K sigma T0(ac, ad) (sigma = assumed sign of T0; K the sliding
        coefficient K_slide, mu_pinDynamic, or at a break-away K_break)."""
        kf = s * K * sigma
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
        return solve_2x2(a11, a12, a21, a22, b1, b2)

    def _slip_accelerations(self, ac_given: float | None, s: float,
                            K: float | None = None) -> tuple[float, float, float]:
        """Accelerations and Q_f while slipping in direction s, with a consistent sign of T0 (the
        coefficient K_slide, or K given: at a break-away, K_break)."""
        if K is None:
            K = self.K_slide
        for sigma in (1.0, -1.0):
            ac, ad = self._solve_slip(ac_given, s, sigma, K)
            T0 = self._T0(ac, ad)
            if T0 * sigma >= 0.0:
                return ac, ad, -s * (K * abs(T0) + self.preload)
        ac, ad = self._solve_slip(ac_given, s, 0.0, K)  # T0 changes sign with the friction: preload only
        return ac, ad, -s * self.preload

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
        ac_s, ad_s, Qf = self._slip_accelerations(ac_given, s, self.K_break)
        if ad_s * s > 0.0:
            return ac_s, ad_s, Qf, s
        # no consistent break-away (capacity grows with the motion it would cause): stay stuck at capacity
        return ac, 0.0, math.copysign(cap, Q_req), 0.0

    # ------------------------------------------------------------------ stepping
    def do_step(self, t: float, h: float) -> None:
        """Advance from t to t + h with the inputs held; raises ParameterError / StepError."""
        if not self._ready:
            raise StepError("do_step called before initialize")
        if not (h.__class__ is float and 0.0 < h < math.inf):
            h = require_positive("communicationStepSize", h)
        self._check_inputs()
        if self._exact:
            # the carrier speed at the step's start and its acceleration (speed drive: the ramp of this
            # step; torque drive: the acceleration at the end of the last step), held over the step
            self._set_speed_loads(self.wc, (self.w_ref - self.wc) / h if self.speed_drive else self.ac)
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
        """The step in C (:mod:`spurdiff.differential.rigid_kernel`) when it is the usual one of a carrier
        torque-driven model slipping throughout: a new solve (inputs other than the cached ones),
        no mode switch. The same operations as :meth:`do_step`'s loop, one pass, and its
        end-of-step accelerations (those of the solve: the same key). False: not that kind of
        step, nothing changed (the Python path runs it)."""
        s = math.copysign(1.0, self.wd)
        tau_c, tau_L, tau_R = self.tau_c, self.tau_L, self.tau_R
        key = (s, None, tau_c, tau_L, tau_R, self._g_wc, self._g_ac)
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
        K = self.K_slide if self.slip_dir != 0.0 else self.K
        return K * abs(self.tau_mesh_L + self.tau_mesh_R) + self.preload

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

    def native_step(self):
        """The whole step in C for a host that steps without Python (:mod:`spurdiff.native_step`,
        :mod:`spurdiff.differential.rigid_native`): with the FMU's watches and a compiled step for the
        locking law in use, else None (also with ``native`` false: the FMU's ``solver.nativeStep``); the
        same plan while the compiled solve is the same."""
        d = self.__dict__
        if not (self._ready and d.get("native", True)):
            return None
        plan = d.get("_native")
        if plan is None or plan.rk is not d["_rk"]:
            from spurdiff.differential import rigid_native
            plan = d["_native"] = rigid_native.native(self)
        return plan

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
        rk = d.get("_rk")
        if rk is not None:
            rk.set_speed_loads(d["_g"], d["_gt"])

