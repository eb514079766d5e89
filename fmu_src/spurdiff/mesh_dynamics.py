"""Gear-mesh dynamics of the differential at multibody fidelity, with switchable effects.

Degrees of freedom (one representative planet pair, see "Lumping" below), all angles of the suns
and planets relative to the carrier:

* carrier angle ``phi_c`` and speed ``w_c`` (states only with ``carrierDrive = "torque"``; with the
  speed drive the carrier follows the target linearly over each communication step, as in
  :mod:`spurdiff.rigid`),
* sun A angle ``psi_A`` (relative to the carrier) and speed ``v_A``; sun B speed ``v_B``,
* planet spins relative to the carrier ``w_1``, ``w_2``,
* the three mesh deflections along the lines of action ``d_A1``, ``d_B2``, ``d_12`` (m).

State vector ``y = (psi_A, d_A1, d_B2, d_12, v_A, v_B, w_1, w_2[, w_c, phi_c])``. The mesh
deflections are states (not the absolute angles, which grow without bound), as MSL's
ElastoBacklash recommends; ``psi_B`` and the planet angles follow from them:

    d_A1' = -(rb_A v_A + rb_1 w_1)      d_B2' = -(rb_B v_B + rb_2 w_2)      d_12' = rb_1 w_1 + rb_2 w_2

(external meshes; base radii ``rb``; the signs make all three normal forces positive when the
carrier drives the suns forward). Normal force per pair ``F = law(d, d')`` (below). Generalised
forces (Lagrange; the kinetic energy is
``T = 1/2 [J_c w_c^2 + J_A (w_c + v_A)^2 + J_B (w_c + v_B)^2 + n J_1 (w_c + w_1)^2 + n J_2 (w_c + w_2)^2]``
with ``J_c`` the carrier including the planets' orbiting masses)::

    Q_A = n (rb_A F_A1 + Mf_A)                Q_B = n (rb_B F_B2 + Mf_B)
    Q_1 = rb_1 (F_A1 - F_12) + Mf_1 + M_1     Q_2 = rb_2 (F_B2 - F_12) + Mf_2 + M_2

    J_A (a_c + v_A') = tau_L + Q_A            J_B (a_c + v_B') = tau_R + Q_B
    J_1 (a_c + w_1') = Q_1                    J_2 (a_c + w_2') = Q_2
    J_c a_c = tau_c - (Q_A + Q_B + n Q_1 + n Q_2)        (torque drive)
    tau_drive = J_c a_c + Q_A + Q_B + n Q_1 + n Q_2     (speed drive: what holds the carrier)

``Mf``: flank-friction moments, ``M_i``: pin friction of planet i. ``Q_A`` is the torque the meshes
deliver to sun A (``tau_mesh_L``).

Mesh laws (:mod:`spurdiff.mesh_laws`), per planet pair, penetration ``p = d`` on the drive flank
and ``p = -(d + j_n)`` on the coast flank (``j_n`` normal backlash, 0 without backlash):

* ``compliant``: ``F = k d + c d'`` (bilateral, no backlash) or MSL ElastoBacklash on each flank;
  ``k = c_gamma_alpha b`` from ISO 6336-1 unless given, ``c = 2 zeta sqrt(k m_e)``,
  ``m_e = 1 / (rb_1^2 / J_1' + rb_2^2 / J_2')`` (a sun's inertia shared by the n pairs).
* ``contact``: ADAMS IMPACT on each flank, ``F = K p^e + STEP(p, 0, 0, d_max, C) p'``, >= 0.
* ``meshStiffnessVariation``: Kahraman and Singh's rectangular wave: with the mesh phase
  ``xi = frac(xi_0 - u / p_b)`` on the drive flanks and ``frac(xi_0c + u / p_b)`` on the coast
  flanks (``u`` = base-circle roll of the mesh's first gear; ``xi_0``, ``xi_0c`` from the tooth
  positions of the pair, :mod:`spurdiff.phasing`: an A1 drive pair starts at its pitch point, the
  other meshes where their teeth then are), two tooth pairs carry the load for
  ``xi < eps_alpha - 1``, one otherwise; the stiffness (k or K) is multiplied by
  ``n_c / eps_alpha`` (``n_c`` pairs in contact), so its mean over a mesh period is the constant one.
  ``eps_alpha`` is the usable contact ratio (involute to tip on both gears, undercut form circles
  from the generating rack, :mod:`spurdiff.generating`); the ISO 6336 stiffness uses it too.
* ``flankFriction``: on each pair in contact at distances ``l_1``, ``l_2`` from the two base tangent
  points, sliding velocity ``v = W_1 l_1 + W_2 l_2`` (``W`` gear speeds relative to the carrier;
  zero at the pitch point), friction ``mu(v) |F| / n_c`` (ADAMS static/dynamic law), moments
  ``-mu |F|/n_c l_1`` and ``-mu |F|/n_c l_2`` on the two gears, loss ``mu |F| v / n_c >= 0``.
* ``pinFriction``: Coulomb friction moment ``M_i`` on each planet's spin, capacity
  ``c_pin |F_pin,i| + M_0,i`` with ``F_pin,i`` the bearing force (vector sum of the planet's two
  normal mesh forces along their lines of action, layout from the centre distances,
  :class:`spurdiff.locking.PinLayout`) and ``M_0,i`` the share of ``lockingPreload``. With
  ``lockingLaw = "pinFriction"`` (default) ``c_pin = mu r_d`` as given, nothing calibrated: the
  same law as the rigid level, so both break away at the same torques in drive and in coast. With
  ``lockingLaw = "paper"`` ``c_pin`` is scaled so that, quasi-statically with equal mesh forces,
  the capacity on the differential coordinate ``n (|rho_1| c_pin F_pin,1 + |rho_2| c_pin F_pin,2)``
  equals the paper's ``K (T_A + T_B)`` in drive (in coast it is then 19 % larger).
  Stick is exact (event-based): a stuck planet has ``w_i = 0`` and ``w_i' = 0`` (its Jacobian row is
  zero), the friction is whatever holds it (``M_i = J_i a_c - (Q_i - M_i)``) while
  ``|M_i| <= c_pin |F_pin,i|``; it breaks away in the direction of the excess and re-sticks when its
  slip speed reaches zero (located by the step control). Mode switches are counted.

Lumping: the n planet pairs are identical and share the load equally: one representative pair is
simulated, its mesh forces act n times on the suns and its inertias n times on the carrier.

Integration: :class:`spurdiff.mesh_integrator.RosenbrockW` (ROS34PW2, L-stable, W-method of order 3)
with an analytic Jacobian and step-size control; contact onset/loss and stick/slip events end an
internal step (secant location), mesh-phase boundaries limit the step. Work and loss are booked per
internal step: work exactly from the state change (momentum balance), loss by Simpson's rule of the
dissipated power (dense output at the midpoint).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import ParameterError, StepError, require_finite, require_positive
from .geometry import DifferentialGeometry
from .inertia import MassProperties, mass_properties
from .mesh_integrator import RosenbrockW, error_norm, new_step_size
from .mesh_laws import (elasto_backlash, friction_coefficient, impact, impact_potential,
                        iso6336_stiffness)
from .params import DifferentialParams
from .rigid import RigidDifferential
from .phasing import mesh_phases
from .locking import locking_coefficients, paper_locking_coefficient, pin_friction
from .statics import MeshForces, kinematics

__all__ = ["MeshParams", "MeshDifferential", "StepError", "MESH_MODELS", "N_PER_MM15"]

MESH_MODELS = ("compliant", "contact")
N_PER_MM15 = 1e3 ** 1.5  # 1 N/mm^1.5 in N/m^1.5
MESHES = ("A1", "B2", "12")

E_REF = 0.1       # J, energy scale of the loss-quadrature error control (see _advance)
STICK_RTOL = 1e-9  # relative margin of the stick test |M_i| <= c_pin |F_pin,i| (rounding only)

# state indices
PSI, DA, DB, D12, VA, VB, W1, W2, WC, PHIC = range(10)


@dataclass
class MeshParams:
    """Selects the mesh effects (structural parameters of the FMU) and their data, SI units.

    Defaults and their sources: docs/mesh-dynamics.md.
    """

    meshModel: str = "compliant"          # "compliant" | "contact"
    backlash: bool = False
    meshStiffnessVariation: bool = False
    pinFriction: bool = True
    flankFriction: bool = False
    tolerance: float = 1e-6               # relative accuracy of the internal integrator
    # circumferential backlash at the operating pitch circle (m); ISO/TR 10064-2 minimum for
    # this gear set: j_bn = 2/3 (0.06 + 0.0005 a + 0.03 m) mm, j_t = j_bn / cos(alpha_w)
    backlashA1: float = 0.127e-3
    backlashB2: float = 0.138e-3
    backlash12: float = 0.120e-3
    # compliant law: mesh stiffness per pair (N/m), 0 = ISO 6336-1 c_gamma_alpha * b
    stiffnessA1: float = 0.0
    stiffnessB2: float = 0.0
    stiffness12: float = 0.0
    dampingRatio: float = 0.07
    youngsModulus: float = 2.06e11        # Pa, the paper's 40CrNi2Mo (used for the ISO stiffness)
    # contact law (ADAMS IMPACT), the paper's values
    contactStiffnessA1: float = 3.9e5 * N_PER_MM15   # N/m^1.5
    contactStiffnessB2: float = 3.31e5 * N_PER_MM15
    contactStiffness12: float = 3.63e5 * N_PER_MM15
    contactExponent: float = 1.5
    contactDamping: float = 50e3          # N s/m (50 N s/mm)
    contactDepth: float = 1e-4            # m, penetration of full damping (0.1 mm)
    # flank friction (paper: static 0.05, dynamic 0.03)
    muStatic: float = 0.05
    muDynamic: float = 0.03
    vStiction: float = 1e-4               # m/s
    vTransition: float = 1e-2             # m/s
    # numerics / start
    preload: bool = True                  # start with the meshes statically loaded
    maxInternalSteps: int = 100000        # per communication step, else StepError

    def validate(self) -> None:
        """Raise ParameterError naming the first invalid field."""
        if self.meshModel not in MESH_MODELS:
            raise ParameterError("meshModel", self.meshModel, " | ".join(MESH_MODELS))
        for name in ("backlash", "meshStiffnessVariation", "pinFriction", "flankFriction", "preload"):
            v = getattr(self, name)
            if not isinstance(v, (bool, np.bool_)) and v not in (0, 1):
                raise ParameterError(name, v, "a boolean")
        tol = require_finite("tolerance", self.tolerance)
        if not 1e-12 <= tol <= 1e-1:
            raise ParameterError("tolerance", self.tolerance, "between 1e-12 and 0.1")
        for name in ("backlashA1", "backlashB2", "backlash12"):
            v = require_finite(name, getattr(self, name))
            if not 0.0 <= v <= 2e-3:
                raise ParameterError(name, v, "between 0 and 2e-3 m")
        for name in ("stiffnessA1", "stiffnessB2", "stiffness12"):
            v = require_finite(name, getattr(self, name))
            if not 0.0 <= v <= 1e12:
                raise ParameterError(name, v, "between 0 (ISO 6336-1) and 1e12 N/m")
        z = require_finite("dampingRatio", self.dampingRatio)
        if not 0.0 <= z <= 10.0:
            raise ParameterError("dampingRatio", self.dampingRatio, "between 0 and 10")
        E = require_finite("youngsModulus", self.youngsModulus)
        if not 1e9 <= E <= 1e12:
            raise ParameterError("youngsModulus", self.youngsModulus, "between 1e9 and 1e12 Pa")
        for name in ("contactStiffnessA1", "contactStiffnessB2", "contactStiffness12"):
            v = require_finite(name, getattr(self, name))
            if not 0.0 < v <= 1e15:
                raise ParameterError(name, v, "> 0 and <= 1e15 N/m^e")
        e = require_finite("contactExponent", self.contactExponent)
        if not 1.0 <= e <= 3.0:
            raise ParameterError("contactExponent", self.contactExponent, "between 1 and 3")
        c = require_finite("contactDamping", self.contactDamping)
        if not 0.0 <= c <= 1e8:
            raise ParameterError("contactDamping", self.contactDamping, "between 0 and 1e8 N s/m")
        dm = require_finite("contactDepth", self.contactDepth)
        if not 0.0 < dm <= 1e-2:
            raise ParameterError("contactDepth", self.contactDepth, "> 0 and <= 0.01 m")
        ms = require_finite("muStatic", self.muStatic)
        if not 0.0 <= ms <= 1.0:
            raise ParameterError("muStatic", self.muStatic, "between 0 and 1")
        md = require_finite("muDynamic", self.muDynamic)
        if not 0.0 <= md <= ms:
            raise ParameterError("muDynamic", self.muDynamic, f"between 0 and muStatic = {ms:g}")
        vs = require_finite("vStiction", self.vStiction)
        if not 0.0 < vs <= 1.0:
            raise ParameterError("vStiction", self.vStiction, "> 0 and <= 1 m/s")
        vd = require_finite("vTransition", self.vTransition)
        if not vs < vd <= 10.0:
            raise ParameterError("vTransition", self.vTransition, f"> vStiction = {vs:g} and <= 10 m/s")
        n = self.maxInternalSteps
        if isinstance(n, bool) or int(n) != n or not 10 <= n <= 10 ** 8:
            raise ParameterError("maxInternalSteps", n, "an integer from 10 to 1e8")


@dataclass(frozen=True)
class MeshData:
    """Derived constants of one mesh (per planet pair)."""

    name: str
    sigma: float        # +1: F > 0 gives + torque on both gears (A1, B2); -1 for mesh 12
    rb1: float
    rb2: float
    k: float            # compliant stiffness (N/m)
    c: float            # compliant damping (N s/m)
    K: float            # contact stiffness (N/m^e)
    jn: float           # normal backlash along the line of action (m), 0 without backlash
    eps: float          # usable transverse contact ratio
    pb: float           # base pitch
    l1min: float        # distance from gear 1's base tangent point to the start of the path
    galpha: float       # length of the path of contact
    L: float            # a sin(alpha_w): distance between the two base tangent points
    xi0: float          # initial phase of the drive-side flanks (spurdiff.phasing)
    xi0c: float         # initial phase of the coast-side flanks
    xip: float          # phase of the pitch point
    m_e: float          # equivalent mass (kg)


class MeshDifferential:
    """Differential with compliant or contact gear meshes; interface as RigidDifferential.

    Inputs (attributes, SI, Modelica signs): ``w_ref``, ``tau_c``, ``tau_L``, ``tau_R``; start values
    ``w_start_carrier``, ``w_start_left``. Call :meth:`initialize`, then :meth:`do_step`.
    """

    ATOMIC_STEP = True   # do_step leaves the state as it was when it raises (the FMU adapter relies on it)

    def __init__(self, params: DifferentialParams | None = None, mesh: MeshParams | None = None):
        self.params = params or DifferentialParams()
        self.mesh = mesh or MeshParams()
        self.w_ref = 0.0
        self.tau_c = 0.0
        self.tau_L = 0.0
        self.tau_R = 0.0
        self.w_start_carrier = 0.0
        self.w_start_left = float("nan")
        self._ready = False

    @property
    def mesh_model(self) -> str:
        return self.mesh.meshModel

    @property
    def active_effects(self) -> tuple[str, ...]:
        """Names of the effects in use: the mesh law, then the enabled switches (pinFriction only
        if the locking coefficient is not zero)."""
        m = self.mesh
        eff = [m.meshModel]
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
        self._pf = pin_friction(geo, p.mu_pin, p.r_collar, self.preload, self.law)
        self.K_paper = paper_locking_coefficient(p.mu_pin, p.r_collar, n, geo.r_a, geo.r_1, geo.r_b, geo.r_2)
        if self.law == "paper":
            self.K = self.K_coast = self.K_paper
        else:
            self.K, self.K_coast = locking_coefficients(self._pf)
        self.speed_drive = p.carrierDrive == "speed"
        mA, mB, m12 = geo.meshA1, geo.meshB2, geo.mesh12
        self.rbA, self.rb1, self.rbB, self.rb2 = mA.rb1, mA.rb2, mB.rb1, mB.rb2
        self._bl = bool(mp_.backlash)
        self._contact = mp_.meshModel == "contact"
        self._var = bool(mp_.meshStiffnessVariation)
        self._flank = bool(mp_.flankFriction)
        self._pin = bool(mp_.pinFriction) and (self._pf.c > 0.0 or self.preload > 0.0)
        self._need_phase = self._var or self._flank
        self._e = float(mp_.contactExponent)
        self._C = float(mp_.contactDamping)
        self._dmax = float(mp_.contactDepth)
        self._fric = (float(mp_.muStatic), float(mp_.muDynamic), float(mp_.vStiction), float(mp_.vTransition))
        self.md = self._mesh_data(geo)
        self._setup_pin(geo)
        # dissipation present at all? (else the loss is identically 0 and not integrated)
        self._dissipative = (self._pin or self._flank
                             or (self._contact and self._C > 0.0)
                             or (not self._contact and any(m.c > 0.0 for m in self.md)))
        N = self.n_states = 8 if self.speed_drive else 10
        self._N = N
        self.y = np.zeros(N)
        self._integ = RosenbrockW(N, self._evaluate)
        self._f0 = np.zeros(N)
        self._f1 = np.zeros(N)
        self._J1 = np.zeros((N, N))
        self._fscratch = np.zeros(N)
        self._scr = np.zeros(N)
        atol = np.ones(N)
        atol[[DA, DB, D12]] = 1e-5  # deflection scale: 10 um
        self._atol_scale = atol
        self._atol = atol * float(mp_.tolerance)
        self._rtol = float(mp_.tolerance)
        # slip speed below which a slipping planet is tested for sticking (rad/s): 1e-3 of the
        # integrator's absolute velocity accuracy
        self._w_stick = 1e-3 * float(mp_.tolerance)
        for J in (self._integ.J, self._J1):
            self._constant_jacobian(J)
        # torque drive: inverse mass matrix in (w_c, v_A, v_B, w_1, w_2) for stick impulses
        if not self.speed_drive:
            M = np.array([[self.Jtot, self.JA, self.JB, n * self.J1, n * self.J2],
                          [self.JA, self.JA, 0, 0, 0], [self.JB, 0, self.JB, 0, 0],
                          [n * self.J1, 0, 0, n * self.J1, 0], [n * self.J2, 0, 0, 0, n * self.J2]])
            self._Minv = np.linalg.inv(M)
        self._initial_state(t0)
        self._ready = True

    def _check_inputs(self) -> None:
        require_finite("carrier.w_ref", self.w_ref)
        require_finite("carrier.tau", self.tau_c)
        require_finite("left.tau", self.tau_L)
        require_finite("right.tau", self.tau_R)

    def _mesh_data(self, geo: DifferentialGeometry) -> tuple[MeshData, MeshData, MeshData]:
        mp_ = self.mesh
        ms = self.mass
        n = ms.n_pairs
        t = geo.table
        gearpairs = {"A1": (t.sunA, t.planet1, ms.J_sunA / n, ms.J_planet1),
                     "B2": (t.sunB, t.planet2, ms.J_sunB / n, ms.J_planet2),
                     "12": (t.planet1, t.planet2, ms.J_planet1, ms.J_planet2)}
        phases = mesh_phases(geo)
        out = []
        for name, me in zip(MESHES, geo.meshes):
            g1, g2, J1, J2 = gearpairs[name]
            # usable path: involute to tip on both gears (form circles from the generating rack)
            L = me.a * math.sin(me.alpha_w)
            l1min, l1max = me.usable_path
            galpha = l1max - l1min
            eps = galpha / me.pb
            ph = phases[name]
            m_e = 1.0 / (me.rb1 ** 2 / J1 + me.rb2 ** 2 / J2)
            k = getattr(mp_, "stiffness" + name)
            if k <= 0.0:
                _, cg = iso6336_stiffness(g1.z, g1.x, g2.z, g2.x, eps, mp_.youngsModulus, t.hf, math.degrees(t.alpha))
                k = cg * 1e9 * me.b   # N/(mm um) per mm face width -> N/m per m
            c = 2.0 * mp_.dampingRatio * math.sqrt(k * m_e)
            jn = getattr(mp_, "backlash" + name) * math.cos(me.alpha_w) if mp_.backlash else 0.0
            K = getattr(mp_, "contactStiffness" + name)
            out.append(MeshData(name, -1.0 if name == "12" else 1.0, me.rb1, me.rb2, k, c, K, jn, eps,
                                me.pb, l1min, galpha, L, ph.drive, ph.coast, ph.pitch, m_e))
        return tuple(out)

    def _setup_pin(self, geo: DifferentialGeometry) -> None:
        """Layout of one planet pair and the pin-friction constants (:mod:`spurdiff.locking`)."""
        pf = self._pf
        self._layout = pf.layout
        self._pin_force = pf.layout.pin_force
        self.layout_angle = pf.layout.theta
        self.pin_unit = pf.layout.unit_pin_loads(1.0)
        self.c_pin = pf.c
        self._M01, self._M02 = pf.M0

    def _constant_jacobian(self, J: np.ndarray) -> None:
        J[:] = 0.0
        J[PSI, VA] = 1.0
        J[DA, VA] = -self.rbA
        J[DA, W1] = -self.rb1
        J[DB, VB] = -self.rbB
        J[DB, W2] = -self.rb2
        J[D12, W1] = self.rb1
        J[D12, W2] = self.rb2
        if not self.speed_drive:
            J[PHIC, WC] = 1.0

    # ================================================================== initial state
    def _initial_state(self, t0: float) -> None:
        p = self.params
        rig = RigidDifferential(p)
        rig.w_ref, rig.tau_c, rig.tau_L, rig.tau_R = self.w_ref, self.tau_c, self.tau_L, self.tau_R
        rig.w_start_carrier, rig.w_start_left = self.w_start_carrier, self.w_start_left
        rig.initialize(t0)
        wc0, wd0 = rig.wc, rig.wd
        self.t = float(t0)
        self.wc = float(wc0)
        self.phic = 0.0
        self._ac = 0.0
        y = self.y
        y[:] = 0.0
        y[VA], y[VB], y[W1], y[W2] = wd0, self.lam * wd0, self.rho1 * wd0, self.rho2 * wd0
        if not self.speed_drive:
            y[WC] = wc0
        ac = 0.0 if self.speed_drive else rig.ac
        self.s = [0, 0]
        FA, FB, F12, ac = self._initial_forces(ac, rig.ad, rig.slip_dir, wd0)
        if not self.mesh.preload:
            FA = FB = F12 = 0.0
        for idx, F, m in ((DA, FA, self.md[0]), (DB, FB, self.md[1]), (D12, F12, self.md[2])):
            y[idx] = self._static_deflection(m, F) if self.mesh.preload else -0.5 * m.jn
        self._dA0, self._dB0, self._d120 = float(y[DA]), float(y[DB]), float(y[D12])
        self.work_in = self.energy_loss = self.loss_last_step = self.parametric_work = 0.0
        self.n_mode_switches = self.n_contact_transitions = 0
        self.n_internal_steps = self.n_rejected_steps = self.n_steps = 0
        self.h_next = 1e-5
        self._last_h = 0.0
        self._contact_flags = self._flags(y)
        self._f0_key = None
        if self._pin:
            self._settle_modes(y, ())
            self.n_mode_switches = 0
        self._refresh_outputs()

    def _initial_forces(self, ac: float, ad: float, slip_dir: float, wd0: float):
        """Mesh forces consistent with the rigid motion at t0 (deflection rates and their
        accelerations zero): stuck planets share the friction in proportion to their capacity
        (equal utilisation); otherwise the slipping (or frictionless) motion is solved for."""
        n, JA, JB, J1, J2 = self.n, self.JA, self.JB, self.J1, self.J2
        rbA, rbB, rb1, rb2 = self.rbA, self.rbB, self.rb1, self.rb2
        tL, tR = self.tau_L, self.tau_R
        if self._pin and slip_dir == 0.0 and wd0 == 0.0:
            FA = (JA * ac - tL) / (n * rbA)
            FB = (JB * ac - tR) / (n * rbB)
            F12 = 0.5 * (FA + FB)
            a1, a2 = J1 * ac - rb1 * FA, J2 * ac - rb2 * FB
            for _ in range(6):
                cap1 = self.c_pin * self._pin_force(0, FA, F12)[0] + self._M01
                cap2 = self.c_pin * self._pin_force(1, FB, F12)[0] + self._M02
                if cap1 + cap2 <= 0.0:
                    cap1 = cap2 = 1.0
                F12 = -(cap2 * a1 + cap1 * a2) / (cap2 * rb1 + cap1 * rb2)
            M1, M2 = a1 + rb1 * F12, a2 + rb2 * F12
            cap1 = self.c_pin * self._pin_force(0, FA, F12)[0] + self._M01
            cap2 = self.c_pin * self._pin_force(1, FB, F12)[0] + self._M02
            if abs(M1) <= cap1 * (1 + 1e-9) and abs(M2) <= cap2 * (1 + 1e-9):
                return FA, FB, F12, ac
            slip_dir = -math.copysign(1.0, self.rho1 * M1 + self.rho2 * M2)
        sd = slip_dir if slip_dir != 0.0 else (math.copysign(1.0, wd0) if wd0 != 0.0 else 1.0)
        s1 = math.copysign(1.0, self.rho1) * sd if self._pin else 0.0
        s2 = math.copysign(1.0, self.rho2) * sd if self._pin else 0.0
        cp = self.c_pin if self._pin else 0.0
        speed = self.speed_drive

        def res(x):
            F12, add = x[0], x[1]
            acc = ac if speed else x[2]
            FA = (JA * (acc + add) - tL) / (n * rbA)
            FB = (JB * (acc + self.lam * add) - tR) / (n * rbB)
            M1 = -s1 * (cp * self._pin_force(0, FA, F12)[0] + (self._M01 if self._pin else 0.0))
            M2 = -s2 * (cp * self._pin_force(1, FB, F12)[0] + (self._M02 if self._pin else 0.0))
            Q1, Q2 = J1 * (acc + self.rho1 * add), J2 * (acc + self.rho2 * add)
            r = [Q1 - (rb1 * (FA - F12) + M1), Q2 - (rb2 * (FB - F12) + M2)]
            if not speed:
                r.append(self.Jc * acc - (self.tau_c - (n * rbA * FA + n * rbB * FB + n * Q1 + n * Q2)))
            return r

        from scipy.optimize import fsolve

        F0 = -(tL + tR) / (n * (rbA + rbB))
        x0 = [F0, ad] + ([] if speed else [ac])
        sol, info, ier, _ = fsolve(res, x0, full_output=True, xtol=1e-13)
        if not np.all(np.isfinite(sol)):
            sol = x0  # no consistent start found: start from the rigid estimate (a short transient)
        F12, add = float(sol[0]), float(sol[1])
        acc = ac if speed else float(sol[2])
        FA = (JA * (acc + add) - tL) / (n * rbA)
        FB = (JB * (acc + self.lam * add) - tR) / (n * rbB)
        self.s = [int(s1), int(s2)]
        return FA, FB, F12, acc

    def _stiffness_factor(self, m: MeshData, xi: float) -> float:
        if not self._var:
            return 1.0
        return (2.0 if xi < m.eps - 1.0 else 1.0) / m.eps

    def _static_deflection(self, m: MeshData, F: float) -> float:
        kf = self._stiffness_factor(m, m.xi0 if F >= 0.0 else m.xi0c)
        if F == 0.0:
            return 0.0 if m.jn == 0.0 else -0.5 * m.jn
        if self._contact:
            pen = (abs(F) / (m.K * kf)) ** (1.0 / self._e)
        else:
            pen = abs(F) / (m.k * kf)
        return pen if F > 0.0 else -(m.jn + pen)

    # ================================================================== right-hand side
    def _angles(self, yl) -> tuple[float, float, float]:
        """(psi_B, theta_1, theta_2) from psi_A and the deflections."""
        th1 = (self._dA0 - yl[DA] - self.rbA * yl[PSI]) / self.rb1
        th2 = (yl[D12] - self._d120 - self.rb1 * th1) / self.rb2
        psiB = (self._dB0 - yl[DB] - self.rb2 * th2) / self.rbB
        return psiB, th1, th2

    def _force(self, m: MeshData, d: float, dd: float, u: float):
        """Normal force per pair: (F, dF/dd, dF/d(dd), Fc, xi of the flank in contact)."""
        if self._need_phase:
            r = m.sigma * u / m.pb
            xp = (m.xi0 - r) % 1.0
            xn = (m.xi0c + r) % 1.0
            if self._var:
                e1 = m.eps - 1.0
                kp = (2.0 if xp < e1 else 1.0) / m.eps
                kn = (2.0 if xn < e1 else 1.0) / m.eps
            else:
                kp = kn = 1.0
        else:
            xp, xn = m.xi0, m.xi0c
            kp = kn = 1.0
        if self._contact:
            if d > 0.0:
                F, dFp, dFv, Fc = impact(d, dd, m.K * kp, self._e, self._C, self._dmax)
                return F, dFp, dFv, Fc, xp
            pen = -(d + m.jn)
            if pen > 0.0:
                F, dFp, dFv, Fc = impact(pen, -dd, m.K * kn, self._e, self._C, self._dmax)
                return -F, dFp, dFv, -Fc, xn
            return 0.0, 0.0, 0.0, 0.0, xp
        if not self._bl:
            if d >= 0.0:
                kk = m.k * kp
                return kk * d + m.c * dd, kk, m.c, kk * d, xp
            kk = m.k * kn
            return kk * d + m.c * dd, kk, m.c, kk * d, xn
        if d > 0.0:
            F, dFp, dFv, Fc = elasto_backlash(d, dd, m.k * kp, m.c)
            return F, dFp, dFv, Fc, xp
        pen = -(d + m.jn)
        if pen > 0.0:
            F, dFp, dFv, Fc = elasto_backlash(pen, -dd, m.k * kn, m.c)
            return -F, dFp, dFv, -Fc, xn
        return 0.0, 0.0, 0.0, 0.0, xp

    def _potential(self, m: MeshData, d: float, u: float) -> float:
        """Elastic energy of one pair of mesh m (J)."""
        r = m.sigma * u / m.pb
        kp = self._stiffness_factor(m, (m.xi0 - r) % 1.0)
        kn = self._stiffness_factor(m, (m.xi0c + r) % 1.0)
        if self._contact:
            if d > 0.0:
                return impact_potential(d, m.K * kp, self._e)
            return impact_potential(-(d + m.jn), m.K * kn, self._e)
        if not self._bl:
            return 0.5 * m.k * (kp if d >= 0.0 else kn) * d * d
        if d > 0.0:
            return 0.5 * m.k * kp * d * d
        pen = -(d + m.jn)
        return 0.5 * m.k * kn * pen * pen if pen > 0.0 else 0.0

    def _flank_friction(self, m: MeshData, F: float, xi: float, W1: float, W2: float):
        """Flank friction of one pair: (M1, M2, dM1/dF, dM2/dF, dM1/dW1, dM1/dW2, dM2/dW2, P)."""
        if F == 0.0:
            return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        mu_s, mu_d, v_s, v_d = self._fric
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
        return M1, M2, dM1F, dM2F, d11, d12, d22, P

    def _evaluate(self, y: np.ndarray, f: np.ndarray, J: np.ndarray | None) -> None:
        """f = y'(y) in the current friction modes; J = df/dy rows that depend on y (if given).
        Side values for events and outputs are left in self._sv."""
        yl = y.tolist()
        psiA, dA, dB, d12, vA, vB, w1, w2 = yl[0], yl[1], yl[2], yl[3], yl[4], yl[5], yl[6], yl[7]
        rbA, rb1, rbB, rb2, n = self.rbA, self.rb1, self.rbB, self.rb2, self.n
        mA, mB, m12 = self.md
        ddA = -(rbA * vA + rb1 * w1)
        ddB = -(rbB * vB + rb2 * w2)
        dd12 = rb1 * w1 + rb2 * w2
        if self._need_phase:
            th1 = (self._dA0 - dA - rbA * psiA) / rb1
            th2 = (d12 - self._d120 - rb1 * th1) / rb2
            psiB = (self._dB0 - dB - rb2 * th2) / rbB
            uA, uB, u12 = rbA * psiA, rbB * psiB, rb1 * th1
        else:
            uA = uB = u12 = 0.0
        FA, kA, cA, FcA, xiA = self._force(mA, dA, ddA, uA)
        FB, kB, cB, FcB, xiB = self._force(mB, dB, ddB, uB)
        F12, k12, c12, Fc12, xi12 = self._force(m12, d12, dd12, u12)
        P = n * ((FA - FcA) * ddA + (FB - FcB) * ddB + (F12 - Fc12) * dd12)
        # mesh moments and their force coefficients
        QA = rbA * FA
        QB = rbB * FB
        Q1 = rb1 * (FA - F12)
        Q2 = rb2 * (FB - F12)
        cQA_FA, cQB_FB = rbA, rbB
        cQ1_FA, cQ1_F12, cQ2_FB, cQ2_F12 = rb1, -rb1, rb2, -rb2
        # velocity coefficients from flank friction: (QA: vA, w1), (QB: vB, w2), Q1: vA, w1, w2, Q2: vB, w1, w2
        gA_vA = gA_w1 = gB_vB = gB_w2 = 0.0
        g1_vA = g1_w1 = g1_w2 = g2_vB = g2_w1 = g2_w2 = 0.0
        if self._flank:
            a1, a2, aF1, aF2, a11, a12, a22, aP = self._flank_friction(mA, FA, xiA, vA, w1)
            QA += a1
            Q1 += a2
            cQA_FA += aF1
            cQ1_FA += aF2
            gA_vA += a11
            gA_w1 += a12
            g1_vA += a12
            g1_w1 += a22
            b1, b2, bF1, bF2, b11, b12, b22, bP = self._flank_friction(mB, FB, xiB, vB, w2)
            QB += b1
            Q2 += b2
            cQB_FB += bF1
            cQ2_FB += bF2
            gB_vB += b11
            gB_w2 += b12
            g2_vB += b12
            g2_w2 += b22
            e1, e2, eF1, eF2, e11, e12, e22, eP = self._flank_friction(m12, F12, xi12, w1, w2)
            Q1 += e1
            Q2 += e2
            cQ1_F12 += eF1
            cQ2_F12 += eF2
            g1_w1 += e11
            g1_w2 += e12
            g2_w1 += e12
            g2_w2 += e22
            P += n * (aP + bP + eP)
        QA *= n
        QB *= n
        # pin friction
        s1, s2 = self.s
        if self._pin:
            cp = self.c_pin
            Fp1, dp1S, dp112 = self._pin_force(0, FA, F12)
            Fp2, dp2S, dp212 = self._pin_force(1, FB, F12)
            cap1, cap2 = cp * Fp1 + self._M01, cp * Fp2 + self._M02
            stuck1, stuck2 = s1 == 0, s2 == 0
        else:
            cap1 = cap2 = 0.0
            stuck1 = stuck2 = False
        Q1nf, Q2nf = Q1, Q2  # without pin friction
        M1 = M2 = 0.0
        if self._pin:
            if not stuck1:
                M1 = -s1 * cap1
                Q1 += M1
                cQ1_FA -= s1 * cp * dp1S
                cQ1_F12 -= s1 * cp * dp112
                P += n * abs(M1 * w1)
            if not stuck2:
                M2 = -s2 * cap2
                Q2 += M2
                cQ2_FB -= s2 * cp * dp2S
                cQ2_F12 -= s2 * cp * dp212
                P += n * abs(M2 * w2)
        # carrier acceleration
        J1_, J2_ = self.J1, self.J2
        if self.speed_drive:
            ac = self._ac
        else:
            Jeff = self.Jc
            Qs = QA + QB
            if stuck1:
                Jeff += n * J1_
            else:
                Qs += n * Q1
            if stuck2:
                Jeff += n * J2_
            else:
                Qs += n * Q2
            ac = (self.tau_c - Qs) / Jeff
        if stuck1:
            M1 = J1_ * ac - Q1nf
            Q1 = J1_ * ac
        if stuck2:
            M2 = J2_ * ac - Q2nf
            Q2 = J2_ * ac
        f[0] = vA
        f[1] = ddA
        f[2] = ddB
        f[3] = dd12
        f[4] = (self.tau_L + QA) / self.JA - ac
        f[5] = (self.tau_R + QB) / self.JB - ac
        f[6] = 0.0 if stuck1 else Q1 / J1_ - ac
        f[7] = 0.0 if stuck2 else Q2 / J2_ - ac
        if not self.speed_drive:
            f[8] = ac
            f[9] = yl[WC]
        self._sv = (FA, FB, F12, QA, QB, Q1, Q2, M1, M2, cap1, cap2, P, ac)
        if J is None:
            return
        # gradients of the forces: FA (dA, vA, w1), FB (dB, vB, w2), F12 (d12, w1, w2)
        fA_d, fA_vA, fA_w1 = kA, -cA * rbA, -cA * rb1
        fB_d, fB_vB, fB_w2 = kB, -cB * rbB, -cB * rb2
        f12_d, f12_w1, f12_w2 = k12, c12 * rb1, c12 * rb2
        # rows of dQ/dy over columns (dA, dB, d12, vA, vB, w1, w2)
        gQA = (n * cQA_FA * fA_d, 0.0, 0.0, n * (cQA_FA * fA_vA + gA_vA), 0.0, n * (cQA_FA * fA_w1 + gA_w1), 0.0)
        gQB = (0.0, n * cQB_FB * fB_d, 0.0, 0.0, n * (cQB_FB * fB_vB + gB_vB), 0.0, n * (cQB_FB * fB_w2 + gB_w2))
        gQ1 = (cQ1_FA * fA_d, 0.0, cQ1_F12 * f12_d, cQ1_FA * fA_vA + g1_vA, 0.0,
               cQ1_FA * fA_w1 + cQ1_F12 * f12_w1 + g1_w1, cQ1_F12 * f12_w2 + g1_w2)
        gQ2 = (0.0, cQ2_FB * fB_d, cQ2_F12 * f12_d, 0.0, cQ2_FB * fB_vB + g2_vB,
               cQ2_F12 * f12_w1 + g2_w1, cQ2_FB * fB_w2 + cQ2_F12 * f12_w2 + g2_w2)
        if self.speed_drive:
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
        iA, iB = 1.0 / self.JA, 1.0 / self.JB
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

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """Right-hand side for scipy's solve_ivp (current inputs and friction modes held)."""
        f = np.zeros(self._N)
        self._evaluate(np.asarray(y, dtype=float), f, None)
        return f

    def jac(self, t: float, y: np.ndarray) -> np.ndarray:
        """Analytic Jacobian for solve_ivp (Radau / BDF)."""
        J = np.zeros((self._N, self._N))
        self._constant_jacobian(J)
        self._evaluate(np.asarray(y, dtype=float), self._fscratch, J)
        return J

    def state_vector(self) -> np.ndarray:
        """Copy of the continuous state y (see the module docstring for its layout)."""
        return self.y.copy()

    def load_state_vector(self, y: np.ndarray) -> None:
        """Put a continuous state (e.g. a point of a solve_ivp trajectory) in place and refresh the
        outputs at it; friction modes and inputs stay as they are."""
        self.y[:] = y
        self._refresh_outputs()

    # ================================================================== events and modes
    def _flags(self, y) -> list[int]:
        """Contact flags (drive, coast) per mesh: 1 where the flank penetrates."""
        if not (self._bl or self._contact):
            return []
        out = []
        for idx, m in zip((DA, DB, D12), self.md):
            d = float(y[idx])
            out.append(1 if d > 0.0 else 0)
            out.append(1 if -(d + m.jn) > 0.0 else 0)
        return out

    @staticmethod
    def _crossing(g0: float, gm: float, g1: float, closed: bool) -> float:
        """Fraction of the step where g leaves its start side, from its values at the start, middle
        and end of the step (piecewise linear); 1.0 if it does not. ``closed``: g <= 0 counts as
        crossed (for g > 0 at the start), else only a change of the sign of g > 0."""
        if closed:
            if g0 > 0.0 and gm <= 0.0:
                return 0.5 * g0 / (g0 - gm)
            if g0 > 0.0 and g1 <= 0.0:
                return 0.5 + 0.5 * gm / (gm - g1) if gm != g1 else 1.0
            return 1.0
        p0, pm, p1 = g0 > 0.0, gm > 0.0, g1 > 0.0
        if pm != p0:
            return 0.5 * g0 / (g0 - gm)
        if p1 != pm:
            return 0.5 + 0.5 * gm / (gm - g1)
        return 1.0

    def _state_events(self, y0: np.ndarray, ym: np.ndarray, y1: np.ndarray) -> float:
        """Smallest fraction of the step at which a contact flank opens/closes or a slipping
        planet reaches zero slip speed, from the start, the dense-output middle and the end of the
        step (so a contact or a stop inside the step is not missed); 1.0 if none."""
        theta = 1.0
        if self._bl or self._contact:
            for idx, m in zip((DA, DB, D12), self.md):
                a, c, b = float(y0[idx]), float(ym[idx]), float(y1[idx])
                theta = min(theta, self._crossing(a, c, b, False),
                            self._crossing(-(a + m.jn), -(c + m.jn), -(b + m.jn), False))
        if self._pin:
            for i, idx in ((0, W1), (1, W2)):
                s = self.s[i]
                if s != 0:
                    theta = min(theta, self._crossing(s * float(y0[idx]), s * float(ym[idx]),
                                                      s * float(y1[idx]), True))
        return theta

    def _settle_modes(self, y: np.ndarray, zeroed) -> int:
        """Decide the friction modes at a state (after zeroing the planets in ``zeroed``):
        stuck planets whose required friction exceeds the capacity break away in the direction of
        the excess. Returns the number of mode changes; leaves f0/J evaluated at y."""
        before = list(self.s)
        for i in zeroed:
            self.s[i] = 0
        for _ in range(4):
            self._evaluate(y, self._f0, self._integ.J)
            sv = self._sv
            changed = False
            for i in (0, 1):
                if self.s[i] == 0:
                    Mreq, cap = sv[7 + i], sv[9 + i]
                    if abs(Mreq) > cap * (1.0 + STICK_RTOL):
                        self.s[i] = -1 if Mreq > 0.0 else 1
                        changed = True
            if not changed:
                break
        return sum(1 for a, b in zip(before, self.s) if a != b)

    def _stick_impulse(self, y: np.ndarray, i: int, wc: float) -> None:
        """Set planet i's slip speed to exactly zero (it re-sticks). The friction impulse that does
        it is inelastic: the kinetic energy it removes is booked as loss, the drive's impulsive
        work (speed drive) as work in."""
        idx = W1 if i == 0 else W2
        w = float(y[idx])
        if w == 0.0:
            return
        nJ = self.n * (self.J1 if i == 0 else self.J2)
        if self.speed_drive:
            self.work_in += -nJ * wc * w
            self.energy_loss += 0.5 * nJ * w * w
            y[idx] = 0.0
            return
        # torque drive: impulse p on w_i with the carrier free: dv = M^-1 e_i p, w_i -> 0,
        # loss 1/2 w^2 / (M^-1)_ii
        k = 3 + i
        col = self._Minv[:, k]
        v = np.array([y[WC], y[VA], y[VB], y[W1], y[W2]]) - col * (w / col[k])
        self.energy_loss += 0.5 * w * w / col[k]
        y[WC], y[VA], y[VB], y[W1], y[W2] = v
        y[idx] = 0.0

    def _phase_limit(self, y: np.ndarray) -> float:
        """Step limit at the next mesh-phase boundary of the loaded flank of each mesh, from the
        current rolling speeds (inf if none). Boundaries: a pair entering or leaving contact
        (xi = 0 and xi = eps - 1: the stiffness wave and the friction arms jump) and, with flank
        friction, a pair passing the pitch point (xi = xip: the sliding velocity changes sign).
        The step ends just past the boundary; past a pitch point by the time the sliding speed
        needs to leave the stiction band (|v| > v_s), so the friction reversal is not inside a step."""
        best = math.inf
        yl = y.tolist()
        rates = (self.rbA * yl[VA], self.rbB * yl[VB], self.rb1 * yl[W1])
        omegas = ((yl[VA], yl[W1]), (yl[VB], yl[W2]), (yl[W1], yl[W2]))
        unilateral = self._bl or self._contact
        v_s = self._fric[2]
        us = None
        for mi, (idx, m) in enumerate(zip((DA, DB, D12), self.md)):
            d = yl[idx]
            if unilateral:
                if d > 0.0:
                    sgn = -1.0          # drive flank: xi = frac(xi0 - sigma u / pb)
                elif -(d + m.jn) > 0.0:
                    sgn = 1.0           # coast flank: xi = frac(xi0c + sigma u / pb)
                else:
                    continue            # no contact: nothing switches
            else:
                sgn = -1.0 if d >= 0.0 else 1.0
            rate = sgn * m.sigma * rates[mi] / m.pb   # d xi / dt
            if rate == 0.0:
                continue
            if us is None:
                psiB, th1, _ = self._angles(yl)
                us = (self.rbA * yl[PSI], self.rbB * psiB, self.rb1 * th1)
            xi = ((m.xi0 if sgn < 0.0 else m.xi0c) + sgn * m.sigma * us[mi] / m.pb) % 1.0
            ar = abs(rate)
            bounds = (0.0, m.eps - 1.0, m.xip) if self._flank else (0.0, m.eps - 1.0)
            for j, xb in enumerate(bounds):
                dist = (xb - xi) % 1.0 if rate > 0.0 else (xi - xb) % 1.0
                if dist == 0.0:
                    dist = 1.0
                dt = dist / ar
                dt += 1e-7 * dt + 1e-12
                if j == 2:
                    o1, o2 = omegas[mi]
                    grad = abs(o1 - o2) * ar * m.pb      # d|v|/dt of the sliding speed at the pitch
                    if grad > 0.0:
                        dt += 1.5 * v_s / grad
                if dt < best:
                    best = dt
        return best

    # ================================================================== stepping
    def do_step(self, t: float, h: float) -> None:
        """Advance from t to t + h with the inputs held; raises ParameterError / StepError.

        On any error the model is left exactly as it was before the call (``ATOMIC_STEP``)."""
        if not self._ready:
            raise StepError("do_step called before initialize")
        h = require_positive("communicationStepSize", h)
        self._check_inputs()
        snapshot = self.get_state()
        try:
            self._advance(t, h)
        except StepError:
            self.set_state(snapshot)
            raise
        except (ArithmeticError, ValueError, np.linalg.LinAlgError) as exc:
            self.set_state(snapshot)
            raise StepError(f"step at t = {t:.9g} s failed: {exc}") from exc
        except Exception:
            self.set_state(snapshot)
            raise

    def _advance(self, t: float, h: float) -> None:
        integ = self._integ
        y = self.y
        speed = self.speed_drive
        wc_start = self.wc
        if speed:
            self._ac = (self.w_ref - wc_start) / h
        ac = self._ac
        n = self.n
        JA, JB, J1, J2 = self.JA, self.JB, self.J1 * n, self.J2 * n
        tL, tR, tc = self.tau_L, self.tau_R, self.tau_c
        f0, f1 = self._f0, self._f1
        key = (tL, tR, tc, ac if speed else None, self.s[0], self.s[1])
        if key == self._f0_key:
            sv0 = self._sv0            # f0, J and side values at y are still those of the last step
        else:
            self._evaluate(y, f0, integ.J)
            sv0 = self._sv
        loss0 = self.energy_loss
        max_steps = int(self.mesh.maxInternalSteps)
        n_here = 0
        tin = 0.0          # time into the communication step
        remaining = h
        h_ctrl = self.h_next
        hmin = 1e-13
        wc_a = wc_start
        phic = self.phic
        while remaining > 1e-12 * h:
            hi = h_ctrl if h_ctrl < remaining else remaining
            if self._need_phase:
                lim = self._phase_limit(y)
                if lim < hi:
                    hi = lim
            if remaining - hi < 1e-9 * h:
                hi = remaining
            truncated = hi < h_ctrl
            located = 0
            rejected = False
            while True:
                n_here += 1
                if n_here > max_steps:
                    raise StepError(f"more than {max_steps} internal steps in the step at t = {t:.9g} s "
                                    f"(maxInternalSteps)")
                if hi < hmin:
                    raise StepError(f"internal step size {hi:.3g} s below {hmin:g} s at t = {t + tin:.9g} s")
                ok = integ.step(y, f0, hi)
                if not ok:
                    self.n_rejected_steps += 1
                    rejected = True
                    hi *= 0.25
                    truncated = True
                    continue
                yn = integ.y_new
                if self._pin:
                    if self.s[0] == 0:
                        yn[W1] = 0.0
                    if self.s[1] == 0:
                        yn[W2] = 0.0
                err = error_norm(integ.err, y, yn, self._atol, self._rtol, self._scr)
                if not err <= 1.0:  # also catches nan
                    self.n_rejected_steps += 1
                    rejected = True
                    hi = new_step_size(hi, err, True) if err == err else hi * 0.25
                    truncated = True
                    continue
                self._evaluate(yn, f1, self._J1)
                sv1 = self._sv
                ym = integ.midpoint(y)
                if self._dissipative:
                    # loss over the step: Simpson with the dense-output midpoint; its difference to
                    # the trapezoidal rule is the quadrature error estimate, controlled like the
                    # state error (the dissipated power is not smooth where forces clip)
                    P0, P1 = sv0[11], sv1[11]
                    self._evaluate(ym, self._fscratch, None)
                    svm = self._sv
                    Pm = svm[11]
                    dloss = hi / 6.0 * (P0 + 4.0 * Pm + P1)
                    errE = abs(dloss - 0.5 * hi * (P0 + P1)) / (self._rtol * (E_REF + dloss))
                    if not errE <= 1.0:
                        self.n_rejected_steps += 1
                        rejected = True
                        hi = new_step_size(hi, errE, True) if errE == errE else hi * 0.25
                        truncated = True
                        continue
                    if errE > err:
                        err = errE
                theta = self._state_events(y, ym, yn)
                # a contact made or lost inside the step makes the stuck planets' friction
                # margins jump there, and their secant estimate, from the start, middle and end
                # values, then lands early again and again (Zeno): locate the contact first
                if self._pin and theta >= 1.0 - 1e-6:
                    # a stuck planet whose required friction exceeds the capacity breaks away
                    tolc = STICK_RTOL * (sv1[9] + sv1[10])
                    for g0, gm, g1 in zip(self._margins_from(sv0), self._margins_from(svm),
                                          self._margins_from(sv1)):
                        if g0 != math.inf and g0 >= 0.0:
                            theta = min(theta, self._crossing(g0 + tolc, gm + tolc, g1 + tolc, True))
                if theta < 1.0 - 1e-6 and located < 4 and theta * hi > hmin:
                    located += 1
                    self.n_rejected_steps += 1
                    hi = hi * theta * (1.0 + 1e-4) + 1e-14
                    truncated = True
                    continue
                break
            # ---- accept
            self.n_internal_steps += 1
            h_prop = new_step_size(hi, err, rejected)
            h_ctrl = max(h_ctrl, h_prop) if truncated and not rejected else h_prop
            if self._dissipative:
                self.energy_loss += dloss
            # work: exact from the state change (momentum balance of the relative motion)
            ya = y.tolist()
            yb = yn.tolist()
            psiBa, th1a, th2a = self._angles(ya)
            psiBb, th1b, th2b = self._angles(yb)
            dpsiA, dpsiB = yb[PSI] - ya[PSI], psiBb - psiBa
            if speed:
                wc_b = wc_start + ac * (tin + hi)
                dphic = wc_a * hi + 0.5 * ac * hi * hi
                W = (self.Jtot * ac * dphic
                     + JA * (yb[VA] * wc_b - ya[VA] * wc_a - ac * dpsiA)
                     + JB * (yb[VB] * wc_b - ya[VB] * wc_a - ac * dpsiB)
                     + J1 * (yb[W1] * wc_b - ya[W1] * wc_a - ac * (th1b - th1a))
                     + J2 * (yb[W2] * wc_b - ya[W2] * wc_a - ac * (th2b - th2a))
                     + tL * dpsiA + tR * dpsiB)
                phic += dphic
                wc_a = wc_b
            else:
                dphic = yb[PHIC] - ya[PHIC]
                W = tc * dphic + tL * (dphic + dpsiA) + tR * (dphic + dpsiB)
                wc_b = yb[WC]
            self.work_in += W
            if self._var:
                self._book_parametric(ya, yb)
            y[:] = yn
            tin += hi
            remaining = h - tin
            # contact transitions
            if self._bl or self._contact:
                fl = self._flags(y)
                self.n_contact_transitions += sum(1 for a, b in zip(fl, self._contact_flags) if a != b)
                self._contact_flags = fl
            # friction modes
            switched = False
            if self._pin:
                zeroed = []
                for i, idx in ((0, W1), (1, W2)):
                    s = self.s[i]
                    w = float(y[idx])
                    # slip speed reached zero, or decays towards it below the resolution of the
                    # integrator (overdamped approach to the capacity limit): try to stick
                    if s != 0 and (s * w <= 0.0 or (abs(w) <= self._w_stick and s * f1[idx] < 0.0)):
                        self._stick_impulse(y, i, wc_b)
                        zeroed.append(i)
                m1 = self._margins_from(sv1)
                tolc = -STICK_RTOL * (sv1[9] + sv1[10])
                if zeroed or m1[0] < tolc or m1[1] < tolc:
                    self.n_mode_switches += self._settle_modes(y, zeroed)
                    switched = True
            if not switched:
                f0, f1 = f1, f0
                integ.J, self._J1 = self._J1, integ.J
                self._f0, self._f1 = f0, f1
                sv0 = sv1
            else:
                f0, f1 = self._f0, self._f1
                sv0 = self._sv
        self.h_next = h_ctrl
        self._f0_key = (tL, tR, tc, ac if speed else None, self.s[0], self.s[1])
        self._sv0 = sv0
        if speed:
            self.wc = float(self.w_ref)
            self.phic = phic
        else:
            self.wc = float(y[WC])
            self.phic = float(y[PHIC])
        self.t = t + h
        self.loss_last_step = self.energy_loss - loss0
        self._last_h = h
        self.n_steps += 1
        self._refresh_outputs(sv0 if (not speed or ac == 0.0) else None)

    def _margins_from(self, sv) -> tuple[float, float]:
        out = []
        for i in (0, 1):
            if self._pin and self.s[i] == 0:
                out.append(sv[9 + i] - abs(sv[7 + i]))
            else:
                out.append(math.inf)
        return out[0], out[1]

    def _book_parametric(self, ya, yb) -> None:
        """Energy put into the mesh springs by single/double contact switches (rectangular
        stiffness wave): V(d, k_after) - V(d, k_before) at the end of the step."""
        psiBa, th1a, _ = self._angles(ya)
        psiBb, th1b, _ = self._angles(yb)
        ua = (self.rbA * ya[PSI], self.rbB * psiBa, self.rb1 * th1a)
        ub = (self.rbA * yb[PSI], self.rbB * psiBb, self.rb1 * th1b)
        for mi, (idx, m) in enumerate(zip((DA, DB, D12), self.md)):
            Va = self._potential(m, yb[idx], ua[mi])
            Vb = self._potential(m, yb[idx], ub[mi])
            if Va != Vb:
                self.parametric_work += self.n * (Vb - Va)

    # ================================================================== outputs
    def _refresh_outputs(self, sv=None) -> None:
        """Outputs at the current state; the speed drive reports the torque that holds the
        reached speed (carrier acceleration 0), as the rigid model does. ``sv``: side values of
        an evaluation at the current state that already used that carrier acceleration."""
        if sv is None:
            ac_keep = self._ac
            if self.speed_drive:
                self._ac = 0.0
            self._evaluate(self.y, self._fscratch, None)
            self._ac = ac_keep
            sv = self._sv
        self._out = sv
        self._V = None
        yl = self.y.tolist()
        self._psiB = self._angles(yl)[0]

    def _potential_energy(self) -> float:
        yl = self.y.tolist()
        psiB, th1, _ = self._angles(yl)
        us = (self.rbA * yl[PSI], self.rbB * psiB, self.rb1 * th1)
        return self.n * sum(self._potential(m, yl[idx], us[i])
                            for i, (idx, m) in enumerate(zip((DA, DB, D12), self.md)))

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
        return o[3] + o[4] + self.n * (o[5] + o[6])

    @property
    def tau_mesh_L(self) -> float:
        """Torque the meshes deliver to sun A (N m)."""
        return self._out[3]

    @property
    def tau_mesh_R(self) -> float:
        return self._out[4]

    @property
    def mesh_forces(self) -> MeshForces:
        """Normal tooth forces per planet pair (N), positive on the drive flanks."""
        o = self._out
        return MeshForces(o[0], o[1], o[2])

    @property
    def locking_torque(self) -> float:
        """Pin friction as a generalised force on the differential coordinate (N m), the rigid
        model's ``Q_f``: n (rho_1 M_1 + rho_2 M_2)."""
        o = self._out
        return self.n * (self.rho1 * o[7] + self.rho2 * o[8]) if self._pin else 0.0

    @property
    def locking_capacity(self) -> float:
        o = self._out
        return self.n * (abs(self.rho1) * o[9] + abs(self.rho2) * o[10])

    @property
    def power_loss(self) -> float:
        """Mean dissipated power over the last step (W), >= 0."""
        return self.loss_last_step / self._last_h if self._last_h > 0.0 else self._out[11]

    @property
    def kinetic_energy(self) -> float:
        y = self.y.tolist()
        wc = self.wc
        n = self.n
        return 0.5 * (self.Jc * wc * wc + self.JA * (wc + y[VA]) ** 2 + self.JB * (wc + y[VB]) ** 2
                      + n * self.J1 * (wc + y[W1]) ** 2 + n * self.J2 * (wc + y[W2]) ** 2)

    @property
    def potential_energy(self) -> float:
        """Elastic energy of all mesh springs (J)."""
        if self._V is None:
            self._V = self._potential_energy()
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
                "w_ref", "tau_c", "tau_L", "tau_R")

    def get_state(self) -> dict:
        """Full state (JSON-serialisable): continuous state, friction modes, contact flags,
        integrator memory (next internal step size), bookkeeping and the held inputs."""
        s = {k: getattr(self, k) for k in self._SCALARS}
        for k in ("w_ref", "tau_c", "tau_L", "tau_R"):
            s[k] = float(s[k])
        s["y"] = self.y.tolist()
        s["modes"] = list(self.s)
        s["contact_flags"] = list(self._contact_flags)
        return s

    def set_state(self, state: dict) -> None:
        for k in self._SCALARS:
            setattr(self, k, state[k])
        self.y[:] = state["y"]
        self.s = [int(v) for v in state["modes"]]
        self._contact_flags = [int(v) for v in state["contact_flags"]]
        self._f0_key = None
        self._refresh_outputs()
