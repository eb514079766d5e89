"""Planar vehicle body with axle-level lateral tyres, load transfer, and speed and steering control.

The model ``Vehicle.fmu`` wraps. Rear-wheel drive: the differential drives the unsteered rear
axle, whose two longitudinal tyre forces ``Fx_L``, ``Fx_R`` are inputs (from the WheelLoad
FMUs); the front axle is steered and undriven.

Frames and signs (ISO 8855): body x forward, y left, z up; yaw rate ``r`` and steering angle
``delta`` positive to the left; ``pathRadius > 0`` is a left turn. States: body-frame velocities
``v_x``, ``v_y``, yaw rate ``r``, heading ``psi``, position ``x``, ``y``; axle slip angles
``alpha_f``, ``alpha_r``; the filtered accelerations that drive load transfer ``a_xs_f``,
``a_y_f``; the controller integrators ``I_v`` (speed) and ``I_r`` (yaw rate).
The equations (body, lateral tyres, loads, steering and speed control) are in
:mod:`spurdiff.vehicle.car_rates`, beside the rate function that evaluates them; the parameters
in :mod:`spurdiff.vehicle.car_params`.

Integration: classical 4th-order Runge-Kutta in plain floats, sub-stepped so that each internal
step is at most ``h_max`` and at most ``sigma / |v_x|`` (the fastest mode is the slip-angle
relaxation, rate ``|v_x| / sigma``; the standstill tyre spring and the body modes are slower, about
40 rad/s), which keeps every mode well inside the RK4 stability region for any communication step.
Inputs are held over a step (zero-order hold), except that the command inputs ``speedTarget`` and
``pathRadius`` ramp from their values at the rates ``speedTargetRate``, ``pathRadiusRate`` (0, the
default: held; a scene gives the rate of its input table, sampled at the step's start as the input
is). The outputs include the rates of the rear wheel loads and wheel-centre speeds
(``rearLeft_dFz``, ``rearLeft_dvx``, ...): after a step their mean over it, ``(end - start) / h``
(at initialization the derivatives, 0 for the loads: the load transfer starts at its fixed
point), so that a WheelLoad stepped after the car ramps its inputs from the car's outputs at the
start of the step to those at its end (first-order hold, continuous; :mod:`spurdiff.vehicle.wheel`,
``rampAnchor = "end"``); a host that steps the car after the wheels gives them the linear
extrapolation of the last step instead (``rampAnchor = "start"``).

Sources: the single-track (bicycle) equations and slip angles of shared/docs/model-references.md,
extended to a planar body with both axles' longitudinal forces; the friction circle (Kamm) for
combined slip on the driven axle; parameter values and their sources in
``spurdiff/data/passenger_car.toml``.
"""
from __future__ import annotations

import math

from spurdiff.errors import ParameterError, StepError, require_finite, require_nonnegative, require_positive, require_range
from spurdiff.vehicle.tyre import slip_for_force_ratio
from spurdiff.vehicle.car_params import (G, STEER_ANGLE, STEER_PATH, BodyParams, LateralTyreParams,  # noqa: F401 (re-exported)
                             SpeedControlParams, SteeringParams, VehicleParams)
from spurdiff.vehicle.car_rates import make_rates
from spurdiff.vehicle import kernel as vehicle_kernel
from spurdiff.vehicle.native_plan import NativeStepMixin

_GRADE_MIN, _GRADE_MAX = -0.25 * math.pi, 0.25 * math.pi   # allowed road grade (rad)

_N = 12  # number of continuous states
_STATE_NAMES = ("vx", "vy", "r", "psi", "x", "y", "alpha_f", "alpha_r", "axs_f", "ay_f", "I_v", "I_r")
_OUTPUT_KEYS = (
    "rearLeft_vx", "rearRight_vx", "rearLeft_Fz", "rearRight_Fz", "frontAxle_Fz", "rearAxle_Fz",
    "speed", "yawRate", "ax", "ay", "driveTorque", "steering_angle", "Fy_front", "Fy_rear",
    "rearLeft_dvx", "rearRight_dvx", "rearLeft_dFz", "rearRight_dFz",
)
_INPUT_KEYS = ("rearLeft_Fx", "rearRight_Fx", "speedTarget", "pathRadius", "steering_angle_cmd", "grade", "mu",
               "speedTargetRate", "pathRadiusRate")


class Vehicle(NativeStepMixin):
    """Planar rear-wheel-drive vehicle; equations in :mod:`spurdiff.vehicle.car_rates`.

    Inputs (attributes, SI): ``rearLeft_Fx``, ``rearRight_Fx`` (N, rear tyre forces on the body),
    ``speedTarget`` (m/s), ``pathRadius`` (m, signed, 0 or inf = straight), ``steering_angle_cmd``
    (rad, used when ``steering.mode = 1``), ``grade`` (rad, uphill positive), ``mu`` (road friction).

    Outputs (attributes, end of the last step): ``rearLeft_vx``, ``rearRight_vx`` (m/s, wheel-centre
    velocity along the wheel, ``v_x -+ r t_r / 2``), ``rearLeft_Fz``, ``rearRight_Fz`` (N, >= 0),
    ``frontAxle_Fz``, ``rearAxle_Fz`` (N), ``speed`` (m/s, magnitude of the CG velocity), ``vx``,
    ``vy`` (m/s), ``yawRate`` (rad/s), ``ax``, ``ay`` (m/s^2, CG acceleration in the body frame),
    ``driveTorque`` (N m, at the axle), ``x``, ``y`` (m), ``psi`` (rad), ``steering_angle`` (rad),
    ``Fy_front``, ``Fy_rear`` (N, axle side forces in their wheel frames); ``rearLeft_dvx``,
    ``rearRight_dvx`` (m/s^2), ``rearLeft_dFz``, ``rearRight_dFz`` (N/s): the mean rates of the
    wheel-side outputs over the last step (at initialization their derivatives, 0 for the loads).

    Command-input rates (attributes): ``speedTargetRate`` (m/s^2), ``pathRadiusRate`` (m/s); the
    input ramps from its value at the step's start at this rate (0: held).
    """

    n_states = _N

    def __init__(self, params: VehicleParams | None = None):
        self.params = params if params is not None else VehicleParams.defaults()
        for k in _INPUT_KEYS + _OUTPUT_KEYS:   # zero until set, but the road's friction
            setattr(self, k, 0.0)
        self.mu = 1.0
        self.s = [0.0] * _N
        self._geo_key = None   # (pathRadius, grade, its sign, L) of the cached terms of _set_geometry
        # implementation of do_step (``solver.kernel``): auto (the compiled step,
        # spurdiff.vehicle.kernel, if it loads, else this Python reference) | compiled | python
        self.kernel = getattr(self.params, "kernel", "auto")   # params.kernel; may be set here
        self._vk = None
        self.kernel_note = "python (not initialized)"
        self._ready = False

    # ------------------------------------------------------------------ setup
    def initialize(self, t0: float = 0.0) -> None:
        """Validate parameters and inputs; set a consistent initial state; compute outputs at t0.

        Start: ``v_x = vx_start``, ``v_y = 0``, ``r = v_x / pathRadius`` (path steering) or 0;
        slip angles at their steady values for these speeds; load-transfer filters equal to the
        accelerations they produce (fixed point); speed integrator at the axle torque that holds
        ``v_x`` against the resistances at t0 (aero, rolling of both axles, grade).
        """
        p = self.params
        p.validate()
        self._load_inputs()
        b = p.vehicle
        vx = float(b.vx_start)
        r = vx * self._kappa if p.steering.mode == STEER_PATH else 0.0
        s = [vx, 0.0, r, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        if r != 0.0 and vx > 0.0:
            s[1], s[11] = self._steady_turn_start(vx, r)
        # steady slip angles for the start velocities and steering
        delta = self._rates_full(s)[1][0]
        cd, sd = math.cos(delta), math.sin(delta)
        vfy = s[1] + b.l_f * r
        vwx_f, vwy_f = vx * cd + vfy * sd, -vx * sd + vfy * cd
        amax = p.lateralTyre.alpha_max
        s[6] = _clamp(-vwy_f / abs(vwx_f), amax) if vwx_f != 0.0 else 0.0
        vwy_r = s[1] - (b.L - b.l_f) * r
        s[7] = _clamp(-vwy_r / abs(vx), amax) if vx != 0.0 else 0.0
        # load-transfer filters at their fixed point
        for _ in range(100):
            ex = self._rates_full(s)[1]
            axs, ay = ex[5], ex[4]
            change = abs(axs - s[8]) + abs(ay - s[9])
            s[8], s[9] = axs, ay
            if change <= 1e-12 * (1.0 + abs(axs) + abs(ay)):
                break
        # speed integrator: the axle torque that holds v_x now
        ex = self._rates_full(s)[1]
        F_other = b.m * ex[3] - ex[6]                  # body-x forces other than the rear drive
        Fxr_hold = -F_other - b.m * s[1] * s[2]        # rear drive force giving dv_x/dt = 0
        rr_rear = b.f_rr * ex[2] * math.tanh(vx / b.v_rr)
        sc = p.speedControl
        s[10] = min(max(b.R_wheel * (Fxr_hold + rr_rear), sc.driveTorqueMin), sc.driveTorqueMax)
        self.s = s
        self.t = float(require_finite("t0", t0))
        self.n_steps = 0
        self.n_substeps = 0
        self._update_outputs()
        self._vk, self.kernel_note = vehicle_kernel.choose_car(self)
        self._ready = True

    def _steady_turn_start(self, vx: float, r: float) -> tuple[float, float]:
        """Side velocity and steering integrator of the steady turn at (vx > 0, r), from the axle
        side forces ``m a_y l_r / L`` (front) and ``m a_y l_f / L`` (rear) with ``a_y = v_x r`` and the
        static loads; (0, 0) if that turn is beyond 95 % of the grip."""
        p = self.params
        b, lt = p.vehicle, p.lateralTyre
        lr = b.L - b.l_f
        mu = self._mu
        Wn = b.m * G * self._cos_g
        if mu <= 0.0 or Wn <= 0.0:
            return 0.0, 0.0
        ay = vx * r
        ratio_f = b.m * ay * lr / b.L / (mu * Wn * lr / b.L)
        ratio_r = b.m * ay * b.l_f / b.L / (mu * Wn * b.l_f / b.L)
        top = 0.95 * (1.0 if lt.C > 1.0 else math.sin(0.5 * math.pi * lt.C))
        if abs(ratio_f) >= top or abs(ratio_r) >= top:
            return 0.0, 0.0
        alpha_r = slip_for_force_ratio(ratio_r, lt.B, lt.C, lt.E)
        alpha_f = slip_for_force_ratio(ratio_f, lt.B, lt.C, lt.E)
        vy = lr * r - vx * alpha_r
        delta = math.atan((vy + b.l_f * r) / vx) + math.atan(alpha_f)
        return vy, delta - self._delta_ff

    def _load_inputs(self) -> None:
        """Validate the inputs (all before changing anything) and cache what the rate function
        needs over a step (held, or ramping at the command inputs' rates)."""
        FxL, FxR, vref, R, dcmd, gr, mu = (self.rearLeft_Fx, self.rearRight_Fx, self.speedTarget, self.pathRadius,
                                           self.steering_angle_cmd, self.grade, self.mu)
        if (math.isfinite(FxL + FxR + vref + dcmd + gr + mu) and R == R and mu >= 0.0 and _GRADE_MIN <= gr <= _GRADE_MAX
                and FxL.__class__ is FxR.__class__ is vref.__class__ is R.__class__ is dcmd.__class__ is gr.__class__
                is mu.__class__ is float):
            # the usual case: all valid floats (else the checks below name the bad one); the terms of
            # path radius and grade computed again only when they change
            self._dvref, self._dR = self._input_rates()   # (checked before anything is stored)
            self._FxL, self._FxR, self._vref, self._dcmd, self._mu = FxL, FxR, vref, dcmd, mu
            key = (R, gr, math.copysign(1.0, gr), self.params.vehicle.L)   # (the sign of a zero grade too)
            if key != self._geo_key:
                self._set_geometry(R, gr)
                self._geo_key = key
            return
        FxL = require_finite("rearLeft.Fx", self.rearLeft_Fx)
        FxR = require_finite("rearRight.Fx", self.rearRight_Fx)
        vref = require_finite("speedTarget", self.speedTarget)
        R = float(self.pathRadius)
        if R != R:
            raise ParameterError("pathRadius", self.pathRadius, "a number (0 or +-inf: straight)")
        dcmd = require_finite("steeringAngleCommand", self.steering_angle_cmd)
        gr = require_range("grade", self.grade, _GRADE_MIN, _GRADE_MAX)
        mu = require_nonnegative("mu", self.mu)
        rates = self._input_rates()
        self._FxL, self._FxR, self._vref, self._dcmd, self._mu = FxL, FxR, vref, dcmd, mu
        self._dvref, self._dR = rates
        self._set_geometry(R, gr)
        self._geo_key = None

    def _input_rates(self) -> tuple[float, float]:
        """The rates of the command inputs over the coming step (speedTargetRate, pathRadiusRate;
        0: held), validated."""
        dv, dR = self.speedTargetRate, self.pathRadiusRate
        if math.isfinite(dv + dR) and dv.__class__ is dR.__class__ is float:
            return dv, dR
        return require_finite("speedTargetRate", dv), require_finite("pathRadiusRate", dR)

    def _set_geometry(self, R: float, gr: float) -> None:
        """The terms of the path radius R and the grade gr the rate function uses."""
        self._R = R
        self._kappa = 0.0 if (R == 0.0 or math.isinf(R)) else 1.0 / R
        self._sin_g, self._cos_g = math.sin(gr), math.cos(gr)
        self._delta_ff = math.atan(self.params.vehicle.L * self._kappa)

    # ------------------------------------------------------------------ stepping
    ATOMIC_STEP = True   # do_step commits nothing when it raises or when the result is not finite

    def _make_rates(self):
        """The model's rate function for the inputs cached by :meth:`_load_inputs`
        (:func:`spurdiff.vehicle.car_rates.make_rates`)."""
        return make_rates(self)

    def _rates_full(self, s, rates=None, tau: float = 0.0) -> tuple:
        """The derivatives and the force/acceleration values of ``rates(..., full=True)`` at the
        state list ``s``, ``tau`` into the step (``rates``: the step's rate function, else one for
        the cached inputs)."""
        rates = rates or self._make_rates()
        return rates(s[0], s[1], s[2], s[3], s[6], s[7], s[8], s[9], s[10], s[11], tau, full=True)

    def do_step(self, t: float, h: float) -> None:
        """Advance from t to t + h with the inputs held (RK4 sub-steps). Atomic: raises
        ParameterError for bad inputs and StepError for a non-finite result, the state and the
        outputs then as before the call."""
        if not self._ready:
            raise StepError("do_step called before initialize")
        if not (h.__class__ is float and 0.0 < h < math.inf):
            h = require_positive("communicationStepSize", h)
        self._load_inputs()
        if self._vk is not None:
            self._step_compiled(self._vk, t, h)
            return
        p = self.params
        h_lim = p.vehicle.h_max
        vx = abs(self.s[0])
        if vx * h_lim > p.lateralTyre.sigma:
            h_lim = p.lateralTyre.sigma / vx
        n = max(1, math.ceil(h / h_lim - 1e-9))
        hs = h / n
        hh = 0.5 * hs
        h6 = hs / 6.0
        amax = p.lateralTyre.alpha_max
        s = self.s
        rates = self._make_rates()
        for j in range(n):
            vx, vy, r, psi, _x, _y, af, ar, axf, ayf, Iv, Ir = s
            tj = j * hs            # the sub-step's time into the step (the command inputs' ramps)
            k1 = rates(vx, vy, r, psi, af, ar, axf, ayf, Iv, Ir, tj)
            k2 = rates(vx + hh * k1[0], vy + hh * k1[1], r + hh * k1[2], psi + hh * k1[3], af + hh * k1[6],
                       ar + hh * k1[7], axf + hh * k1[8], ayf + hh * k1[9], Iv + hh * k1[10], Ir + hh * k1[11],
                       tj + hh)
            k3 = rates(vx + hh * k2[0], vy + hh * k2[1], r + hh * k2[2], psi + hh * k2[3], af + hh * k2[6],
                       ar + hh * k2[7], axf + hh * k2[8], ayf + hh * k2[9], Iv + hh * k2[10], Ir + hh * k2[11],
                       tj + hh)
            k4 = rates(vx + hs * k3[0], vy + hs * k3[1], r + hs * k3[2], psi + hs * k3[3], af + hs * k3[6],
                       ar + hs * k3[7], axf + hs * k3[8], ayf + hs * k3[9], Iv + hs * k3[10], Ir + hs * k3[11],
                       tj + hs)
            # s + h/6 (k1 + 2 (k2 + k3) + k4), the slip angles limited to +-alpha_max
            af = af + h6 * (k1[6] + 2.0 * (k2[6] + k3[6]) + k4[6])
            ar = ar + h6 * (k1[7] + 2.0 * (k2[7] + k3[7]) + k4[7])
            s = [vx + h6 * (k1[0] + 2.0 * (k2[0] + k3[0]) + k4[0]),
                 vy + h6 * (k1[1] + 2.0 * (k2[1] + k3[1]) + k4[1]),
                 r + h6 * (k1[2] + 2.0 * (k2[2] + k3[2]) + k4[2]),
                 psi + h6 * (k1[3] + 2.0 * (k2[3] + k3[3]) + k4[3]),
                 _x + h6 * (k1[4] + 2.0 * (k2[4] + k3[4]) + k4[4]),
                 _y + h6 * (k1[5] + 2.0 * (k2[5] + k3[5]) + k4[5]),
                 amax if af > amax else (-amax if af < -amax else af),
                 amax if ar > amax else (-amax if ar < -amax else ar),
                 axf + h6 * (k1[8] + 2.0 * (k2[8] + k3[8]) + k4[8]),
                 ayf + h6 * (k1[9] + 2.0 * (k2[9] + k3[9]) + k4[9]),
                 Iv + h6 * (k1[10] + 2.0 * (k2[10] + k3[10]) + k4[10]),
                 Ir + h6 * (k1[11] + 2.0 * (k2[11] + k3[11]) + k4[11])]
        out = self._outputs(s, rates, h)
        if not math.isfinite(sum(s) + sum(out)) and not all(math.isfinite(x) for x in s + list(out)):
            raise StepError(f"vehicle: the step at t = {t:.6g} s gave a non-finite state; state kept")
        self.s = s
        self.n_substeps += n
        self.t = t + h
        self.n_steps += 1
        # the rates of the wheel-side outputs: their mean over this step (a WheelLoad stepped after
        # the car then ramps its inputs from the car's outputs at the step's start to those at its end)
        out = out[:-4] + ((out[0] - self.rearLeft_vx) / h, (out[1] - self.rearRight_vx) / h,
                          (out[2] - self.rearLeft_Fz) / h, (out[3] - self.rearRight_Fz) / h)
        self._set_outputs(out)

    def _step_compiled(self, vk, t: float, h: float) -> None:
        """The step of :meth:`do_step` in C (:mod:`spurdiff.vehicle.kernel`; the same numbers bit for
        bit), the inputs loaded and checked; atomic as the reference."""
        io = vk.io
        io[0:12] = self.s
        io[12:29] = (h, self._FxL, self._FxR, self._vref, self._dcmd, self._mu, self._dvref, self._dR, self._R,
                     self._kappa, self._delta_ff, self._sin_g, self._cos_g, self.rearLeft_vx, self.rearRight_vx,
                     self.rearLeft_Fz, self.rearRight_Fz)
        bad = vk.fn(vk.const, io)
        s = io[29:41]
        out = io[41:59]
        if bad:
            raise StepError(f"vehicle: the step at t = {t:.6g} s gave a non-finite state; state kept")
        self.s = s
        self.n_substeps += int(io[59])
        self.t = t + h
        self.n_steps += 1
        self._set_outputs(out)

    def _native_plan(self, vk) -> "vehicle_kernel.CarNative":
        """The native step's plan on the compiled kernel ``vk`` (:class:`NativeStepMixin`)."""
        return vehicle_kernel.CarNative(vk, (_GRADE_MIN, _GRADE_MAX), _OUTPUT_KEYS)

    def _update_outputs(self) -> None:
        self._set_outputs(self._outputs(self.s))

    def _outputs(self, s, rates=None, tau: float = 0.0) -> tuple:
        """The output values (in the order of ``_OUTPUT_KEYS``) for the state ``s``, ``tau`` into
        the step of ``rates``. The rates of the wheel-side outputs are their derivatives for the
        initialization (the load-transfer filters start at their fixed point: the loads' are 0);
        after a step :meth:`do_step` replaces them by the step's mean rates."""
        p = self.params
        b = p.vehicle
        d, (delta, Fz_f, Fz_r, ax, ay, _, _, Fyf, Fyr, u) = self._rates_full(s, rates, tau)
        vx, vy, r = s[0], s[1], s[2]
        half_t = 0.5 * b.trackRear
        dFz = p.vehicle.rollStiffnessShareRear * b.m * s[9] * b.h_cg / b.trackRear
        half = 0.5 * Fz_r
        dFz = half if dFz > half else (-half if dFz < -half else dFz)
        sc = p.speedControl
        return (vx - r * half_t, vx + r * half_t, half - dFz, half + dFz, Fz_f, Fz_r,
                math.sqrt(vx * vx + vy * vy), r, ax, ay, min(max(u, sc.driveTorqueMin), sc.driveTorqueMax),
                delta, Fyf, Fyr, d[0] - d[2] * half_t, d[0] + d[2] * half_t, 0.0, 0.0)

    def _set_outputs(self, out: tuple) -> None:
        (self.rearLeft_vx, self.rearRight_vx, self.rearLeft_Fz, self.rearRight_Fz, self.frontAxle_Fz,
         self.rearAxle_Fz, self.speed, self.yawRate, self.ax, self.ay, self.driveTorque,
         self.steering_angle, self.Fy_front, self.Fy_rear, self.rearLeft_dvx, self.rearRight_dvx,
         self.rearLeft_dFz, self.rearRight_dFz) = out

    # ------------------------------------------------------------------ convenience
    @property
    def vx(self) -> float:
        return self.s[0]

    @property
    def vy(self) -> float:
        return self.s[1]

    @property
    def x(self) -> float:
        return self.s[4]

    @property
    def y(self) -> float:
        return self.s[5]

    @property
    def psi(self) -> float:
        return self.s[3]

    @property
    def kinetic_energy(self) -> float:
        """Translational + yaw kinetic energy of the body, J."""
        b = self.params.vehicle
        vx, vy, r = self.s[0], self.s[1], self.s[2]
        return 0.5 * b.m * (vx * vx + vy * vy) + 0.5 * b.Iz * r * r

    # ------------------------------------------------------------------ state
    def get_state(self) -> dict[str, float]:
        """The full internal state (floats and ints; JSON-serialisable)."""
        st = {name: v for name, v in zip(_STATE_NAMES, self.s)}
        st.update(t=self.t, n_steps=self.n_steps, n_substeps=self.n_substeps)
        for k in _INPUT_KEYS + _OUTPUT_KEYS:
            st[k] = getattr(self, k)
        return st

    def set_state(self, state: dict[str, float]) -> None:
        """Restore a state from :meth:`get_state`; the continuation is then bit-identical."""
        self.s = [state[name] for name in _STATE_NAMES]
        self.t, self.n_steps, self.n_substeps = state["t"], state["n_steps"], state["n_substeps"]
        for k in _INPUT_KEYS + _OUTPUT_KEYS:
            setattr(self, k, state[k])
        self._load_inputs()
        if self.kernel_note.startswith("python (not"):
            self._vk, self.kernel_note = vehicle_kernel.choose_car(self)
        self._ready = True


def _clamp(x: float, lim: float) -> float:
    return lim if x > lim else (-lim if x < -lim else x)


__all__ = [
    "Vehicle", "VehicleParams", "BodyParams", "LateralTyreParams", "SteeringParams", "SpeedControlParams",
    "STEER_PATH", "STEER_ANGLE", "G",
]
