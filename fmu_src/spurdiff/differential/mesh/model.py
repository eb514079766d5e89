"""Gear-mesh dynamics of the differential at multibody fidelity, with switchable effects: the model
(set-up, initial state, outputs, state), on :class:`spurdiff.differential.model_base.DifferentialModel`.

Degrees of freedom (one representative planet pair: the n pairs are identical and share the load
equally; its mesh forces act n times on the suns, its inertias n times on the carrier), all angles
of the suns and planets relative to the carrier: carrier angle ``phi_c`` and speed ``w_c`` (states
only with ``carrierDrive = "torque"``; with the speed drive the carrier follows the target linearly
over each communication step, as in :mod:`spurdiff.differential.rigid`), sun A angle ``psi_A`` and speed
``v_A``, sun B speed ``v_B``, planet spins ``w_1``, ``w_2``, and the three mesh deflections along
the lines of action ``d_A1``, ``d_B2``, ``d_12`` (m):
``y = (psi_A, d_A1, d_B2, d_12, v_A, v_B, w_1, w_2[, w_c, phi_c])``. The deflections are states
(not the absolute angles, which grow without bound), as MSL's ElastoBacklash recommends::

    d_A1' = -(rb_A v_A + rb_1 w_1)      d_B2' = -(rb_B v_B + rb_2 w_2)      d_12' = rb_1 w_1 + rb_2 w_2

Lagrange's equations with
``T = 1/2 [J_c w_c^2 + J_A (w_c + v_A)^2 + J_B (w_c + v_B)^2 + n J_1 (w_c + w_1)^2 + n J_2 (w_c + w_2)^2]``::

    Q_A = n (rb_A F_A1 + Mf_A)                Q_B = n (rb_B F_B2 + Mf_B)
    Q_1 = rb_1 (F_A1 - F_12) + Mf_1 + M_1     Q_2 = rb_2 (F_B2 - F_12) + Mf_2 + M_2
    J_A (a_c + v_A') = tau_L + Q_A            J_B (a_c + v_B') = tau_R + Q_B
    J_1 (a_c + w_1') = Q_1                    J_2 (a_c + w_2') = Q_2
    J_c a_c = tau_c - (Q_A + Q_B + n Q_1 + n Q_2)        (torque drive)
    tau_drive = J_c a_c + Q_A + Q_B + n Q_1 + n Q_2     (speed drive: what holds the carrier)

``Mf``: flank-friction moments, ``M_i``: pin friction of planet i (exact stick: a stuck planet has
``w_i = w_i' = 0`` and the friction that holds it while ``|M_i| <= c_pin |F_pin,i| + M_0,i``).
The mesh laws and effects: :mod:`spurdiff.differential.mesh.forces`; the driver over a communication step:
:mod:`spurdiff.differential.mesh.stepper`; numbers and sources: docs/mesh-dynamics.md.

(Over 400 lines: the one class of the mesh levels, its state, initialization and outputs; the
laws, events, stick-slip, integrator and stepper are modules of their own.)
"""
from __future__ import annotations

import math
from dataclasses import replace
from functools import partial

from spurdiff.errors import ParameterError, StepError, require_finite, require_positive
from spurdiff.numerics import gj_inverse
from spurdiff.gears.geometry import DifferentialGeometry
from spurdiff.differential.inertia import MassProperties, mass_properties
from spurdiff.differential.flank_law import locking_coefficient_flank
from spurdiff.differential.locking import (PinFriction, dynamic_pin_model, locking_coefficients,
                                           paper_locking_coefficient, pin_friction)
from spurdiff.differential.model_base import DifferentialModel
from spurdiff.differential.params import DifferentialParams
from spurdiff.differential.statics import MeshForces
from spurdiff.gears.layout import kinematics
from spurdiff.differential.mesh import kernel as compiled
from spurdiff.differential.mesh.forces import (BilateralSpring, ElastoBacklash, FlankFriction, Impact, MeshPhase, SideValues, evaluate,
                     gear_meshes, potential)
from spurdiff.differential.mesh.integrator import METHODS, RosenbrockW, zeros
from spurdiff.differential.mesh.layout import (D12, DA, DB, PSI, VA, VB, W1, W2, WC, constant_jacobian, mesh_data,
                                              relative_angles, roll_gradients, split)
from spurdiff.differential.mesh.params import MeshParams
from spurdiff.differential.mesh.events import contact_flags
from spurdiff.differential.mesh.stepper import advance
from spurdiff.differential.mesh.stickslip import initial_state



class MeshDifferential(DifferentialModel):
    """Differential with compliant or contact gear meshes (the contract:
    :class:`spurdiff.differential.model_base.DifferentialModel`)."""

    ATOMIC_STEP = True   # do_step leaves the state as it was when it raises (the FMU adapter relies on it)

    def __init__(self, params: DifferentialParams | None = None, mesh: MeshParams | None = None):
        super().__init__(params or DifferentialParams())    # the inputs and start values
        self.mesh = mesh or MeshParams()
        self.input_names = dict(self.INPUT_NAMES)
        self._ready = False

    @property
    def mesh_model(self) -> str:
        return self.mesh.level

    @property
    def active_effects(self) -> tuple[str, ...]:
        """Names of the effects in use: the mesh law, then the enabled switches (pinFriction only
        if the locking coefficient is not zero)."""
        m = self.mesh
        eff = [m.level]
        for name in ("backlash", "meshStiffnessVariation", "pinFriction", "flankFriction"):
            on = bool(getattr(m, name))
            if name == "pinFriction" and self._ready:
                on = self._pin
            if on:
                eff.append(name)
        return tuple(eff)

    # ================================================================== setup
    def initialize(self, t0: float = 0.0) -> None:
        """Validate, derive constants, set the (preloaded) initial state, compute outputs at t0."""
        p, mp_ = self.params, self.mesh
        geo: DifferentialGeometry = p.validate()
        mp_.validate()
        self._check_inputs()
        self.geometry = geo
        self.mass: MassProperties = mass_properties(p, geo)
        kin = kinematics(geo)
        self.lam, self.rho1, self.rho2 = kin.sunB_per_sunA, kin.planet1_per_sunA, kin.planet2_per_sunA
        ms = self.mass
        n = self.n = ms.n_pairs
        self.JA, self.JB, self.J1, self.J2 = ms.J_sunA, ms.J_sunB, ms.J_planet1, ms.J_planet2
        self.Jc = ms.J_carrier_total
        self.Jtot = self.Jc + self.JA + self.JB + n * (self.J1 + self.J2)
        # the rigid model's names, for the FMU's calculated parameters
        self.Mcc = self.Jtot
        self.Mdd = self.JA + self.lam ** 2 * self.JB + n * (self.J1 * self.rho1 ** 2 + self.J2 * self.rho2 ** 2)
        self.law = p.lockingLaw
        self.preload = float(p.lockingPreload)
        pf = self._pf = pin_friction(geo, p.mu_pin, p.r_collar, self.preload, self.law, *dynamic_pin_model(p))
        self.K_paper = paper_locking_coefficient(p.mu_pin, p.r_collar, n, geo.r_a, geo.r_1, geo.r_b, geo.r_2)
        # the static / dynamic split of the pins (as the rigid level): pf.c (mu_pin) stuck and at
        # break-away, c_pin_slide (mu_pinDynamic, equal to mu_pin where that is 0) while a planet slips
        mu_d = p.mu_sliding
        c_d = pin_friction(geo, mu_d, p.r_collar, self.preload, self.law, *dynamic_pin_model(p)).c
        if self.law == "paper":
            self.K = self.K_coast = self.K_paper
            self.K_slide = self.K_slide_coast = paper_locking_coefficient(mu_d, p.r_collar, n, geo.r_a, geo.r_1,
                                                                          geo.r_b, geo.r_2)
        else:
            self.K, self.K_coast = locking_coefficients(pf, p.leadingSun)
            self.K_slide, self.K_slide_coast = ((self.K, self.K_coast) if c_d == pf.c
                                                else locking_coefficients(replace(pf, c=c_d), p.leadingSun))
        self.speed_drive = p.carrierDrive == "speed"
        mA, mB = geo.meshA1, geo.meshB2
        self.rbA, self.rb1, self.rbB, self.rb2 = mA.rb1, mA.rb2, mB.rb1, mB.rb2
        # the effects
        self._bl = bool(mp_.backlash)
        self._contact = mp_.level == "contact"
        self._var = bool(mp_.meshStiffnessVariation)
        self._flank = bool(mp_.flankFriction)
        self._pin = bool(mp_.pinFriction) and (pf.c > 0.0 or self.preload > 0.0)
        self._need_phase = self._var or self._flank
        # the locking coefficients without flank friction, and with it where it is on (pin-load
        # law): the mesh-cycle average of the Coulomb flank friction at the static coefficient
        # (spurdiff.differential.flank_law; the break-away of a slow ramp from rest depends on the
        # start phases, within the range info prints)
        self.K_pins, self.K_pins_coast = self.K, self.K_coast
        if self._flank and self.law == "pinFriction":
            pf_f = pf if self._pin else PinFriction(pf.layout, 0.0, (0.0, 0.0), pf.rho, pf.rb, pf.n)
            self.K, self.K_coast = (locking_coefficient_flank(geo, pf_f, float(mp_.muStatic), sg)
                                    for sg in (1.0, -1.0))
            # sliding: the pins at mu_pinDynamic, the flanks at flank.muDynamic
            pf_fd = replace(pf_f, c=c_d if self._pin else 0.0)
            self.K_slide, self.K_slide_coast = (locking_coefficient_flank(geo, pf_fd, float(mp_.muDynamic), sg)
                                                for sg in (1.0, -1.0))
        self.law_obj = (Impact(float(mp_.contactExponent), float(mp_.contactDamping), float(mp_.contactDepth))
                        if self._contact else ElastoBacklash() if self._bl else BilateralSpring())
        self.phase_obj = MeshPhase(self._var, self._need_phase)
        self.flank_obj = (FlankFriction(float(mp_.muStatic), float(mp_.muDynamic), float(mp_.vStiction),
                                        float(mp_.vTransition)) if self._flank else None)
        self.md = mesh_data(geo, ms, mp_)
        self.gear_meshes = gear_meshes(self.md)
        self._du = roll_gradients(self.rbA)
        self._mode = None          # the phase modes held over an internal step (stepper), else None
        # pin friction: layout of one planet pair and the constants (spurdiff.differential.locking)
        # the planets' centrifugal pin loads per unit w_c^2 (pinSpeedLoads, as the rigid level)
        th = pf.layout.theta
        self._cf = (((ms.m_planet1 * geo.meshA1.a, 0.0),
                     (ms.m_planet2 * geo.meshB2.a * math.cos(th), ms.m_planet2 * geo.meshB2.a * math.sin(th)))
                    if p.pinSpeedLoads and self._pin and self.law == "pinFriction" else ((0.0, 0.0), (0.0, 0.0)))
        # and their tangential (carrier-acceleration) pin loads -m_i a_i alpha_c e_t,i per unit alpha_c
        self._ct = (((0.0, -ms.m_planet1 * geo.meshA1.a),
                     (ms.m_planet2 * geo.meshB2.a * math.sin(th), -ms.m_planet2 * geo.meshB2.a * math.cos(th)))
                    if p.pinSpeedLoads and self._pin and self.law == "pinFriction" else ((0.0, 0.0), (0.0, 0.0)))
        self._g, self._g_wc, self._g_ac = (0.0, 0.0, 0.0, 0.0), 0.0, 0.0
        self._pin_flat = pf.layout._flat
        self._pin_ends = pf.layout.ends         # the journal's two ends (issue 41; planar: end L zero)
        self._pin3d = tuple(int(e[3] != 0.0 or any(e[2])) for e in pf.layout.ends)
        self.layout_angle = pf.layout.theta
        self.pin_unit = pf.layout.unit_pin_loads(1.0)
        self.c_pin = pf.c
        self.c_pin_slide = c_d if self._pin else pf.c
        self._M01, self._M02 = pf.M0
        # dissipation present at all? (else the loss is identically 0 and not integrated)
        self._dissipative = (self._pin or self._flank
                             or (self._contact and float(mp_.contactDamping) > 0.0)
                             or (not self._contact and any(m.c > 0.0 for m in self.md)))
        N = self.n_states = 8 if self.speed_drive else 10
        self._N = N
        self.y = zeros(N)          # (a list; the compiled kernel's state array where it runs)
        self._integ = RosenbrockW(N, partial(evaluate, self), METHODS[mp_.method_in_use()], split(N))
        self._f0 = zeros(N)
        self._f1 = zeros(N)
        self._J1 = zeros(N, N)
        self._fscratch = zeros(N)
        tol = float(mp_.tolerance)
        # the deflections' scale is 10 um
        self._atol = [(1e-5 if i in (DA, DB, D12) else 1.0) * tol for i in range(N)]
        self._rtol = float(mp_.tolerance)
        # slip speed below which a slipping planet is tested for sticking (rad/s): 1e-3 of the
        # integrator's absolute velocity accuracy
        self._w_stick = 1e-3 * float(mp_.tolerance)
        for J in (self._integ.J, self._J1):
            constant_jacobian(J, self.rbA, self.rb1, self.rbB, self.rb2, self.speed_drive)
        # torque drive: inverse mass matrix in (w_c, v_A, v_B, w_1, w_2) for stick impulses
        if not self.speed_drive:
            M = [[self.Jtot, self.JA, self.JB, n * self.J1, n * self.J2],
                 [self.JA, self.JA, 0.0, 0.0, 0.0], [self.JB, 0.0, self.JB, 0.0, 0.0],
                 [n * self.J1, 0.0, 0.0, n * self.J1, 0.0], [n * self.J2, 0.0, 0.0, 0.0, n * self.J2]]
            Minv = gj_inverse([list(row) for row in M])
            if Minv is None:
                raise ParameterError(f"the mass matrix of the carrier, suns and planets is singular: {M} "
                                     "(allowed: positive inertias)")
            self._Minv = Minv
        self._kernel, self.kernel_in_use = compiled.choose(self)
        if self._kernel is not None:
            self.y = self._kernel.y       # the state lives in the kernel's structure
        self.n_phase_switches = 0   # loaded flanks' single/double contact switches (diagnostic, solver_counts)
        initial_state(self, t0)
        self._ready = True

    def _check_inputs(self) -> None:
        if math.isfinite(self.w_ref + self.tau_c + self.tau_L + self.tau_R):   # (a sum is cheaper than 4 checks)
            return
        names = self.input_names
        for attr in ("w_ref", "tau_c", "tau_L", "tau_R"):
            require_finite(names[attr], getattr(self, attr))

    # ================================================================== solve_ivp interface
    def rhs(self, t: float, y) -> list:
        """Right-hand side for scipy's solve_ivp (current inputs and friction modes held; the
        compiled kernel's evaluation where it runs, the same numbers); ``y`` any sequence of floats."""
        f = zeros(self._N)
        yl = _floats(y)
        if self._kernel is not None:
            self._kernel.evaluate(self, yl, f, None)
        else:
            evaluate(self, yl, f, None)
        return f

    def jac(self, t: float, y) -> list:
        """Analytic Jacobian for solve_ivp (Radau / BDF), rows."""
        J = zeros(self._N, self._N)
        constant_jacobian(J, self.rbA, self.rb1, self.rbB, self.rb2, self.speed_drive)
        yl = _floats(y)
        if self._kernel is not None:
            self._kernel.evaluate(self, yl, self._fscratch, J)
        else:
            evaluate(self, yl, self._fscratch, J)
        return J

    def state_vector(self) -> list:
        """Copy of the continuous state y (see the module docstring for its layout)."""
        return list(self.y)

    def load_state_vector(self, y) -> None:
        """Put a continuous state (e.g. a point of a solve_ivp trajectory) in place and refresh the
        outputs at it; friction modes and inputs stay as they are. The integrator's memory of the
        old state goes (its f at y, its Jacobian: a new one at the next step, as after
        initialize), so the compiled kernel and the Python reference go on alike."""
        yl = _floats(y)
        if len(yl) != self._N:
            raise ParameterError("y", f"{len(yl)} values", f"{self._N}, the state's length")
        self.y[:] = yl
        self._f0_key = None
        self._jac_age, self._integ.lu_h = -1, 0.0
        if self._kernel is not None:      # (its counters stay: not a full Jacobian pack)
            self._kernel.state.jac_age, self._kernel.state.lu_h = -1, 0.0
        if self._bl or self._contact:
            self._contact_flags = contact_flags(self, self.y)
        self._kernel_dirty = True
        self._refresh_outputs()

    def _pin_force(self, i: int, Fs: float, F12: float) -> tuple[float, float, float]:
        """Pin friction load of planet i with its inertial force (|F_pin| planar, |R_0| + |R_L| with
        the journal's end reactions) and its derivatives by Fs and F12
        (:meth:`spurdiff.gears.layout.PinLayout.pin_force` with ``g_i``)."""
        c0, w0, cL, wL = self._pin_ends[i]
        tx, ty, rx, ry, ux, uy, qx, qy = c0
        aS = abs(Fs)
        a12 = abs(F12)
        gx, gy = self._g[2 * i], self._g[2 * i + 1]
        fx = Fs * tx + aS * rx + F12 * ux + a12 * qx + w0 * gx
        fy = Fs * ty + aS * ry + F12 * uy + a12 * qy + w0 * gy
        mag = math.sqrt(fx * fx + fy * fy)
        sgS = 1.0 if Fs >= 0.0 else -1.0
        sg12 = 1.0 if F12 >= 0.0 else -1.0
        if mag == 0.0:
            tot = dS = d12 = 0.0
        else:
            tot, dS, d12 = (mag, (fx * (tx + sgS * rx) + fy * (ty + sgS * ry)) / mag,
                            (fx * (ux + sg12 * qx) + fy * (uy + sg12 * qy)) / mag)
        if self._pin3d[i]:          # the far end of the journal: |R_0| + |R_L| (PinLayout.ends)
            tx, ty, rx, ry, ux, uy, qx, qy = cL
            fx = Fs * tx + aS * rx + F12 * ux + a12 * qx + wL * gx
            fy = Fs * ty + aS * ry + F12 * uy + a12 * qy + wL * gy
            mag = math.sqrt(fx * fx + fy * fy)
            if mag != 0.0:
                tot += mag
                dS += (fx * (tx + sgS * rx) + fy * (ty + sgS * ry)) / mag
                d12 += (fx * (ux + sg12 * qx) + fy * (uy + sg12 * qy)) / mag
        return tot, dS, d12

    def _set_speed_loads(self, wc: float, alpha: float) -> None:
        """The planets' inertial pin loads at carrier speed ``wc`` and carrier acceleration ``alpha``,
        held over the next step: centrifugal ``m_i a_i w_c^2 e_r,i`` plus tangential
        ``-m_i a_i alpha_c e_t,i`` (:mod:`spurdiff.differential.speed_law`), one vector per planet."""
        if wc == self._g_wc and alpha == self._g_ac:
            return
        self._g_wc, self._g_ac = wc, alpha
        self._g = self._inertial_loads()
        self._f0_key = None
        if self._kernel is not None:
            self._kernel.set_speed_loads(self._g)

    def _inertial_loads(self) -> tuple:
        """The pin loads of :meth:`_set_speed_loads` at ``_g_wc`` and ``_g_ac`` (g1x g1y g2x g2y, N)."""
        wc, a = self._g_wc, self._g_ac
        w2 = wc * wc
        (c1x, c1y), (c2x, c2y) = self._cf
        if a == 0.0:
            return (c1x * w2, c1y * w2, c2x * w2, c2y * w2)
        (t1x, t1y), (t2x, t2y) = self._ct
        return (c1x * w2 + t1x * a, c1y * w2 + t1y * a, c2x * w2 + t2x * a, c2y * w2 + t2y * a)

    # ================================================================== stepping
    def do_step(self, t: float, h: float) -> None:
        """Advance from t to t + h with the inputs held; raises ParameterError / StepError.

        On any error the model is left exactly as it was before the call (``ATOMIC_STEP``)."""
        if not self._ready:
            raise StepError("do_step called before initialize")
        h = require_positive("communicationStepSize", h)
        self._check_inputs()
        # carrier speed at the step's start and acceleration (speed drive: this step's ramp; torque
        # drive: the acceleration at the end of the last step), held over the step
        if self.speed_drive:
            self._set_speed_loads(self.wc, (self.w_ref - self.wc) / h)
        else:
            self._set_speed_loads(float(self.y[WC]), self._out.ac)
        if self._kernel is not None:   # the whole step in C (which changes nothing on failure), outputs included
            self._refresh_outputs(SideValues(*self._kernel.advance(self, t, h)))
            return
        snapshot = self.get_state()
        try:
            advance(self, t, h)
        except StepError:
            self.set_state(snapshot)
            raise
        except (ArithmeticError, ValueError) as exc:
            self.set_state(snapshot)
            raise StepError(f"step at t = {t:.9g} s failed: {exc}") from exc
        except Exception:
            self.set_state(snapshot)
            raise
        self._refresh_outputs(self._sv0 if (not self.speed_drive or self._ac == 0.0) else None)

    def solver_counts(self) -> dict[str, int]:
        """The internal solver's work since initialize: accepted and rejected internal steps,
        Jacobian evaluations and factorizations of W, and the loaded flanks' single/double contact
        switches at the located phase boundaries (diagnostics; not part of the FMU state)."""
        k = self._kernel is not None and not self._jac_dirty
        S = self._kernel.state if k else None
        return {"steps": self.n_internal_steps, "rejected": self.n_rejected_steps,
                "jacobians": int(S.n_jac) if k else self.n_jacobians,
                "factorizations": int(S.n_lu) if k else self._integ.n_factorizations,
                "phase_switches": int(S.n_psw) if k else self.n_phase_switches}

    def states_only(self) -> None:
        """From now on integrate the states alone: no loss quadrature (the dissipated energy is
        not booked), as an ODE integrator without a quadrature does (the solver comparison). Not
        with pin friction (its break-away test uses the quadrature's midpoint evaluation)."""
        if self._pin:
            raise ParameterError("mesh.pinFriction", True, "false for a states-only run")
        self._dissipative = False
        if self._kernel is not None:
            self._kernel.params.dissipative = 0

    def run_dense(self, t_end: float, times) -> list:
        """An integration over a whole run from the current time with the inputs held, as
        solve_ivp's one call with ``t_eval``: one step of length ``t_end`` (the internal steps are
        not cut at communication points) with the states at ``times`` (from the current time,
        increasing, in (0, t_end]) by the method's dense output, a list of rows; the model ends at the end.
        For the solver comparison (harness.measure.bench.mesh); a co-simulation steps with do_step."""
        if not self._ready:
            raise StepError("run_dense called before initialize")
        t_end = require_positive("t_end", t_end)
        self._check_inputs()
        try:
            tq = _floats(times)
        except (TypeError, ValueError):
            tq = None
        # (comparisons that are False for NaN: a NaN time is refused too)
        if (not tq or not (tq[0] > 0.0 and tq[-1] <= t_end)
                or not all(b > a for a, b in zip(tq, tq[1:]))):
            raise ParameterError("times", times if tq is None else tq[:3], f"increasing, in (0, {t_end:g}]")
        t = self.t
        if self._kernel is not None:   # the outputs from the side values the kernel left (as do_step)
            ys, sv = self._kernel.advance_dense(self, t, t_end, tq)
            self._refresh_outputs(SideValues(*sv))
            return ys
        ys = [None] * len(tq)
        advance(self, t, t_end, dense=(tq, ys))
        self._refresh_outputs()
        return ys

    # ================================================================== outputs
    def _refresh_outputs(self, sv=None) -> None:
        """Outputs at the current state; the speed drive reports the torque that holds the
        reached speed (carrier acceleration 0), as the rigid model does. ``sv``: side values of
        an evaluation at the current state that already used that carrier acceleration."""
        if sv is None:
            ac_keep = self._ac
            if self.speed_drive:
                self._ac = 0.0
            sv = evaluate(self, self.y, self._fscratch, None)
            self._ac = ac_keep
        self._out = sv
        self._V = None
        self._psiB = None

    @property
    def w_L(self) -> float:
        return self.wc + float(self.y[VA])

    @property
    def w_R(self) -> float:
        return self.wc + float(self.y[VB])

    @property
    def phi_L(self) -> float:
        return self.phic + float(self.y[PSI])

    @property
    def phi_R(self) -> float:
        if self._psiB is None:
            self._psiB = relative_angles(self, list(self.y))[0]
        return self.phic + self._psiB

    @property
    def wd(self) -> float:
        """Speed of sun A relative to the carrier (the rigid model's differential speed)."""
        return float(self.y[VA])

    @property
    def tau_drive(self) -> float:
        """Torque the carrier drive delivers (speed drive: what holds the speed)."""
        if not self.speed_drive:
            return self.tau_c
        o = self._out
        return o.Q_A + o.Q_B + self.n * (o.Q_1 + o.Q_2)

    @property
    def tau_mesh_L(self) -> float:
        """Torque the meshes deliver to sun A (N m)."""
        return self._out.Q_A

    @property
    def tau_mesh_R(self) -> float:
        return self._out.Q_B

    @property
    def mesh_forces(self) -> MeshForces:
        """Normal tooth forces per planet pair (N), positive on the drive flanks."""
        o = self._out
        return MeshForces(o.F_A1, o.F_B2, o.F_12)

    @property
    def side_values(self):
        """The last evaluation's :class:`spurdiff.differential.mesh.forces.SideValues` at the current state."""
        return self._out

    @property
    def locking_torque(self) -> float:
        """Pin friction as a generalised force on the differential coordinate (N m), the rigid
        model's ``Q_f``: n (rho_1 M_1 + rho_2 M_2)."""
        o = self._out
        return self.n * (self.rho1 * o.M_1 + self.rho2 * o.M_2) if self._pin else 0.0

    @property
    def locking_capacity(self) -> float:
        o = self._out
        return self.n * (abs(self.rho1) * o.cap_1 + abs(self.rho2) * o.cap_2)

    @property
    def power_loss(self) -> float:
        """Mean dissipated power over the last step (W), >= 0."""
        return self.loss_last_step / self._last_h if self._last_h > 0.0 else self._out.P

    @property
    def kinetic_energy(self) -> float:
        y = list(self.y)
        wc = self.wc
        n = self.n
        return 0.5 * (self.Jc * wc * wc + self.JA * (wc + y[VA]) ** 2 + self.JB * (wc + y[VB]) ** 2
                      + n * self.J1 * (wc + y[W1]) ** 2 + n * self.J2 * (wc + y[W2]) ** 2)

    @property
    def potential_energy(self) -> float:
        """Elastic energy of all mesh springs (J)."""
        if self._V is None:
            self._V = potential(self, list(self.y))
        return self._V

    @property
    def stuck(self) -> bool:
        return self._pin and self.s[0] == 0 and self.s[1] == 0

    @property
    def planet_modes(self) -> tuple[int, int]:
        """Pin-friction mode of planet 1 and 2: 0 stuck, +1/-1 slipping forward/backward."""
        return tuple(self.s)

    # ================================================================== state
    _SCALARS = ("t", "wc", "phic", "_ac", "h_next", "_dA0", "_dB0", "_d120", "work_in", "energy_loss",
                "loss_last_step", "parametric_work", "n_mode_switches", "n_contact_transitions",
                "n_internal_steps", "n_rejected_steps", "n_steps", "_last_h",
                "w_ref", "tau_c", "tau_L", "tau_R", "_g_wc", "_g_ac")

    def get_state(self) -> dict:
        """Full state (JSON-serialisable): continuous state, friction modes, contact flags,
        integrator memory (next internal step size), bookkeeping and the held inputs."""
        s = {k: getattr(self, k) for k in self._SCALARS}
        for k in ("w_ref", "tau_c", "tau_L", "tau_R"):
            s[k] = float(s[k])
        s["y"] = list(self.y)
        s["modes"] = list(self.s)
        s["contact_flags"] = list(self._contact_flags)
        # the integrator's Jacobian in use and its age (a W-method's memory, as h_next is)
        k = self._kernel is not None and not self._jac_dirty
        s["jacobian"] = [v for row in (self._kernel.J if k else self._integ.J) for v in row]
        s["jac_age"] = int(self._kernel.state.jac_age) if k else self._jac_age
        return s

    def set_state(self, state: dict) -> None:
        for k in self._SCALARS:
            setattr(self, k, state[k])
        self._g = self._inertial_loads()              # the speed loads are a function of _g_wc, _g_ac
        self.y[:] = [float(v) for v in state["y"]]
        self.s = [int(v) for v in state["modes"]]
        self._contact_flags = [int(v) for v in state["contact_flags"]]
        if "jacobian" in state:
            N, flat = self._N, state["jacobian"]
            for i, row in enumerate(self._integ.J):
                row[:] = [float(v) for v in flat[i * N:(i + 1) * N]]
            self._jac_age = int(state["jac_age"])
        else:
            self._jac_age = -1
        self._integ.lu_h = 0.0
        self._f0_key = None
        self._kernel_dirty = self._jac_dirty = True
        self._refresh_outputs()


def _floats(y) -> list:
    """A sequence of numbers (a list, a numpy array from solve_ivp, a tuple) as a list of floats."""
    tolist = getattr(y, "tolist", None)        # (numpy's, without importing it: its floats are Python's)
    return [float(v) for v in (tolist() if tolist is not None else y)]
