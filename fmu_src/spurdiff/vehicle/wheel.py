"""Wheel load: compliant half-shaft, wheel inertia and longitudinal tyre of one driven wheel.

The model one ``WheelLoad.fmu`` instance wraps (one per driven wheel). Causality: flange angle and
speed in (from the differential's sun flange), flange torque out; vehicle speed at the wheel
centre in, tyre force out.

Equations (SI; Modelica sign conventions)::

    theta     = phi_flange - phi_wheel                      half-shaft twist (rad), a state
    tau_shaft = c theta + d (w_flange - w)                  shaft torque on the wheel (N m)
    dtheta/dt = w_flange - w
    J dw/dt   = tau_shaft - R Fx - M_rr                     wheel (w: wheel speed, rad/s)
    sigma dk/dt + |v_x| k = R w - v_x                       transient slip k (see tyre.py)
    Fx        = mu max(Fz, 0) f(k)                          Magic Formula (tyre.py)
    M_rr      = f_rr max(Fz, 0) R tanh(w / w_eps)           rolling resistance, faded at w = 0
    flange.tau = -tau_shaft                                 torque ON the differential's flange

Inputs are held over a communication step (zero-order hold); the flange angle is
``phi(t) = phi_in + w_in (t - t_step)``. The load and the wheel-centre speed may ramp instead
(first-order hold): ``Fz(t) = Fz_in + dFz (t - t_a)``, ``v_x(t) = v_in + dv (t - t_a)`` with the
rates ``FzRate``, ``vxRate`` (0, the default: held) anchored at ``t_a`` = the step's start
(``rampAnchor = "start"``) or its end (``"end"``: the vehicle stepped first and handed over its
outputs at the end of the step with their mean rates over it, so the ramp joins the vehicle's
outputs at both ends); each sub-step takes the ramp at its midpoint (the load not below 0, so a
wheel lifts inside the step), the outputs the values at the end.

With ``followFlangeAngle = 1`` the twist is corrected at the start of each step by the
difference between the flange angle input and the angle this model extrapolated to at the end
of the previous step, so the twist follows the differential's actual angle and does not drift;
the correction's change of spring energy is booked as work done at the flange. Only the twist
is a state (absolute angles grow without bound). The angle reference is taken from the flange
angle input of the first step (the twist then is
``phi_rel_start``): a Gauss-Seidel master that steps the differential first hands this model the
angle at the end of the first step, ``w h`` ahead of the angle at initialization, which would
otherwise twist the shaft by ``w h`` at once (a torque pulse ``c w h``: 47 N m at 30 rad/s and
h = 0.2 ms) instead of only shifting the wheel's angle.

Integration: implicit midpoint rule, sub-stepped to ``h_max`` (default 1 ms). Why:

* A-stable: the shaft-wheel-tyre modes (shaft c / J about 100 rad/s; the tyre's standstill
  spring R^2 B C mu Fz / sigma / J about 250 rad/s; relaxation |v_x| / sigma up to 400 1/s) stay
  stable for any step, including a communication step of 1e-2 s in one sub-step.
* Second order, and with it the discrete energy balance is exact: kinetic and spring energy are
  quadratic, so their changes over a sub-step equal the midpoint powers times the step. The
  ledger (shaft work at the flange, work delivered to the vehicle ``Fx v_x``, shaft damping,
  slip ``Fx (R w - v_x)``, rolling resistance) is accumulated from the same midpoint values and
  closes to rounding error.
* Cheap: twist and slip are linear in the midpoint wheel speed, so each sub-step is one scalar
  Newton iteration (2-4 passes) in plain floats, no arrays, no allocation.

``shaftCoupling = "wheel"`` (the differential owns the half-shaft, :mod:`spurdiff.differential.shafts`): the
shaft torque ``shaftIn.tau`` is an input, the wheel angle and speed are outputs. The differential
computed that torque (the mean over its step) for the wheel moving as this model's interface
outputs predicted (``wheel.aFree``, ``wheel.invJ``, ``wheel.dadw``, ``tyre.torqueRate``,
``tyre.torqueStiffness``, ``tyre.relaxationRate``: the wheel speed and tyre torque linearized about
the state at the communication point, :meth:`WheelLoad._update_surrogate`), a speed change
``shaftIn.dw`` over the step (0 when not connected: the speed ``w_k`` held). With
``interfaceStiffness = 1`` the shaft's ``c`` and ``d`` act inside this step on the wheel's deviation
from that motion (the speed ramp ``w_p(s) = w_k + dw s / h`` and its angle), ``tau = tau_in + c
(phi_p(s) - (phi - phi_k)) + d (w_p(s) - w)``, so the stiff wheel/shaft mode (about 100 rad/s) is
implicit on this side too. Any step sequence: nothing here assumes a constant step. With ``shaftCoupling = "torque"`` and
``followFlangeAngle = 1``, a Gauss-Seidel master that steps the differential first hands the
flange angle at the end of the differential's step: the reference offset taken at the first step
(``w h``) is right only while the step stays the same (alternating steps give errors of order
``c w dh`` in the shaft torque); use ``shaftCoupling = "wheel"`` or a constant step there.

The slip energy ``Fx (R w - v_x)`` is the net work done at the contact patch: with transient slip
a small part of it is elastic (tread deflection) and comes back; over a run it is dissipation.

(Over 400 lines: about 70 of them are the derivation above; the rest is the one class and its
half-shaft step.)
"""
from __future__ import annotations

import math
import operator
from spurdiff.errors import StepError, require_finite, require_nonnegative, require_positive
from spurdiff.vehicle import kernel as vehicle_kernel
from spurdiff.vehicle.native_plan import NativeStepMixin
from spurdiff.vehicle.wheel_params import SHAFT_COUPLINGS, HalfShaftParams, WheelLoadParams, WheelParams  # noqa: F401 (re-exported)

_STATE_KEYS = (
    "t", "theta", "w", "k", "phi_ref", "n_steps", "n_substeps",
    "work_flange", "work_road", "loss_damping", "loss_slip", "loss_rolling", "KE0", "PE0",
    # inputs held over the last step and outputs (so a restored instance reports the same values)
    "flange_phi", "flange_w", "Fz", "mu", "vx",
    "flange_tau", "Fx", "wheel_w", "slip", "shaft_tau", "shaft_power",
    # shaftCoupling = "wheel": wheel angle, shaft torque input and the anchor of the step, the
    # differential's predicted speed change over the step, the linear model reported for the next
    "phi", "tau_in", "w_anchor", "dw_in", "sur_a", "sur_invJ", "sur_dadw", "sur_qrate", "sur_ct", "sur_rt",
    # the rates of the load and the wheel-centre speed over the step (FzRate, vxRate)
    "dFz", "dvx",
)
_WHEEL_STEP_KEYS = ("theta", "w_anchor", "w", "k", "phi", "t", "n_steps", "n_substeps", "work_flange",
                    "work_road", "loss_slip", "loss_rolling", "flange_tau", "Fx", "wheel_w", "slip",
                    "shaft_tau", "shaft_power", "sur_a", "sur_invJ", "sur_dadw", "sur_qrate", "sur_ct",
                    "sur_rt")
_get_step_values = operator.attrgetter(*_WHEEL_STEP_KEYS)


class WheelLoad(NativeStepMixin):
    """Half-shaft + wheel + longitudinal tyre; equations and integrator in the module docstring.

    Inputs (attributes, SI): ``flange_phi`` (rad), ``flange_w`` (rad/s) of the differential's sun
    flange; ``Fz`` normal load (N, negative is treated as 0); ``mu`` road friction (>= 0);
    ``vx`` longitudinal velocity of the wheel centre in the wheel frame (m/s); ``dFz`` (N/s),
    ``dvx`` (m/s^2): their rates over the step (FMI ``FzRate``, ``vxRate``; 0: held).

    Outputs (attributes, values at the end of the last step with the inputs held over it):
    ``flange_tau`` (N m, torque on the differential's flange, Modelica sign: negative when the
    wheel is driven forward), ``Fx`` (N, on the vehicle), ``wheel_w`` (rad/s), ``slip`` (k),
    ``shaft_tau`` (N m), ``shaft_power`` (W, shaft torque x flange speed).

    Energy account (J, since :meth:`initialize`): ``work_flange`` (done on the model at the
    flange), ``work_road`` (delivered to the vehicle, integral of Fx v_x), ``loss_damping``,
    ``loss_slip``, ``loss_rolling``; properties ``kinetic_energy``, ``potential_energy``,
    ``energy_dissipated`` and ``energy_residual`` (the balance; rounding-level).
    """

    def __init__(self, params: WheelLoadParams | None = None):
        self.params = params if params is not None else WheelLoadParams.defaults()
        self.flange_phi = 0.0
        self.flange_w = 0.0
        self.Fz = 0.0
        self.mu = 1.0
        self.vx = 0.0
        self.tau_in = 0.0
        self.dw_in = 0.0
        self.dFz = 0.0
        self.dvx = 0.0
        self.flange_tau = self.Fx = self.wheel_w = self.slip = self.shaft_tau = self.shaft_power = 0.0
        # implementation of the sub-steps and outputs (``solver.kernel``): auto (the compiled step,
        # spurdiff.vehicle.kernel, if it loads, else this Python reference) | compiled | python
        self.kernel = getattr(self.params, "kernel", "auto")   # params.kernel; may be set here
        self._vk = None
        self.kernel_note = "python (not initialized)"
        self._ready = False

    # ------------------------------------------------------------------ setup
    def initialize(self, t0: float = 0.0) -> None:
        """Validate parameters and inputs, set the initial state, compute the outputs at t0."""
        p = self.params
        p.validate()
        phi_in, w_in, Fz, mu, v = self._inputs()
        sh, wh, ty = p.halfShaft, p.wheel, p.tyre
        self.theta = float(sh.phi_rel_start)
        self.w = float(w_in if math.isnan(wh.w_start) else wh.w_start)
        if math.isnan(ty.k_start):
            k = (wh.R * self.w - v) / abs(v) if v != 0.0 else 0.0
        else:
            k = float(ty.k_start)
        self.k = min(max(k, -ty.k_max), ty.k_max)
        self.phi_ref = phi_in
        self.phi = 0.0
        self.w_anchor = self.w
        self.wheel_mode = p.shaftCoupling == "wheel"
        if self.wheel_mode:
            self.theta = 0.0
            require_finite("shaftIn.tau", self.tau_in)
        self.t = float(require_finite("t0", t0))
        self.n_steps = 0
        self.n_substeps = 0
        self.work_flange = self.work_road = 0.0
        self.loss_damping = self.loss_slip = self.loss_rolling = 0.0
        self.KE0 = self.kinetic_energy
        self.PE0 = self.potential_energy
        self._update_outputs(self.w if self.wheel_mode else w_in, v, Fz, mu)
        self._vk, self.kernel_note = vehicle_kernel.choose_wheel(self)
        self._ready = True

    def _inputs(self) -> tuple[float, float, float, float, float]:
        phi, w, Fz, mu, v = self.flange_phi, self.flange_w, self.Fz, self.mu, self.vx
        if (math.isfinite(phi + w + Fz + mu + v) and mu >= 0.0
                and phi.__class__ is w.__class__ is Fz.__class__ is mu.__class__ is v.__class__ is float):
            return phi, w, (Fz if Fz > 0.0 else 0.0), mu, v   # the usual case; else the checks name the bad one
        phi = require_finite("flange.phi", self.flange_phi)
        w = require_finite("flange.w", self.flange_w)
        Fz = require_finite("Fz", self.Fz)
        mu = require_nonnegative("mu", self.mu)
        v = require_finite("vx", self.vx)
        return phi, w, (Fz if Fz > 0.0 else 0.0), mu, v

    def _input_rates(self) -> tuple[float, float]:
        """The rates of the load and the wheel-centre speed over the coming step (attributes
        ``dFz``, ``dvx``, FMI ``FzRate``, ``vxRate``; 0: held), validated."""
        dFz, dv = self.dFz, self.dvx
        if math.isfinite(dFz + dv) and dFz.__class__ is dv.__class__ is float:
            return dFz, dv
        return require_finite("FzRate", self.dFz), require_finite("vxRate", self.dvx)

    def _ramp(self, Fz: float, v: float, h: float) -> tuple[float, float, float, float, float, float]:
        """(Fz0, v0, Fz1, v1, dFz, dv): the load and the wheel-centre speed at the start and at the
        end of a step of length h over which they ramp at the input rates dFz, dv (checked), the
        inputs Fz (>= 0), v being the values at the step's start or end (``rampAnchor``); the load
        at the end not below 0 (at the start it may be: the sub-steps take the ramp's values, not
        below 0, at their midpoints). Rates 0: the inputs held."""
        dFz, dv = self._input_rates()
        if dFz == 0.0 and dv == 0.0:
            return Fz, v, Fz, v, dFz, dv
        if self.params.rampAnchor == "end":
            return Fz - dFz * h, v - dv * h, Fz, v, dFz, dv
        Fz1 = Fz + dFz * h
        return Fz, v, (Fz1 if Fz1 > 0.0 else 0.0), v + dv * h, dFz, dv

    # ------------------------------------------------------------------ stepping
    def do_step(self, t: float, h: float) -> None:
        """Advance from t to t + h with the inputs held (Fz and vx ramping at their rates). Raises
        ParameterError for bad inputs (the state is then unchanged) and StepError if the implicit
        equation cannot be solved."""
        if not self._ready:
            raise StepError("do_step called before initialize")
        if not (h.__class__ is float and 0.0 < h < math.inf):
            h = require_positive("communicationStepSize", h)
        if self.wheel_mode:
            self._do_step_wheel(t, h)
            return
        phi_in, w_in, Fz, mu, v = self._inputs()
        Fz0, v0, Fz, v, dFz, dv = self._ramp(Fz, v, h)   # checks the rates before the state changes
        p = self.params
        c = p.halfShaft.c
        if p.followFlangeAngle and self.n_steps > 0:
            dphi = phi_in - self.phi_ref
            if dphi != 0.0:
                th0 = self.theta
                self.theta = th0 + dphi
                self.work_flange += 0.5 * c * (self.theta * self.theta - th0 * th0)
        n = max(1, math.ceil(h / p.h_max - 1e-9))
        if self._vk is not None:
            io = self._compiled(self._vk, h / n, n, w_in, 0.0, v0, Fz0, mu, p.halfShaft.c, p.halfShaft.d, 0.0, dFz,
                                dv, w_in, v, Fz, 0.0, 0.0, False)
            self._commit_compiled(io)
            self.n_substeps += n
            self.phi_ref = phi_in + w_in * h
            self.t = t + h
            self.n_steps += 1
            return
        self._substeps(h / n, n, w_in, 0.0, v0, Fz0, mu, dFz=dFz, dv=dv)
        self.n_substeps += n
        self.phi_ref = phi_in + w_in * h
        self.t = t + h
        self.n_steps += 1
        self._update_outputs(w_in, v, Fz, mu)

    def _do_step_wheel(self, t: float, h: float) -> None:
        """shaftCoupling = "wheel": the shaft torque is an input (the differential owns the shaft).
        Atomic: on an error or a non-finite result the state is as before the call."""
        _, _, Fz, mu, v = self._inputs()
        tau_in, dw_in = self.tau_in, self.dw_in
        if not (math.isfinite(tau_in + dw_in) and tau_in.__class__ is dw_in.__class__ is float):
            tau_in = require_finite("shaftIn.tau", self.tau_in)
            dw_in = require_finite("shaftIn.dw", self.dw_in)
        Fz0, v0, Fz, v, dFz, dv = self._ramp(Fz, v, h)
        p = self.params
        if self._vk is not None:   # the same in C; nothing stored before the result is checked
            k = 1.0 if p.interfaceStiffness else 0.0
            n = max(1, math.ceil(h / p.h_max - 1e-9))
            w0 = self.w
            io = self._compiled(self._vk, h / n, n, w0, dw_in, v0, Fz0, mu, k * p.halfShaft.c, k * p.halfShaft.d,
                                tau_in, dFz, dv, w0 + dw_in, v, Fz, self.tau_in, k, True)
            if not (math.isfinite(io[1] + io[2] + io[3] + io[9] + io[11])
                    or all(math.isfinite(x) for x in (io[1], io[2], io[3], io[9], io[11]))):
                raise StepError(f"wheel: the step at t = {t:.6g} s gave a non-finite state")
            self.w_anchor = w0
            self._commit_compiled(io)
            self.n_substeps += n
            self.t = t + h
            self.n_steps += 1
            return
        saved = _get_step_values(self)   # what a step changes (cheap)
        try:
            # interface stiffness: the differential computed tau_in with the wheel side moving at
            # the speed it had at the start of the step plus the change dw_in it predicted (a linear
            # ramp; 0: constant speed); the shaft's c and d act on the deviation from that motion
            # (implicitly, inside this step)
            self.theta = 0.0
            self.w_anchor = w0 = self.w
            k = 1.0 if p.interfaceStiffness else 0.0
            c, d = k * p.halfShaft.c, k * p.halfShaft.d
            n = max(1, math.ceil(h / p.h_max - 1e-9))
            # the anchor speed at each sub-step's midpoint (the midpoint rule integrates the ramp)
            self._substeps(h / n, n, w0, dw_in, v0, Fz0, mu, c, d, tau_in, dFz, dv)
            self.n_substeps += n
            self.t = t + h
            self.n_steps += 1
            self._update_outputs(w0 + dw_in, v, Fz, mu)
            if not (math.isfinite(self.w + self.k + self.phi + self.shaft_tau + self.Fx)
                    or all(math.isfinite(x) for x in (self.w, self.k, self.phi, self.shaft_tau, self.Fx))):
                raise StepError(f"wheel: the step at t = {t:.6g} s gave a non-finite state")
        except BaseException:
            for k, x in zip(_WHEEL_STEP_KEYS, saved):
                setattr(self, k, x)
            raise

    @property
    def ATOMIC_STEP(self) -> bool:
        """True with shaftCoupling = "wheel": do_step leaves the state as it was when it raises
        and never commits a non-finite state (the FMU adapter then takes no snapshot)."""
        return getattr(self, "wheel_mode", False)

    def _native_plan(self, vk) -> "vehicle_kernel.WheelNative":
        """The native step's plan on the compiled kernel ``vk`` (:class:`NativeStepMixin`)."""
        return vehicle_kernel.WheelNative(vk, self)

    def _compiled(self, vk, hs: float, n: int, w_in: float, dw_in: float, v: float, Fz: float, mu: float,
                  c: float, d: float, tau0: float, dFz: float, dv: float, w_out: float, v_end: float,
                  Fz_end: float, tau_in: float, k_if: float, wheel_mode: bool) -> list:
        """:meth:`_substeps` and :meth:`_update_outputs` in C (:mod:`spurdiff.vehicle.kernel`; the same
        numbers bit for bit), the sub-steps' arguments as there (the twist from 0 with
        ``wheel_mode``, as :meth:`_do_step_wheel` starts it), the outputs' (``w_out``, ``v_end``,
        ``Fz_end``, ``tau_in``: shaftIn.tau, ``k_if``: the interface stiffness 0 or 1) as
        ``_update_outputs`` takes them. Returns the new theta, w, k, phi, the ledger and the outputs
        (io[28:47]); raises StepError as the reference does, nothing stored."""
        io = vk.io
        io[0:28] = (hs, n, w_in, dw_in, v, Fz, mu, c, d, tau0, dFz, dv, 1.0 if wheel_mode else 0.0,
                    0.0 if wheel_mode else self.theta, self.w, self.k, self.phi, self.work_flange, self.loss_damping, self.work_road,
                    self.loss_slip, self.loss_rolling, w_out, v_end, Fz_end, tau_in, k_if,
                    1.0 if wheel_mode else 0.0)
        status = vk.fn(vk.const, io)
        if status == 1:
            raise StepError(f"wheel: implicit step not solvable (slope {io[47]!r}); reduce wheelLoad.h_max")
        if status:
            raise StepError("wheel: Newton iteration did not converge; reduce wheelLoad.h_max")
        return io[28:47]

    def _commit_compiled(self, out: list) -> None:
        """Store what :meth:`_compiled` returned."""
        (self.theta, self.w, self.k, self.phi, self.work_flange, self.loss_damping, self.work_road,
         self.loss_slip, self.loss_rolling, self.shaft_tau, self.flange_tau, self.Fx, self.shaft_power,
         self.sur_a, self.sur_invJ, self.sur_dadw, self.sur_qrate, self.sur_ct, self.sur_rt) = out
        self.wheel_w = self.w
        self.slip = self.k

    def _substeps(self, hs: float, n: int, w_in: float, dw_in: float, v: float, Fz: float, mu: float,
                  c: float | None = None, d: float | None = None, tau0: float | None = None,
                  dFz: float = 0.0, dv: float = 0.0) -> None:
        """n implicit-midpoint steps of length hs; updates the state and the energy ledger.
        tau0 None (shaftCoupling = "torque"): the flange speed w_in held (dw_in unused).
        tau0 given (shaftCoupling = "wheel"): shaft torque tau0 + c theta + d (w_a - w), the
        twist-like theta measured from the anchor motion, whose speed at sub-step i's midpoint is
        w_a = w_in + dw_in (i + 1/2) / n; work booked at the wheel speed. dFz, dv (not both 0): the
        load and the wheel-centre speed ramp over the step from Fz, v at its start, taken at each
        sub-step's midpoint (the load not below 0). The state is worked on in locals and stored at
        the end (a StepError leaves it as it was)."""
        p = self.params
        torque_in = tau0 is not None
        if not torque_in:
            c, d = p.halfShaft.c, p.halfShaft.d
            tau0 = 0.0
        J, R = p.wheel.J, p.wheel.R
        ty = p.tyre
        B, C, E = ty.B, ty.C, ty.E
        kmax = ty.k_max
        D = mu * Fz
        Mrr0 = ty.f_rr * Fz * R
        inv_weps = 1.0 / ty.w_eps
        a = 0.5 * hs
        b = a / ty.sigma
        q = 1.0 + b * abs(v)
        dk_dw = b * R / q
        gs = J + a * (c * a + d)          # the linear part of g'
        bv = b * v
        atan, sin, cos, tanh = math.atan, math.sin, math.cos, math.tanh
        th0, w0, k0, phi_w = self.theta, self.w, self.k, self.phi
        work_flange, loss_damping = self.work_flange, self.loss_damping
        work_road, loss_slip, loss_rolling = self.work_road, self.loss_slip, self.loss_rolling
        wa = w_in
        ramp = dFz != 0.0 or dv != 0.0
        v0, Fz0 = v, Fz
        for i in range(n):
            if torque_in:
                wa = w_in + dw_in * (i + 0.5) / n
            if ramp:   # the inputs at this sub-step's midpoint (first-order hold)
                tm = (i + 0.5) * hs
                v = v0 + dv * tm
                Fz = Fz0 + dFz * tm
                Fz = Fz if Fz > 0.0 else 0.0
                D = mu * Fz
                Mrr0 = ty.f_rr * Fz * R
                q = 1.0 + b * abs(v)
                dk_dw = b * R / q
                bv = b * v
            # midpoint values as functions of the midpoint wheel speed wm (linear in wm):
            #   theta_m = th0 + a (wa - wm),  k_m = (k0 + b (R wm - v)) / q
            # residual g(wm) = J (wm - w0) - a (tau_m - R F_m - M_m) = 0, solved by Newton
            th_c = th0 + a * wa             # theta_m = th_c - a wm
            k_c = (k0 - bv) / q             # k_m = k_c + dk_dw wm
            wm = w0
            for _ in range(30):
                k = k_c + dk_dw * wm
                x = B * k
                phi = x - E * (x - atan(x))
                cat = C * atan(phi)
                F = D * sin(cat)
                dF = D * cos(cat) * C / (1.0 + phi * phi) * B * (1.0 - E + E / (1.0 + x * x))
                tnh = tanh(wm * inv_weps)
                tau = tau0 + c * (th_c - a * wm) + d * (wa - wm)
                g = J * (wm - w0) - a * (tau - R * F - Mrr0 * tnh)
                dg = gs + a * (R * dF * dk_dw + Mrr0 * (1.0 - tnh * tnh) * inv_weps)
                if not dg > 0.0:
                    raise StepError(f"wheel: implicit step not solvable (slope {dg!r}); reduce wheelLoad.h_max")
                dw = g / dg
                wm -= dw
                if abs(dw) <= 1e-13 * (1.0 + abs(wm)):
                    break
            else:
                raise StepError("wheel: Newton iteration did not converge; reduce wheelLoad.h_max")
            # final midpoint values at the converged wm
            th = th_c - a * wm
            k = k_c + dk_dw * wm
            x = B * k
            F = D * sin(C * atan(x - E * (x - atan(x))))
            M = Mrr0 * tanh(wm * inv_weps)
            tau = tau0 + c * th + d * (wa - wm)
            if torque_in:   # no shaft in this model: the work is done at the wheel
                work_flange += hs * tau * wm
                phi_w += hs * wm
            else:
                work_flange += hs * tau * wa
                loss_damping += hs * d * (wa - wm) * (wa - wm)
            work_road += hs * F * v
            loss_slip += hs * F * (R * wm - v)
            loss_rolling += hs * M * wm
            th0 = 2.0 * th - th0
            w0 = 2.0 * wm - w0
            k1 = 2.0 * k - k0
            k0 = kmax if k1 > kmax else (-kmax if k1 < -kmax else k1)
        self.theta, self.w, self.k, self.phi = th0, w0, k0, phi_w
        self.work_flange, self.loss_damping = work_flange, loss_damping
        self.work_road, self.loss_slip, self.loss_rolling = work_road, loss_slip, loss_rolling

    def _update_outputs(self, w_in: float, v: float, Fz: float, mu: float) -> None:
        p = self.params
        ty = p.tyre
        if self.wheel_mode:
            k = 1.0 if p.interfaceStiffness else 0.0
            self.shaft_tau = self.tau_in + k * (p.halfShaft.c * self.theta + p.halfShaft.d * (w_in - self.w))
            self.flange_tau = 0.0
        else:
            self.shaft_tau = p.halfShaft.c * self.theta + p.halfShaft.d * (w_in - self.w)
            self.flange_tau = -self.shaft_tau
        B, C, E = ty.B, ty.C, ty.E
        x = B * self.k
        phi = x - E * (x - math.atan(x))
        cat = C * math.atan(phi)
        self.Fx = mu * Fz * math.sin(cat)
        self.wheel_w = self.w
        self.slip = self.k
        self.shaft_power = self.shaft_tau * w_in
        self._update_surrogate(v, Fz, mu, x, phi, cat)

    def _update_surrogate(self, v: float, Fz: float, mu: float, x: float, phi: float, cat: float) -> None:
        """The wheel side's linear model about the present state for the coming step, with the
        inputs v, Fz, mu as held over the last step (see spurdiff.differential.shafts.WheelSurrogate): the wheel
        speed w and the tyre torque R Fx(k) linearized, the shaft torque the input. x, phi, cat:
        the Magic Formula's B k, phi and C atan(phi) at the present slip (from _update_outputs)."""
        p = self.params
        ty, R, J = p.tyre, p.wheel.R, p.wheel.J
        B, C, E = ty.B, ty.C, ty.E
        D = mu * Fz
        dF = D * math.cos(cat) * C / (1.0 + phi * phi) * B * (1.0 - E + E / (1.0 + x * x))
        Mrr0 = ty.f_rr * Fz * R
        tnh = math.tanh(self.w / ty.w_eps)
        kdot = (R * self.w - v - abs(v) * self.k) / ty.sigma
        if abs(self.k) >= ty.k_max and kdot * self.k > 0.0:
            kdot = 0.0   # at the slip limit: the slip stays there
        self.sur_a = -(R * self.Fx + Mrr0 * tnh) / J
        self.sur_invJ = 1.0 / J
        self.sur_dadw = -Mrr0 * (1.0 - tnh * tnh) / ty.w_eps / J
        self.sur_qrate = R * dF * kdot
        self.sur_ct = R * R * dF / ty.sigma if dF > 0.0 else 0.0
        self.sur_rt = abs(v) / ty.sigma

    # ------------------------------------------------------------------ energy
    @property
    def kinetic_energy(self) -> float:
        """Spin kinetic energy of the wheel, J."""
        return 0.5 * self.params.wheel.J * self.w * self.w

    @property
    def potential_energy(self) -> float:
        """Elastic energy of the half-shaft twist, J (0 with shaftCoupling = "wheel": the
        differential owns the shaft)."""
        if self.wheel_mode:
            return 0.0
        return 0.5 * self.params.halfShaft.c * self.theta * self.theta

    @property
    def energy_dissipated(self) -> float:
        """Shaft damping + tyre slip + rolling resistance since the start, J."""
        return self.loss_damping + self.loss_slip + self.loss_rolling

    @property
    def energy_residual(self) -> float:
        """work_flange - work_road - dKE - dPE - dissipated (J); zero up to rounding."""
        return (self.work_flange - self.work_road - (self.kinetic_energy - self.KE0)
                - (self.potential_energy - self.PE0) - self.energy_dissipated)

    # ------------------------------------------------------------------ state
    def get_state(self) -> dict[str, float]:
        """The full internal state (floats and ints; JSON-serialisable)."""
        return {k: getattr(self, k) for k in _STATE_KEYS}

    def set_state(self, state: dict[str, float]) -> None:
        """Restore a state from :meth:`get_state`; the continuation is then bit-identical."""
        for k in _STATE_KEYS:
            setattr(self, k, state[k])
        self.wheel_mode = self.params.shaftCoupling == "wheel"
        if self.kernel_note.startswith("python (not"):
            self._vk, self.kernel_note = vehicle_kernel.choose_wheel(self)
        self._ready = True


__all__ = ["SHAFT_COUPLINGS", "WheelLoad", "WheelLoadParams", "HalfShaftParams", "WheelParams"]
