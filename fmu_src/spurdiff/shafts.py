"""Half-shafts owned by the differential: the stiff sun/shaft mode integrated inside the step.

Why: the suns' small inertia (``inertia.differential`` about 6.8e-3 kg m^2) on two 8,000 N m/rad
half-shafts is an anti-symmetric mode at about 1,530 rad/s. Split across two FMUs (torque in,
speed out on the differential) and coupled explicitly, it limits the communication step to about
0.49 ms. Here the compliance is part of the differential's step, integrated implicitly, so the
coupling to the wheels carries only the wheel mode (about 100 rad/s): wheel-side angle and speed
in, shaft torque out (``shaftCoupling = "wheel"``).

Model (each side, Modelica signs, ``phi_s`` the sun flange angle, ``phi_w`` the wheel-side angle)::

    theta = phi_s - phi_w - theta_off             twist (rad)
    tau   = c theta + d dtheta/dt                 shaft torque ON THE WHEEL (drives it forward)
    sun flange torque (input of the inner model) = -tau

Integration over a communication step ``h`` in ``n = ceil(h / h_max)`` sub-steps ``hs`` (a sub-step
whose Newton iteration below does not converge is done as two halves, down to 1/64). The wheel
side moves over the step as the wheel's reported linear model predicts (the interface surrogate,
:class:`WheelSurrogate`: wheel speed ``w`` and tyre torque deviation ``q`` about the communication
point, the shaft torque ``tau`` on the wheel an input)::

    dw/dt = a_free + (tau - q) / J + dadw (w - w_k)
    dq/dt = q_rate + c_t (w - w_k) - r_t q,      q(t_k) = 0

integrated by the implicit midpoint rule (as the wheel integrates itself), so the wheel-side angle
change of a sub-step is affine in the shaft torque. All zero (the defaults, nothing connected):
the wheel side turns at its speed of the communication point, ``phi_w(t) = phi_w,k + w_w,k (t -
t_k)`` (the linear extrapolation). In each sub-step the sun torques ``T = (T_L, T_R)`` are
constant and solve (backward Euler in the twist; the shaft torque on the wheel is ``-T``)::

    T + c (theta_0 + dtheta(T)) + d dtheta(T) / hs = 0,   dtheta(T) = dphi_s(T) - dphi_w(-T)

where ``dphi_s(T)`` is the inner model's (rigid, compliant or contact) sun-angle change over the
sub-step with the torques ``T`` held. The inner model's response is affine in ``T`` within a
friction/contact mode (exactly so at rigid), and so is the wheel side's: a Newton iteration with a
finite-difference Jacobian, refreshed by Broyden updates and recomputed when a mode change slows
it, converges in two corrections in the usual case (three inner steps per sub-step).

Backward Euler in the twist is L-stable: the stiff mode is damped for any ``hs`` and never rings
(the physical mode is about critically damped anyway). It is passive: the twist energy changes by
``c theta_1 dtheta - c dtheta^2 / 2``, so the scheme dissipates ``c dtheta^2 / 2`` per sub-step on
top of the damper's ``d dtheta^2 / hs``; both are booked in ``shaft_loss`` and the energy balance
closes to rounding. The price is first order in ``hs`` during fast transients of the twist; in
steady driving the twist is quasi-static and the step does not matter (docs/accuracy.md).

Angles: at the start of each step the twist is re-anchored on the wheel-side angle input
(``theta = phi_s - phi_w,in - theta_off``, ``theta_off`` fixed at initialization from
``phi_rel_start``), so it does not drift, whatever the step sequence, as long as the wheel-side
inputs are the values at the communication point (Jacobi, or Gauss-Seidel with the differential
stepped before the wheels). The spring-energy change of that re-anchoring is booked as work done
at the wheel side. Output: the shaft torque on each wheel as the mean over the last step
(``tau_mean``: the work it does on the linearly moving wheel side equals that torque times the
wheel's angle change), and the value at the end of the step.
"""
from __future__ import annotations

import math
import operator
from dataclasses import dataclass, field

from .datafile import differential_default as _d
from .errors import ParameterError, StepError, require_finite, require_nonnegative, require_positive

SHAFT_COUPLINGS = ("torque", "wheel")

_STATE_KEYS = (
    "t", "off_L", "off_R", "theta_L", "theta_R", "T_L", "T_R", "tau_mean_L", "tau_mean_R",
    "tau_end_L", "tau_end_R", "work_wheels", "work_suns", "shaft_loss", "PE0_shaft", "n_steps",
    "n_substeps", "n_evals", "n_jacobians", "n_halvings", "jac", "dw_pred_L", "dw_pred_R",
)
_get_own_values = operator.attrgetter(*_STATE_KEYS)


@dataclass
class ShaftParams:
    """One half-shaft: c torsional stiffness (N m/rad), d damping (N m s/rad), phi_rel_start twist
    at the start (rad)."""

    c: float = _d("leftShaft.c")      # defaults: spurdiff/data/differential.toml
    d: float = _d("leftShaft.d")
    phi_rel_start: float = _d("leftShaft.phi_rel_start")

    def validate(self, name: str) -> None:
        c = require_positive(f"{name}.c", self.c)
        if c > 1e9:
            raise ParameterError(f"{name}.c", self.c, "between 0 and 1e9 N m/rad")
        d = require_nonnegative(f"{name}.d", self.d)
        if d > 1e6:
            raise ParameterError(f"{name}.d", self.d, "between 0 and 1e6 N m s/rad")
        th = require_finite(f"{name}.phi_rel_start", self.phi_rel_start)
        if abs(th) > 1.0:
            raise ParameterError(f"{name}.phi_rel_start", self.phi_rel_start, "between -1 and 1 rad")


@dataclass
class ShaftsParams:
    """Both half-shafts and the largest sub-step h_max (s) of the implicit shaft integration
    (5 ms: one sub-step at the vehicle scenes' step; measured: the steady results as with 0.25 ms)."""

    left: ShaftParams = field(default_factory=lambda: ShaftParams(**_d("leftShaft")))
    right: ShaftParams = field(default_factory=lambda: ShaftParams(**_d("rightShaft")))
    h_max: float = _d("shafts.h_max")

    def validate(self) -> None:
        self.left.validate("leftShaft")
        self.right.validate("rightShaft")
        h = require_positive("shafts.h_max", self.h_max)
        if h > 0.1:
            raise ParameterError("shafts.h_max", self.h_max, "between 0 and 0.1 s")


@dataclass
class WheelSurrogate:
    """The wheel side's linear model over the coming step, reported by the wheel at the
    communication point (WheelLoad's ``wheel.aFree`` ... outputs; see the module docstring).
    a_free (rad/s^2): wheel acceleration without the shaft torque; inv_J (1/(kg m^2)): its change
    per N m of shaft torque; dadw (1/s): per rad/s of wheel speed; q_rate (N m/s): rate of the tyre
    torque; c_t (N m/rad): its rate's change per rad/s of wheel speed; r_t (1/s): its
    relaxation rate. All zero: the wheel side keeps its speed (the linear extrapolation)."""

    a_free: float = 0.0
    inv_J: float = 0.0
    dadw: float = 0.0
    q_rate: float = 0.0
    c_t: float = 0.0
    r_t: float = 0.0

    FIELDS = ("a_free", "inv_J", "dadw", "q_rate", "c_t", "r_t")

    def checked(self, side: str) -> "WheelSurrogate":
        # the usual case in one expression (a NaN fails every comparison, an infinity the sum)
        if (math.isfinite(self.a_free + self.inv_J + self.dadw + self.q_rate + self.c_t + self.r_t)
                and self.inv_J >= 0.0 and self.c_t >= 0.0 and self.r_t >= 0.0 and self.dadw <= 0.0):
            return self
        names = ("aFree", "invJ", "dadw", "tyreTorqueRate", "tyreStiffness", "tyreRelaxation")
        for f, n in zip(self.FIELDS, names):
            require_finite(f"{side}Wheel.{n}", getattr(self, f))
        for f, n in (("inv_J", "invJ"), ("c_t", "tyreStiffness"), ("r_t", "tyreRelaxation")):
            require_nonnegative(f"{side}Wheel.{n}", getattr(self, f))
        if self.dadw > 0.0:
            raise ParameterError(f"{side}Wheel.dadw", self.dadw, "<= 0 (a passive wheel)")
        return self

    def midpoint(self, hs: float, x0: tuple[float, float]) -> tuple[float, float, float, float]:
        """One implicit-midpoint sub-step of the linear model from x0 = (w - w_k, q): the end values
        affine in the shaft torque tau: (dw_0, dw_tau, q_0, q_tau), dw_1 = dw_0 + dw_tau tau."""
        a = 0.5 * hs
        # (I - a A) x1 = (I + a A) x0 + hs (b + B tau), A = [[dadw, -inv_J], [c_t, -r_t]], B = (inv_J, 0)
        m11, m12, m21, m22 = 1.0 - a * self.dadw, a * self.inv_J, -a * self.c_t, 1.0 + a * self.r_t
        w0, q0 = x0
        rhs1 = w0 + a * (self.dadw * w0 - self.inv_J * q0) + hs * self.a_free
        rhs2 = q0 + a * (self.c_t * w0 - self.r_t * q0) + hs * self.q_rate
        det = m11 * m22 - m12 * m21   # >= 1 for the allowed signs
        w_c = (m22 * rhs1 - m12 * rhs2) / det
        q_c = (m11 * rhs2 - m21 * rhs1) / det
        w_t = m22 * hs * self.inv_J / det
        q_t = -m21 * hs * self.inv_J / det
        return w_c, w_t, q_c, q_t


class _NotConverged(StepError):
    """The sub-step's Newton iteration did not converge (the step is then halved)."""


class ShaftedDifferential:
    """A differential model (rigid or mesh) with its two half-shafts; see the module docstring.

    Inputs (attributes, SI): ``wheelL_phi``, ``wheelL_w``, ``wheelR_phi``, ``wheelR_w`` (wheel-side
    angle and speed of each shaft), ``wheelL_model``, ``wheelR_model`` (:class:`WheelSurrogate`,
    the wheel side's linear model; zero: constant speed), ``w_ref`` and ``tau_c`` (the carrier,
    forwarded to the inner model). Outputs: ``tau_mean_L/R`` (shaft torque on the wheel, mean over
    the last step), ``dw_pred_L/R`` (the wheel-side speed change over the last step the torques
    were computed for),
    ``tau_end_L/R`` (at the end of the step), ``theta_L/R`` (twist), and everything of the inner
    model (read through attribute delegation: ``w_L``, ``phi_L``, ``locking_torque``...).
    ``do_step`` is atomic: on any error the state is as before the call.
    """

    ATOMIC_STEP = True
    _rigid = False   # the inner model is the rigid one (set by initialize)

    def __init__(self, inner, params: ShaftsParams | None = None):
        self.__dict__["inner"] = inner
        self.shafts = params if params is not None else ShaftsParams()
        self.wheelL_phi = self.wheelL_w = self.wheelR_phi = self.wheelR_w = 0.0
        self.wheelL_model = WheelSurrogate()
        self.wheelR_model = WheelSurrogate()
        self._ready = False

    # inputs of the inner model pass through; every other unknown attribute (parameters, geometry)
    # is the inner model's (the outputs are explicit: INNER_OUTPUTS below)
    def __getattr__(self, name):
        return getattr(self.__dict__["inner"], name)

    @property
    def w_ref(self) -> float:
        return self.inner.w_ref

    @w_ref.setter
    def w_ref(self, v: float) -> None:
        self.inner.w_ref = v

    @property
    def tau_c(self) -> float:
        return self.inner.tau_c

    @tau_c.setter
    def tau_c(self, v: float) -> None:
        self.inner.tau_c = v

    # ------------------------------------------------------------------ setup
    def _wheel_inputs(self) -> tuple[float, float, float, float]:
        pL, wL, pR, wR = self.wheelL_phi, self.wheelL_w, self.wheelR_phi, self.wheelR_w
        if math.isfinite(pL + wL + pR + wR) and pL.__class__ is wL.__class__ is pR.__class__ is wR.__class__ is float:
            return pL, wL, pR, wR   # the usual case; otherwise the checks below name the bad input
        return (require_finite("leftWheel.phi", self.wheelL_phi), require_finite("leftWheel.w", self.wheelL_w),
                require_finite("rightWheel.phi", self.wheelR_phi), require_finite("rightWheel.w", self.wheelR_w))

    def initialize(self, t0: float = 0.0) -> None:
        """Validate, initialize the inner model with the start twists' torques, set the state."""
        sp = self.shafts
        sp.validate()
        pL, wL, pR, wR = self._wheel_inputs()
        inner = self.inner
        cL, dL, cR, dR = sp.left.c, sp.left.d, sp.right.c, sp.right.d
        thL, thR = float(sp.left.phi_rel_start), float(sp.right.phi_rel_start)
        # the inner model's start speeds are needed for the damper part: initialize twice
        inner.tau_L = inner.tau_R = 0.0
        inner.initialize(t0)
        for _ in range(2):
            inner.tau_L = -(cL * thL + dL * (inner.w_L - wL))
            inner.tau_R = -(cR * thR + dR * (inner.w_R - wR))
            inner.initialize(t0)
        self.T_L, self.T_R = inner.tau_L, inner.tau_R
        self.off_L = inner.phi_L - pL - thL
        self.off_R = inner.phi_R - pR - thR
        self.theta_L, self.theta_R = thL, thR
        self.tau_end_L = self.tau_mean_L = -self.T_L
        self.tau_end_R = self.tau_mean_R = -self.T_R
        self.dw_pred_L = self.dw_pred_R = 0.0
        self.t = float(t0)
        self.work_wheels = self.work_suns = self.shaft_loss = 0.0
        self.PE0_shaft = self.shaft_energy
        self.n_steps = self.n_substeps = self.n_evals = self.n_jacobians = self.n_halvings = 0
        self._lr = (sp.left, sp.right)
        self._rigid = getattr(inner, "mesh_model", None) == "rigid"
        self.jac = {}   # mode key -> the inner model's normalized sun-angle sensitivity (see _substep)
        # how closely the residual can be solved: to rounding for the rigid model (exact
        # integration), to the integrator's relative tolerance for the mesh models
        mesh = getattr(inner, "mesh", None)
        self._accept = max(1e-6, 10.0 * float(mesh.tolerance)) if mesh is not None else 1e-6
        self._ready = True

    # ------------------------------------------------------------------ stepping
    def _eval(self, snap: dict, t: float, hs: float, TL: float, TR: float,
              phiL0: float, phiR0: float, dwL: float, dwR: float, sL: float = 0.0,
              sR: float = 0.0, restore: bool = True) -> tuple[float, float, float, float]:
        """Residuals (N m) and twist changes for sun torques (TL, TR) held over one sub-step; the
        wheel-side angle changes are dwL + sL (-TL) and dwR + sR (-TR) (affine in the torque).
        restore False: the inner model is in the state ``snap`` already (not restored)."""
        inner = self.inner
        if restore:
            inner.set_state(snap)
        inner.tau_L, inner.tau_R = TL, TR
        inner.do_step(t, hs)
        self.n_evals += 1
        left, right = self._lr
        dthL = inner.phi_L - phiL0 - (dwL - sL * TL)
        dthR = inner.phi_R - phiR0 - (dwR - sR * TR)
        rL = TL + left.c * (self.theta_L + dthL) + left.d * dthL / hs
        rR = TR + right.c * (self.theta_R + dthR) + right.d * dthR / hs
        return rL, rR, dthL, dthR

    def _jacobian(self, snap, t, hs, TL, TR, r, args, mode) -> list[float]:
        """Finite-difference Jacobian of the residuals at (TL, TR) on the piece (mode) of the point
        (the response is affine within a mode of the rigid model): each column from a difference
        of 1e-3 relative (smaller ones lose digits to the absolute angles), on whichever side
        stays on the point's piece, down to 1e-7 relative near a stick-slip kink."""
        cols = []
        base = 1e-3 * (1.0 + abs(TL) + abs(TR))
        for j in (0, 1):
            for dT in (base, -base, 1e-2 * base, -1e-2 * base, 1e-4 * base, -1e-4 * base):
                e = self._eval(snap, t, hs, TL + (dT if j == 0 else 0.0), TR + (dT if j == 1 else 0.0), *args)
                if self._mode(snap) == mode:
                    break
            cols.append(((e[0] - r[0]) / dT, (e[1] - r[1]) / dT))
        self.n_jacobians += 1
        return [cols[0][0], cols[1][0], cols[0][1], cols[1][1]]

    def _mode(self, snap: dict) -> str:
        """The inner model's mode over the last evaluated sub-step: the slip direction at its end
        and whether it switched inside (a rigid model; the mesh models have one key)."""
        inner = self.inner
        sd = getattr(inner, "slip_dir", None)
        if sd is None:
            return "m"
        switched = inner.n_mode_switches != snap.get("n_mode_switches", inner.n_mode_switches)
        # the key f"{sd:+.0f}" plus "x" if switched; the usual directions without formatting
        key = "+1" if sd == 1.0 else ("-1" if sd == -1.0 else f"{sd:+.0f}")
        return key + "x" if switched else key

    def _substep(self, t: float, hs: float, wL: float, wR: float, xL: tuple, xR: tuple,
                 mL: WheelSurrogate, mR: WheelSurrogate, snap: dict) -> tuple[float, float, float, float]:
        """One sub-step from the inner model's state ``snap`` (its present state); wL, wR the
        wheel-side speeds at the communication point, xL, xR the wheel sides' deviations (dw, q)
        from it at the start of the sub-step (updated in place)."""
        inner = self.inner
        phiL0, phiR0 = inner.phi_L, inner.phi_R
        # wheel-side angle change, trapezoidal in the midpoint rule's speeds: affine in its torque
        pL = mL.midpoint(hs, xL)
        pR = mR.midpoint(hs, xR)
        a = 0.5 * hs
        args = (phiL0, phiR0, hs * wL + a * (xL[0] + pL[0]), hs * wR + a * (xR[0] + pR[0]),
                a * pL[1], a * pR[1])
        sp = self.shafts
        # The Jacobian J = I + diag(k) (S + diag(s)) with k = c + d / hs, s the wheel sides' angle
        # change per N m (known) and S the inner model's sun-angle change per N m, S = hs^2 S_n with
        # S_n constant within a mode of the rigid model (constant accelerations). S_n is kept per
        # mode (self.jac: mode key -> S_n, refreshed by Broyden updates and finite differences), so
        # the usual sub-step needs the first evaluation, one correction and its check.
        kL, kR = sp.left.c + sp.left.d / hs, sp.right.c + sp.right.d / hs
        sL, sR, h2 = args[4], args[5], hs * hs

        def J_of(Sn):
            return [1.0 + kL * (Sn[0] * h2 + sL), kL * Sn[1] * h2, kR * Sn[2] * h2, 1.0 + kR * (Sn[3] * h2 + sR)]

        def Sn_of(J):
            return [((J[0] - 1.0) / kL - sL) / h2, J[1] / kL / h2, J[2] / kR / h2, ((J[3] - 1.0) / kR - sR) / h2]

        cache = self.jac
        TL, TR = self.T_L, self.T_R
        # the first evaluation starts from the present state: a rigid inner model is not restored
        # (its set_state of its own get_state changes nothing)
        r = self._eval(snap, t, hs, TL, TR, *args, restore=not self._rigid)
        mode = self._mode(snap)
        J = J_of(cache[mode]) if mode in cache else None
        # the torque-twist law to 1e-10 relative: the result is then a smooth function of the
        # inputs down to that level (another host feeding the same inputs to the last bits gets the
        # same trajectory to 1e-9; at 1e-8 the iteration count flips and it does not)
        scale = 1e-10 * (1.0 + abs(TL) + abs(TR))
        fresh = switched = False
        for it in range(40):
            if abs(r[0]) + abs(r[1]) <= scale:
                break
            if J is None or (it >= 2 and not fresh):
                J = self._jacobian(snap, t, hs, TL, TR, r, args, mode)
                fresh = True
            det = J[0] * J[3] - J[1] * J[2]
            if not (det != 0.0 and math.isfinite(det)):
                if fresh:
                    raise StepError("shafts: the sun-torque Jacobian is singular")
                J = None
                continue
            dTL = -(J[3] * r[0] - J[1] * r[1]) / det
            dTR = -(J[0] * r[1] - J[2] * r[0]) / det
            if it >= 8:   # piecewise-affine residual near a mode switch: damp the correction
                dTL *= 0.5
                dTR *= 0.5
            TL, TR = TL + dTL, TR + dTR
            r_new = self._eval(snap, t, hs, TL, TR, *args)
            mode_new = self._mode(snap)
            if mode_new != mode and mode_new in cache and not switched:
                # the first switch to another piece of the piecewise-affine response: its kept
                # Jacobian (later switches: the secant across the kink, which does not cycle)
                J = J_of(cache[mode_new])
                switched = True
            else:
                # Broyden update: J += (dr - J dT) dT' / |dT|^2 (the secant through both points)
                n2 = dTL * dTL + dTR * dTR
                if n2 > 0.0:
                    yL = r_new[0] - r[0] - (J[0] * dTL + J[1] * dTR)
                    yR = r_new[1] - r[1] - (J[2] * dTL + J[3] * dTR)
                    J = [J[0] + yL * dTL / n2, J[1] + yL * dTR / n2, J[2] + yR * dTL / n2, J[3] + yR * dTR / n2]
            mode = mode_new
            r = r_new
            scale = 1e-10 * (1.0 + abs(TL) + abs(TR))
        else:
            # a piecewise-affine residual (a stick-slip switch inside the sub-step: a kink at the
            # solution) can stall Newton above the tight tolerance, and a mesh model's response
            # carries its integrator's error: accept 1e-6 relative (the torque-twist law to 0.1 mN m
            # at 100 N m; the energy ledger stays exact, it books the torques actually applied) or
            # ten times the mesh tolerance, no more
            if not abs(r[0]) + abs(r[1]) <= self._accept * (1.0 + abs(TL) + abs(TR)):
                raise _NotConverged(f"shafts: the implicit sub-step at t = {t:.6g} s did not converge (residual "
                                    f"{abs(r[0]) + abs(r[1]):.3g} N m, sub-step halved 6 times); reduce shafts.h_max")
        if J is not None:
            cache[mode] = Sn_of(J)
        # the inner model now holds the converged sub-step (the last evaluation)
        dthL, dthR = r[2], r[3]
        sp = self.shafts
        self.work_suns += TL * (inner.phi_L - phiL0) + TR * (inner.phi_R - phiR0)
        # shaft torque on the wheel is -T; the wheel side moves by the model's angle change
        self.work_wheels += TL * (args[2] - args[4] * TL) + TR * (args[3] - args[5] * TR)
        xL[0], xL[1] = pL[0] - pL[1] * TL, pL[2] - pL[3] * TL
        xR[0], xR[1] = pR[0] - pR[1] * TR, pR[2] - pR[3] * TR
        self.shaft_loss += (0.5 * sp.left.c * dthL * dthL + sp.left.d * dthL * dthL / hs
                            + 0.5 * sp.right.c * dthR * dthR + sp.right.d * dthR * dthR / hs)
        self.theta_L += dthL
        self.theta_R += dthR
        self.T_L, self.T_R = TL, TR
        return TL, TR, dthL, dthR

    def _advance(self, t: float, hs: float, wL: float, wR: float, xL: list, xR: list, acc: list,
                 depth: int, snap: dict | None = None) -> None:
        """One sub-step; where its Newton does not converge (a mesh model's impacts through the
        backlash make its response non-smooth in the torques) two halves instead, down to 1/64.
        ``snap``: the inner model's present state if the caller has it (else taken here)."""
        if snap is None:
            snap = self.inner.get_state()
        jac = {k: list(v) for k, v in self.jac.items()}
        try:
            TL, TR, _, _ = self._substep(t, hs, wL, wR, xL, xR, self.wheelL_model, self.wheelR_model, snap)
        except _NotConverged:
            if depth >= 6:
                raise
            self.inner.set_state(snap)
            self.jac = jac
            self.n_halvings += 1
            self._advance(t, 0.5 * hs, wL, wR, xL, xR, acc, depth + 1)
            self._advance(t + 0.5 * hs, 0.5 * hs, wL, wR, xL, xR, acc, depth + 1)
            return
        acc[0] += TL * hs
        acc[1] += TR * hs
        self.n_substeps += 1

    def do_step(self, t: float, h: float) -> None:
        """Advance from t to t + h; atomic (the state is unchanged when it raises)."""
        if not self._ready:
            raise StepError("do_step called before initialize")
        if not (h.__class__ is float and 0.0 < h < math.inf):
            h = require_positive("communicationStepSize", h)
        pL, wL, pR, wR = self._wheel_inputs()
        self.wheelL_model.checked("left")
        self.wheelR_model.checked("right")
        inner = self.inner
        saved_inner = inner.get_state()
        saved = _get_own_values(self), {k: list(v) for k, v in self.jac.items()}   # the rollback point
        try:
            self._do_step(t, h, pL, wL, pR, wR, saved_inner)
            if not (math.isfinite(self.theta_L + self.theta_R + self.T_L + self.T_R + inner.w_L + inner.w_R)
                    or all(math.isfinite(x) for x in (self.theta_L, self.theta_R, self.T_L, self.T_R,
                                                      inner.w_L, inner.w_R))):
                raise StepError(f"shafts: the step at t = {t:.6g} s gave a non-finite state")
        except BaseException:
            inner.set_state(saved_inner)
            for k, v in zip(_STATE_KEYS, saved[0]):
                object.__setattr__(self, k, v)
            self.jac = saved[1]
            raise

    def _do_step(self, t, h, pL, wL, pR, wR, snap: dict | None = None) -> None:
        """The step; ``snap`` the inner model's present state if the caller has it."""
        inner = self.inner
        sp = self.shafts
        self._lr = (sp.left, sp.right)
        cL, cR = sp.left.c, sp.right.c
        # re-anchor the twists on the wheel-side angles (no drift); book the spring-energy change
        thL = inner.phi_L - pL - self.off_L
        thR = inner.phi_R - pR - self.off_R
        self.work_wheels += (0.5 * cL * (thL * thL - self.theta_L * self.theta_L)
                             + 0.5 * cR * (thR * thR - self.theta_R * self.theta_R))
        self.theta_L, self.theta_R = thL, thR
        n = max(1, math.ceil(h / sp.h_max - 1e-9))
        hs = h / n
        xL, xR = [0.0, 0.0], [0.0, 0.0]
        acc = [0.0, 0.0]   # the torques' integrals over the step (N m s)
        for i in range(n):
            self._advance(t + i * hs, hs, wL, wR, xL, xR, acc, 0, snap if i == 0 else None)
        self.dw_pred_L, self.dw_pred_R = xL[0], xR[0]
        self.tau_mean_L, self.tau_mean_R = -acc[0] / h, -acc[1] / h
        self.tau_end_L, self.tau_end_R = -self.T_L, -self.T_R
        self.t = t + h
        self.n_steps += 1

    # ------------------------------------------------------------------ energy
    @property
    def shaft_energy(self) -> float:
        """Elastic energy of the two half-shafts (J)."""
        sp = self.shafts
        return 0.5 * (sp.left.c * self.theta_L ** 2 + sp.right.c * self.theta_R ** 2)

    @property
    def potential_energy(self) -> float:
        return float(getattr(self.inner, "potential_energy", 0.0)) + self.shaft_energy

    @property
    def energy_loss(self) -> float:
        """Friction (inner model) + shaft damping and the implicit scheme's dissipation (J)."""
        return self.inner.energy_loss + self.shaft_loss

    @property
    def work_in(self) -> float:
        """Work done on differential and shafts by the carrier drive and the wheel sides (J)."""
        return self.inner.work_in - self.work_suns + self.work_wheels

    # ------------------------------------------------------------------ state
    def get_own_state(self) -> dict:
        s = dict(zip(_STATE_KEYS, _get_own_values(self)))
        s["jac"] = {k: list(v) for k, v in self.jac.items()}
        return s

    def set_own_state(self, s: dict) -> None:
        for k in _STATE_KEYS:
            object.__setattr__(self, k, s[k])
        self.jac = {k: list(v) for k, v in s["jac"].items()}
        self._ready = True

    def get_state(self) -> dict:
        return {"inner": self.inner.get_state(), "shafts": self.get_own_state()}

    def set_state(self, state: dict) -> None:
        self.inner.set_state(state["inner"])
        self.set_own_state(state["shafts"])


# The outputs an FMU binds to (spurdiff.differential_fmu) are this class's own attributes, never
# reached through __getattr__ (about 1 us per read): its own results are instance attributes
# (tau_mean_L, tau_end_L, theta_L, dw_pred_L...) and properties (potential_energy, energy_loss,
# work_in), the inner model's outputs are forwarded by C-level getters, the same names the
# torque-coupled models answer (spurdiff.model_base.DifferentialModel).
INNER_OUTPUTS = ("wc", "phic", "w_L", "phi_L", "w_R", "phi_R", "tau_drive", "tau_mesh_L", "tau_mesh_R",
                 "mesh_forces", "locking_torque", "locking_capacity", "power_loss", "kinetic_energy", "stuck",
                 "stuck_indicator", "n_mode_switches", "n_contact_transitions")
for _name in INNER_OUTPUTS:
    setattr(ShaftedDifferential, _name,
            property(operator.attrgetter("inner." + _name), doc=f"The inner model's ``{_name}``."))


def _n_internal_steps(self) -> int:
    """The mesh levels' internal steps; with the rigid level, this model's steps."""
    inner = self.inner
    return self.n_steps if inner.mesh_model == "rigid" else inner.n_internal_steps


ShaftedDifferential.n_internal_steps = property(_n_internal_steps)

__all__ = ["ShaftedDifferential", "ShaftParams", "ShaftsParams", "WheelSurrogate", "SHAFT_COUPLINGS", "INNER_OUTPUTS"]
