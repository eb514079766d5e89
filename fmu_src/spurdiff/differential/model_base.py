"""The contract every fidelity of the differential meets (rigid, compliant, contact).

The FMU adapter (:mod:`spurdiff.fmi.differential_fmu`), the shaft coupling (:mod:`spurdiff.differential.shafts`)
and the harness's direct runs use a model only through this contract, so any fidelity can stand
in for another.
"""
from __future__ import annotations


class DifferentialModel:
    """A differential model of any fidelity.

    **Parameters** are given to the constructor (:class:`spurdiff.differential.params.DifferentialParams`, plus
    the level's own, e.g. :class:`spurdiff.differential.mesh.MeshParams`) and validated by :meth:`initialize`:
    a bad value raises :class:`spurdiff.errors.ParameterError` naming the field and its range.

    **Inputs** (attributes, SI units, Modelica signs; held constant over a communication step):
    ``w_ref`` carrier speed target (``carrierDrive = "speed"``: reached linearly over the step),
    ``tau_c`` carrier torque (``carrierDrive = "torque"``), ``tau_L`` and ``tau_R`` the external
    torques on the left (sun A) and right (sun B) flanges (a load is negative). **Start values**:
    ``w_start_carrier``, ``w_start_left`` (nan: the carrier's speed). A non-finite input raises
    ParameterError naming it, in the model's names (``INPUT_NAMES``, which an adapter may map
    to its interface's names).

    **Life cycle**: :meth:`initialize` (t0) validates, derives the constants and sets a consistent
    initial state; :meth:`do_step` (t, h) advances one communication step. A step that cannot be
    completed raises :class:`spurdiff.errors.StepError`; with ``ATOMIC_STEP`` the model is then
    exactly as before the call (an FMU answers fmi2Discard).

    **Outputs** (read after initialize and after each step): speeds ``wc``, ``w_L``, ``w_R``,
    ``wd`` (sun A relative to the carrier), angles ``phic``, ``phi_L``, ``phi_R``, torques
    ``tau_drive`` (what the carrier drive delivers), ``tau_mesh_L``, ``tau_mesh_R`` (what the
    gears deliver to the suns), ``mesh_forces`` (:class:`spurdiff.differential.statics.MeshForces`, per
    planet pair), ``locking_torque`` and ``locking_capacity`` (pin friction on the differential
    coordinate), ``stuck`` (``stuck_indicator`` as 1.0 / 0.0); counters ``n_steps``, ``n_mode_switches``,
    ``n_internal_steps``, ``n_contact_transitions``; the half-shaft outputs ``tau_mean_L/R``,
    ``tau_end_L/R``, ``theta_L/R``, ``dw_pred_L/R`` (defaults below). Calculated parameters:
    ``geometry``, ``K``, ``K_coast`` (locking coefficients), ``Mcc``, ``Mdd`` (inertias of the
    carrier and differential modes), ``mesh_model`` (the level's name).

    **Energy accounting**: ``work_in`` (work of the drive and the loads since the start),
    ``energy_loss`` (dissipated, never decreasing), ``power_loss`` (mean over the last step),
    ``kinetic_energy`` and ``potential_energy`` (elastic, 0 for rigid gears) balance:
    ``work_in = delta kinetic_energy + delta potential_energy + energy_loss`` (the mesh levels'
    stiffness wave adds its ``parametric_work`` on the left); the tests check it per level.

    **State**: :meth:`get_state` returns the whole state as JSON-serialisable values (continuous
    state, friction modes, integrator memory, bookkeeping, the held inputs); :meth:`set_state`
    puts it back, so that stepping on reproduces the original continuation bit for bit, also on a
    fresh instance initialized with the same parameters.
    """

    mesh_model = ""
    ATOMIC_STEP = False
    INPUT_NAMES = {"w_ref": "w_ref", "tau_c": "tau_c", "tau_L": "tau_L", "tau_R": "tau_R"}

    # Outputs every coupling answers (the FMU's outputs bind to them): the shaft-owning coupling
    # (spurdiff.differential.shafts.ShaftedDifferential) computes the half-shafts' torques, twists and the
    # wheels' predicted speed changes; with the torque coupling the flange torques are the shaft
    # torques, there is no twist and no prediction. Levels without contacts or springs count no
    # contact transitions and store no elastic energy.
    theta_L = theta_R = 0.0
    dw_pred_L = dw_pred_R = 0.0
    n_contact_transitions = 0
    potential_energy = 0.0
    parametric_work = 0.0     # the stiffness wave's work (mesh levels with meshStiffnessVariation)

    def __init__(self, params) -> None:
        """The parameters ``params`` (:class:`spurdiff.differential.params.DifferentialParams`), the inputs
        at 0 and the start values (``w_start_left`` nan: the carrier's speed)."""
        self.params = params
        # inputs
        self.w_ref = 0.0
        self.tau_c = 0.0
        self.tau_L = 0.0
        self.tau_R = 0.0
        # start values
        self.w_start_carrier = 0.0
        self.w_start_left = float("nan")

    @property
    def loaded_flanks(self) -> int:
        """Which flanks carry the load: 1 the drive flanks (T_A + T_B > 0, the carrier drives the
        suns), -1 the coast flanks (the suns drive the carrier), 0 none."""
        T0 = self.tau_mesh_L + self.tau_mesh_R
        return 1 if T0 > 0.0 else -1 if T0 < 0.0 else 0

    @property
    def tau_mean_L(self) -> float:
        return -self.tau_L

    @property
    def tau_mean_R(self) -> float:
        return -self.tau_R

    tau_end_L = tau_mean_L
    tau_end_R = tau_mean_R

    @property
    def stuck_indicator(self) -> float:
        """``stuck`` as a Real: 1 while locked by friction, else 0."""
        return 1.0 if self.stuck else 0.0

    def initialize(self, t0: float = 0.0) -> None:
        raise NotImplementedError

    def do_step(self, t: float, h: float) -> None:
        raise NotImplementedError

    def get_state(self) -> dict:
        raise NotImplementedError

    def set_state(self, state: dict) -> None:
        raise NotImplementedError
