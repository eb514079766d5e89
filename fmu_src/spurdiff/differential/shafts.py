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
sub-step with the torques ``T`` held, solved by a Newton iteration (:mod:`spurdiff.differential.shaft_solver`).

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

from spurdiff.errors import StepError, require_finite, require_positive
from spurdiff.differential.shaft_params import SHAFT_COUPLINGS, ShaftParams, ShaftsParams, WheelSurrogate  # noqa: F401 (re-exported)
from spurdiff.differential import shaft_kernel
from spurdiff.differential.shaft_solver import ShaftSolver

_STATE_KEYS = (
    "t", "off_L", "off_R", "theta_L", "theta_R", "T_L", "T_R", "tau_mean_L", "tau_mean_R",
    "tau_end_L", "tau_end_R", "work_wheels", "work_suns", "shaft_loss", "PE0_shaft", "n_steps",
    "n_substeps", "n_evals", "n_jacobians", "n_halvings", "jac", "dw_pred_L", "dw_pred_R",
)
_get_own_values = operator.attrgetter(*_STATE_KEYS)


class ShaftedDifferential(ShaftSolver):
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
    _sk = None       # the compiled step (spurdiff.differential.shaft_kernel), set by initialize
    shaft_kernel_note = "none (not initialized)"
    q_end_L = q_end_R = 0.0   # the wheel sides' tyre-torque deviations at the end of the last step (derivatives.py)

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
        if getattr(inner, "mesh_model", None) == "rigid":
            # a break-away from stuck slips at the static lever for the rest of its inner step (one
            # sub-step), then at the sliding one: the sub-step's response is then continuous in the
            # sun torques (with mu_pinDynamic < mu_pin the sliding lever makes it jump there, and the
            # implicit equation has no root; docs/locking-law.md). Equal coefficients: no change.
            inner.c_break, inner.K_break = inner.pf.c, inner.K
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
        # the step in C with a rigid inner model (its kernel switch decides: auto | compiled | python)
        self._sk, self.shaft_kernel_note = shaft_kernel.choose(self)
        self._mf = None
        self._ready = True

    # ------------------------------------------------------------------ stepping (the sub-step: ShaftSolver)
    def do_step(self, t: float, h: float) -> None:
        """Advance from t to t + h; atomic (the state is unchanged when it raises)."""
        if not self._ready:
            raise StepError("do_step called before initialize")
        if not (h.__class__ is float and 0.0 < h < math.inf):
            h = require_positive("communicationStepSize", h)
        self._mf = None     # the mesh forces of the new state (computed when asked for)
        pL, wL, pR, wR = self._wheel_inputs()
        self.wheelL_model.checked("left")
        self.wheelR_model.checked("right")
        sk = self._sk
        if sk is not None:
            if sk.step(self, t, h, pL, wL, pR, wR):
                return      # the compiled step (bit for bit this one)
            sk.forget()     # not taken, nothing changed: the Python code runs it
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
        self.q_end_L, self.q_end_R = xL[1], xR[1]
        self.tau_mean_L, self.tau_mean_R = -acc[0] / h, -acc[1] / h
        self.tau_end_L, self.tau_end_R = -self.T_L, -self.T_R
        self.t = t + h
        self.n_steps += 1

    def native_step(self) -> "shaft_kernel.DiffNative | None":
        """The whole step in C for a host that steps without Python (:mod:`spurdiff.native_step`):
        with the compiled step of this module's kernel and the FMU's two watches, else None (also with
        ``native`` false: the FMU's ``solver.nativeStep``); the same plan while the kernel is the same."""
        sk = self.__dict__.get("_sk") if self._ready and self.__dict__.get("native", True) else None
        if sk is None:
            return None
        plan = self.__dict__.get("_native")
        if plan is None or plan.kernel is not sk:
            plan = self._native = shaft_kernel.native(self)
        return plan

    # ------------------------------------------------------------------ the Jacobian cache
    @property
    def jac(self) -> dict:
        """The Jacobian cache: mode key -> the inner model's normalized sun-angle sensitivity (see
        :meth:`ShaftSolver._substep`). While the compiled step holds it (``_jac`` None), read from
        its arrays when asked for (``get_state``, a step of the Python code)."""
        d = self.__dict__
        j = d.get("_jac")
        if j is None:
            sk = d.get("_sk")
            j = d["_jac"] = sk.jac_dict() if sk is not None else {}
        return j

    @jac.setter
    def jac(self, value: dict) -> None:
        self.__dict__["_jac"] = value

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
        self._mf = None
        for k in _STATE_KEYS:
            object.__setattr__(self, k, s[k])
        self.jac = {k: list(v) for k, v in s["jac"].items()}
        self._ready = True

    def get_state(self) -> dict:
        return {"inner": self.inner.get_state(), "shafts": self.get_own_state()}

    def set_state(self, state: dict) -> None:
        self.inner.set_state(state["inner"])
        self.set_own_state(state["shafts"])


# The outputs an FMU binds to (spurdiff.fmi.differential_fmu) are this class's own attributes, never
# reached through __getattr__ (about 1 us per read): its own results are instance attributes
# (tau_mean_L, tau_end_L, theta_L, dw_pred_L...) and properties (potential_energy, energy_loss,
# work_in), the inner model's outputs are forwarded by C-level getters, the same names the
# torque-coupled models answer (spurdiff.differential.model_base.DifferentialModel).
INNER_OUTPUTS = ("wc", "phic", "w_L", "phi_L", "w_R", "phi_R", "tau_drive", "tau_mesh_L", "tau_mesh_R",
                 "mesh_forces", "locking_torque", "locking_capacity", "power_loss", "kinetic_energy", "stuck",
                 "stuck_indicator", "n_mode_switches", "n_contact_transitions", "parametric_work", "loaded_flanks")
for _name in INNER_OUTPUTS:
    setattr(ShaftedDifferential, _name,
            property(operator.attrgetter("inner." + _name), doc=f"The inner model's ``{_name}``."))


# the differential speed, read by the overspeed watch after every step (spurdiff.differential.watches; not through __getattr__)
ShaftedDifferential.wd = property(operator.attrgetter("inner.wd"), doc="The inner model's ``wd``.")


def _mesh_forces(self):
    """The inner model's ``mesh_forces``, computed once per state: three outputs and the load-capacity
    watch read it after every step (``_mf`` is dropped by ``do_step``, ``set_own_state``, ``initialize``)."""
    d = self.__dict__
    mf = d.get("_mf")
    if mf is None:
        mf = d["_mf"] = self.inner.mesh_forces
    return mf


ShaftedDifferential.mesh_forces = property(_mesh_forces)


def _n_internal_steps(self) -> int:
    """The mesh levels' internal steps; with the rigid level, this model's steps."""
    inner = self.inner
    return self.n_steps if inner.mesh_model == "rigid" else inner.n_internal_steps


ShaftedDifferential.n_internal_steps = property(_n_internal_steps)

__all__ = ["ShaftedDifferential", "ShaftParams", "ShaftsParams", "WheelSurrogate", "SHAFT_COUPLINGS", "INNER_OUTPUTS"]
