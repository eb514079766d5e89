"""FMI interface of SpurDifferential.fmu, declared once: the FMU's name, description and variables,
each bound to what it stands for (see :mod:`spurdiff.fmi.variables`), and ``build_model``.

Kept free of pythonfmu so the build step, the direct runner and the tests can read it. Names are
Modelica-style (``carrier.w``, ``left.tau``, ``sunA.z``); units are SI with engineering display
units. Parameters bind to the fields of :class:`Setup` (the parameter objects ``diff``, ``mesh``,
``shafts``), whose defaults, and so the start values, come from ``spurdiff/data/differential.toml``;
inputs and outputs bind to the attributes every differential model answers (the torque-coupled
models through :class:`spurdiff.differential.model_base.DifferentialModel`, the shaft-owning one through
:class:`spurdiff.differential.shafts.ShaftedDifferential`).

(Over 400 lines because it is the declaration: 94 variables, one line each, and the parameter
set-up they bind to.)
"""
from __future__ import annotations

from dataclasses import field, replace

from spurdiff.attrpath import record, resolve
from spurdiff.errors import bound_of
from spurdiff.fmi.binding import bindings, build_params, renamed
from spurdiff.errors import ParameterError
from spurdiff.fmi.variables import Var
from spurdiff.differential.locking import torque_bias_ratio
from spurdiff.gears.axial import AxialLayout
from spurdiff.datafile import parse_bundled
from spurdiff.gears.design import derive
from spurdiff.gears.design_sets import gear_set, table_from_data
from spurdiff.gears.phasing import mesh_phases
from spurdiff.differential.mesh import MeshParams
from spurdiff.differential.params import DifferentialParams
from spurdiff.differential.rigid import RigidDifferential
from spurdiff.differential.shaft_params import SHAFT_COUPLINGS, ShaftsParams
from spurdiff.differential.watches import OVERSPEED_LIMIT, CapacityWatch, OverspeedWatch, attach
from spurdiff.gears.capacity import CapacityParams

FMU_NAME = "SpurDifferential"
DESCRIPTION = ("Spur-gear planetary inter-wheel differential: two suns on the half-shafts, pairs of "
               "meshing planets on a driven carrier, pin-bushing friction locking")
# The default experiment, what any host runs with nothing connected (spurdiff/data/default_experiment.toml,
# docs/use-the-fmu.md): a gear set the FMU does not call failing hardware (the designed set, sun B
# trimmed to the 17 mm it meshes on: no rating or stack-up finding at capacity.T0), the paper's carrier
# speed imposed, an uneven load within the locking capacity (-200 / -300 N m) and sun A starting 20 rad/s
# ahead of the carrier: the locking friction brakes the relative speed to 0 in about 7 ms, then holds
# the uneven split locked (slip, then stick). The paper's set stays the physics default
# (DifferentialParams); the paper scenes select it (gearSet = "paper"). A slipping (cornering) steady
# state cannot come from constant inputs (Coulomb locking with constant torques sticks or runs away;
# shaftCoupling = wheel needs advancing wheel angles): the recipes in docs/use-the-fmu.md drive one.
DEFAULT_EXPERIMENT = {"startTime": 0.0, "stopTime": 0.3, "stepSize": 1e-3}
_DEFAULT_DATA = parse_bundled("default_experiment.toml")
DEFAULT_GEAR_TABLE = table_from_data(_DEFAULT_DATA, gear_set(_DEFAULT_DATA["gearSet"]))
DEFAULT_CARRIER_SPEED = _DEFAULT_DATA["inputs"]["carrierSpeed"]      # rad/s, the paper's carrier speed
DEFAULT_LEFT_LOAD = _DEFAULT_DATA["inputs"]["leftLoad"]              # N m on sun A (a load is negative)
DEFAULT_RIGHT_LOAD = _DEFAULT_DATA["inputs"]["rightLoad"]            # N m on sun B
DEFAULT_DIFFERENTIAL_START = _DEFAULT_DATA["inputs"]["differentialStart"]   # rad/s, sun A - carrier

# FMI 3.0: first derivatives of the outputs output_rates answers (shaft torques and twists, flange
# and carrier speeds and angles; spurdiff.differential.derivatives), the others refused by name
MAX_OUTPUT_DERIVATIVE_ORDER = 1
# FMI 3.0: with earlyReturnAllowed, fmi3DoStep ends at a stick/slip transition (adapter.fmi2_do_step_early)
MIGHT_RETURN_EARLY = True


def output_rates(model) -> dict[str, float]:
    """The FMI 3.0 output derivatives of ``model`` (any level; spurdiff.differential.derivatives)."""
    from spurdiff.differential import derivatives                  # (imported at the first derivative asked
    from spurdiff.differential.mesh import rates as mesh_rates     # for: a start imports neither)
    return derivatives.output_rates(model, mesh_rates.sun_accelerations)


MESH_MODELS = ("rigid", "compliant", "contact")
EFFECTS = ("backlash", "meshStiffnessVariation", "pinFriction", "flankFriction")


@record
class Setup:
    """What the parameters bind to: the parameter objects and the start values of the model."""

    diff: DifferentialParams = field(default_factory=lambda: DifferentialParams(table=DEFAULT_GEAR_TABLE))
    mesh: MeshParams = field(default_factory=MeshParams)
    shafts: ShaftsParams = field(default_factory=ShaftsParams)
    capacity: CapacityParams = field(default_factory=CapacityParams)   # load capacity (block after VARIABLES)
    shaftCoupling: str = "torque"
    w_start_carrier: float = 0.0
    w_start_differential: float = DEFAULT_DIFFERENTIAL_START   # the default experiment's slip
    overspeedLimit: float = 0.0        # rad/s, |w_A - w_c|; 0: the pin bushings' sliding-speed limit


_DEFAULTS = Setup()


def _p(name: str, bind: str, description: str, unit: str | None = None, display: str | None = None,
       kind: str = "Real") -> Var:
    """A parameter whose start value is its bound field's default (differential.toml) and whose min and
    max are the range the field's class declares and checks (spurdiff.errors)."""
    b = bound_of(_DEFAULTS, bind)
    return Var(name, "parameter", description, unit, display, resolve(_DEFAULTS, bind), kind=kind, bind=bind,
               min=None if b is None else b.lo, max=None if b is None else b.hi)


def _gear_vars(name: str, label: str) -> list[Var]:
    g = f"diff.table.{name}"
    return [
        _p(f"{name}.z", f"{g}.z", f"Number of teeth of {label}", kind="Integer"),
        _p(f"{name}.x", f"{g}.x", f"Profile-shift coefficient of {label}", "1"),
        _p(f"{name}.b", f"{g}.b", f"Face width of {label}", "m", "mm"),
        _p(f"{name}.da", f"{g}.da", f"Tip diameter of {label} (0: untrimmed m (z + 2 ha + 2 x))", "m", "mm"),
        _p(f"{name}.axialStart", f"{g}.axialStart", f"Axial position where the face of {label} starts, from carrier "
           "wall A's inner face (axial layout, spurdiff.gears.axial)", "m", "mm"),
        Var(f"{name}.dF", "calculatedParameter",
            f"Form diameter of {label}: where its involute starts (generating rack, undercut included)", "m", "mm"),
    ]


def _mesh_vars(mesh: str, label: str) -> list[Var]:
    g = f"geometry.mesh{mesh}"
    return [
        Var(f"mesh{mesh}.alpha_w", "calculatedParameter", f"Operating pressure angle of mesh {label}", "rad", "deg",
            bind=f"{g}.alpha_w"),
        Var(f"mesh{mesh}.a", "calculatedParameter", f"Operating centre distance of mesh {label}", "m", "mm",
            bind=f"{g}.a"),
        Var(f"mesh{mesh}.rw1", "calculatedParameter", f"Operating pitch radius of the first gear of mesh {label}", "m",
            "mm", bind=f"{g}.rw1"),
        Var(f"mesh{mesh}.rw2", "calculatedParameter", f"Operating pitch radius of the second gear of mesh {label}", "m",
            "mm", bind=f"{g}.rw2"),
        Var(f"mesh{mesh}.epsilon_alpha", "calculatedParameter", f"Transverse contact ratio of mesh {label}", "1",
            bind=f"{g}.epsilon_alpha"),
        Var(f"mesh{mesh}.epsilon_usable", "calculatedParameter",
            f"Usable transverse contact ratio of mesh {label} (involute from form circle to tip on both gears; "
            "used by the ISO stiffness and the stiffness wave)", "1", bind=f"{g}.epsilon_usable"),
        Var(f"mesh{mesh}.b", "calculatedParameter", f"Face width of mesh {label}: the axial overlap of its gears "
            "(axial layout)", "m", "mm"),
        Var(f"mesh{mesh}.axialCentre", "calculatedParameter", f"Axial position of the middle of mesh {label}, from "
            "carrier wall A's inner face", "m", "mm"),
        Var(f"mesh{mesh}.phase", "calculatedParameter",
            f"Initial phase of the drive flanks of mesh {label} along its usable path, in base pitches "
            "(tooth positions; an A1 drive pair starts at its pitch point)", "1"),
    ]


VARIABLES: list[Var] = [
    # --- inputs
    Var("carrier.w_ref", "input", "Carrier speed target (carrierDrive = speed); reached linearly over each step "
        "(start value: the paper's 1.389 rad/s, the default experiment)",
        "rad/s", "rpm", DEFAULT_CARRIER_SPEED, min=-1e4, max=1e4, bind="w_ref"),
    Var("carrier.tau", "input", "External torque driving the carrier (carrierDrive = torque)", "N.m", "N.mm", 0.0,
        min=-1e6, max=1e6, bind="tau_c"),
    Var("left.tau", "input", "shaftCoupling = torque: external torque on the left half-shaft flange (sun A), "
        "Modelica sign: a load is negative (start value: the default experiment's, -200 N m; ignored with "
        "shaftCoupling = wheel)", "N.m", "N.mm", DEFAULT_LEFT_LOAD, min=-1e6, max=1e6, bind="tau_L"),
    Var("right.tau", "input", "shaftCoupling = torque: external torque on the right half-shaft flange (sun B), "
        "Modelica sign: a load is negative (start value: the default experiment's, -300 N m; ignored with "
        "shaftCoupling = wheel)", "N.m", "N.mm", DEFAULT_RIGHT_LOAD, min=-1e6, max=1e6, bind="tau_R"),
    Var("leftWheel.phi", "input", "shaftCoupling = wheel: angle of the wheel end of the left half-shaft "
        "(WheelLoad's wheel.phi)", "rad", "deg", 0.0, min=-1e9, max=1e9, bind="wheelL_phi"),
    Var("leftWheel.w", "input", "shaftCoupling = wheel: speed of the wheel end of the left half-shaft "
        "(WheelLoad's wheel.w)", "rad/s", "rpm", 0.0, min=-1e4, max=1e4, bind="wheelL_w"),
    Var("rightWheel.phi", "input", "shaftCoupling = wheel: angle of the wheel end of the right half-shaft",
        "rad", "deg", 0.0, min=-1e9, max=1e9, bind="wheelR_phi"),
    Var("rightWheel.w", "input", "shaftCoupling = wheel: speed of the wheel end of the right half-shaft",
        "rad/s", "rpm", 0.0, min=-1e4, max=1e4, bind="wheelR_w"),
    # the wheel side's linear model over the coming step (WheelLoad's outputs of the same names; all 0:
    # the wheel side keeps its speed over the step, the linear extrapolation; spurdiff.differential.shafts.WheelSurrogate)
    *[v for side, m in (("left", "wheelL_model"), ("right", "wheelR_model")) for v in (
        Var(f"{side}Wheel.aFree", "input", f"shaftCoupling = wheel, interface model of the {side} wheel: its "
            "acceleration without the shaft torque (WheelLoad's wheel.aFree; 0 with the defaults: speed held)",
            "rad/s2", None, 0.0, min=-1e7, max=1e7, bind=f"{m}.a_free"),
        Var(f"{side}Wheel.invJ", "input", f"Interface model of the {side} wheel: acceleration per N m of shaft "
            "torque (WheelLoad's wheel.invJ; 0: speed held)", "1/(kg.m2)", None, 0.0, min=0.0, max=1e6,
            bind=f"{m}.inv_J"),
        Var(f"{side}Wheel.dadw", "input", f"Interface model of the {side} wheel: acceleration per rad/s of "
            "wheel speed (WheelLoad's wheel.dadw, <= 0)", "1/s", None, 0.0, min=-1e6, max=0.0, bind=f"{m}.dadw"),
        Var(f"{side}Wheel.tyreTorqueRate", "input", f"Interface model of the {side} wheel: rate of its tyre "
            "torque (WheelLoad's tyre.torqueRate)", "N.m/s", None, 0.0, min=-1e9, max=1e9, bind=f"{m}.q_rate"),
        Var(f"{side}Wheel.tyreStiffness", "input", f"Interface model of the {side} wheel: change of the tyre "
            "torque's rate per rad/s of wheel speed (WheelLoad's tyre.torqueStiffness, >= 0)", "N.m/rad", None,
            0.0, min=0.0, max=1e9, bind=f"{m}.c_t"),
        Var(f"{side}Wheel.tyreRelaxation", "input", f"Interface model of the {side} wheel: relaxation rate of "
            "its tyre torque (WheelLoad's tyre.relaxationRate, >= 0)", "1/s", None, 0.0, min=0.0, max=1e6,
            bind=f"{m}.r_t"),
    )],
    # --- outputs (values at the end of the last step; no direct feedthrough)
    Var("leftShaft.tau", "output", "shaftCoupling = wheel: torque of the left half-shaft on its wheel, mean over "
        "the last step (positive drives the wheel forward; connect to WheelLoad's shaftIn.tau); "
        "torque: -left.tau", "N.m", "N.mm", bind="tau_mean_L"),
    Var("rightShaft.tau", "output", "shaftCoupling = wheel: torque of the right half-shaft on its wheel, mean over "
        "the last step; torque: -right.tau", "N.m", "N.mm", bind="tau_mean_R"),
    Var("leftShaft.dwWheel", "output", "shaftCoupling = wheel: change of the left wheel's speed over the last "
        "step that leftShaft.tau was computed for (from the interface model; connect to WheelLoad's "
        "shaftIn.dw)", "rad/s", "rpm", bind="dw_pred_L"),
    Var("rightShaft.dwWheel", "output", "shaftCoupling = wheel: change of the right wheel's speed over the "
        "last step that rightShaft.tau was computed for (connect to WheelLoad's shaftIn.dw)", "rad/s", "rpm",
        bind="dw_pred_R"),
    Var("leftShaft.tauEnd", "output", "Torque of the left half-shaft on its wheel at the end of the last step",
        "N.m", "N.mm", bind="tau_end_L"),
    Var("rightShaft.tauEnd", "output", "Torque of the right half-shaft on its wheel at the end of the last step",
        "N.m", "N.mm", bind="tau_end_R"),
    Var("leftShaft.phi_rel", "output", "Twist of the left half-shaft, sun angle - wheel angle (0 with "
        "shaftCoupling = torque)", "rad", "deg", bind="theta_L"),
    Var("rightShaft.phi_rel", "output", "Twist of the right half-shaft (0 with shaftCoupling = torque)", "rad", "deg",
        bind="theta_R"),
    Var("carrier.w", "output", "Carrier speed", "rad/s", "rpm", bind="wc"),
    Var("carrier.phi", "output", "Carrier angle", "rad", "deg", bind="phic"),
    Var("left.w", "output", "Left flange (sun A) speed", "rad/s", "rpm", bind="w_L"),
    Var("left.phi", "output", "Left flange (sun A) angle", "rad", "deg", bind="phi_L"),
    Var("right.w", "output", "Right flange (sun B) speed", "rad/s", "rpm", bind="w_R"),
    Var("right.phi", "output", "Right flange (sun B) angle", "rad", "deg", bind="phi_R"),
    Var("carrier.tauDrive", "output", "Torque the carrier drive delivers", "N.m", "N.mm", bind="tau_drive"),
    Var("left.tauMesh", "output", "Torque the meshes deliver to sun A", "N.m", "N.mm", bind="tau_mesh_L"),
    Var("right.tauMesh", "output", "Torque the meshes deliver to sun B", "N.m", "N.mm", bind="tau_mesh_R"),
    Var("mesh.F_A1", "output", "Normal tooth force of mesh sun A / planet 1, per planet pair", "N",
        bind="mesh_forces.F_A1"),
    Var("mesh.F_B2", "output", "Normal tooth force of mesh sun B / planet 2, per planet pair", "N",
        bind="mesh_forces.F_B2"),
    Var("mesh.F_12", "output", "Normal tooth force of mesh planet 1 / planet 2, per planet pair", "N",
        bind="mesh_forces.F_12"),
    Var("lockingTorque", "output",
        "Pin-bushing friction torque on the differential motion, as a sun-torque difference (positive speeds sun A up)",
        "N.m", "N.mm", bind="locking_torque"),
    Var("lockingCapacity", "output",
        "Limit of the friction in its present mode as a torque difference: stuck, the largest it can hold "
        "(break-away, mu_pin); slipping, the sliding friction (mu_pinDynamic): n sum_i |rho_i| (mu r_d |F_pin,i| "
        "+ preload share) from the pin loads (lockingLaw = pinFriction), K |T_A + T_B| + preload (paper)", "N.m", "N.mm",
        bind="locking_capacity"),
    Var("powerLoss", "output", "Friction power, mean over the last step (>= 0)", "W", bind="power_loss"),
    Var("energyLoss", "output", "Friction energy dissipated since the start", "J", bind="energy_loss"),
    Var("workIn", "output", "Work done on the differential by the carrier drive and the flange torques since the start", "J",
        bind="work_in"),
    Var("kineticEnergy", "output", "Kinetic energy of all parts", "J", bind="kinetic_energy"),
    Var("stuck", "output", "1 while the differential is locked by friction (no relative motion), else 0", "1",
        bind="stuck_indicator"),
    Var("modeSwitches", "output", "Number of stick/slip mode switches since the start", None, None, 0, kind="Integer",
        bind="n_mode_switches"),
    Var("internalSteps", "output", "Number of internal integration steps since the start", None, None, 0, kind="Integer",
        bind="n_internal_steps"),
    Var("contactTransitions", "output",
        "Number of tooth contact losses and re-engagements since the start (backlash, compliant/contact)",
        None, None, 0, kind="Integer", bind="n_contact_transitions"),
    Var("potentialEnergy", "output", "Elastic energy stored in the mesh springs (0 at rigid)", "J",
        bind="potential_energy"),
    Var("parametricWork", "output", "Work of the mesh stiffness wave on the gears since the start (0 without "
        "meshStiffnessVariation): workIn + parametricWork = change of kineticEnergy + potentialEnergy + energyLoss",
        "J", bind="parametric_work"),
    Var("loadedFlanks", "output", "Flanks that carry the load: 1 drive (the carrier drives the suns, "
        "T_A + T_B > 0; lockingCoefficient applies), -1 coast (the suns drive the carrier; "
        "lockingCoefficientCoast), 0 unloaded", None, None, 0, kind="Integer", bind="loaded_flanks"),
    Var("overspeed", "output", "1 while the differential speed |w_A - w_c| is above overspeedLimit (a runaway: "
        "the first time is logged as a warning), else 0", "1", bind="overspeed_watch.indicator"),
    Var("overspeedLimit", "parameter", "Largest differential speed |w_A - w_c| the pin bushings are rated for "
        "(0: the bronze bushing's sliding-speed limit 3.81 m/s, spurdiff/data/pin_bushing.toml, over r_collar and the "
        "planets' spin ratio z_sun / z_planet)",
        "rad/s", "rpm", 0.0, min=OVERSPEED_LIMIT.lo, bind="overspeedLimit"),
    Var("overspeedLimitInUse", "calculatedParameter", "The differential-speed limit in use", "rad/s", "rpm"),
    Var("nStates", "calculatedParameter", "Number of continuous states of the selected fidelity", None, None, 0,
        kind="Integer"),
    Var("activeEffects", "calculatedParameter",
        "Effects in use, comma separated: the mesh model, then the enabled effects that act", None, None, "",
        kind="String"),
    # --- structural parameters (fidelity: only what is switched on allocates states and costs time)
    Var("meshModel", "parameter",
        "Mesh fidelity: rigid (kinematic, 2 states) | compliant (linear mesh springs, planets free) | "
        "contact (ADAMS IMPACT law, planets free)", None, None, "rigid", kind="String", bind="mesh.level"),
    Var("backlash", "parameter", "Circumferential backlash per mesh: contact loss and impacts (compliant/contact)",
        None, None, False, kind="Boolean", bind="mesh.backlash"),
    Var("meshStiffnessVariation", "parameter",
        "Mesh stiffness varies with single/double tooth contact as the gears turn (compliant/contact)",
        None, None, False, kind="Boolean", bind="mesh.meshStiffnessVariation"),
    Var("pinFriction", "parameter", "Load-dependent pin-bushing friction (the locking friction), every level",
        None, None, True, kind="Boolean", bind="mesh.pinFriction"),
    Var("flankFriction", "parameter", "Coulomb friction on the tooth flanks (compliant/contact)",
        None, None, False, kind="Boolean", bind="mesh.flankFriction"),
    _p("tolerance", "mesh.tolerance", "Relative accuracy of the internal integrator (compliant/contact)", "1"),
    _p("maxInternalSteps", "mesh.maxInternalSteps",
       "Internal steps allowed per communication step before doStep discards", None, kind="Integer"),
    _p("solver.kernel", "mesh.kernel", "Implementation of the compliant/contact levels, of the rigid level's "
       "pin-load solve and of the step with the half-shafts (shaftCoupling = wheel, rigid): auto (the compiled kernel shipped in the FMU when it loads, else the Python reference, "
       "with the reason logged) | compiled (refuse to start without it) | python (the pure-Python reference; "
       "same results, slower)", kind="String"),
    _p("solver.method", "mesh.method", "Integration method of the compliant/contact levels: auto (RODAS5P at "
       "the contact level, ROS34PW2 at the compliant level) | ros34pw2 (ROS34PW2, order 3, a Rosenbrock-W "
       "method that reuses its Jacobian) | rodas5p (RODAS5P, order 5, a Jacobian every internal step; several "
       "times fewer internal steps from tolerance 1e-4 down, docs/accuracy.md)",
       kind="String"),
    Var("solver.nativeStep", "parameter", "At rigid with a compiled step in use (shaftCoupling = wheel: the "
        "half-shafts' step with the pin-load law; torque: the rigid step, every locking law): true = the whole communication step runs in C without entering Python (the FMU's native step: "
        "the inputs checked, the step, the watches, the outputs; the same results bit for bit; the state is "
        "handed back to Python before any other call reads it) | false = every step runs through the Python "
        "model around the compiled kernel (for comparison)", None, None, True, kind="Boolean",
        bind="mesh.nativeStep"),
    Var("solver.kernelInUse", "calculatedParameter", "Implementation that runs the compliant/contact levels, "
        "or the rigid level's pin-load solve: compiled | python (and why) | none (rigid without a pin-load "
        "solve: lockingLaw = paper, or no pin friction); with shaftCoupling = wheel followed by '; half-shafts: ' "
        "and the implementation of the step with the half-shafts", None, None, "", kind="String"),
    Var("carrierDrive", "parameter", "How the carrier is driven: speed (carrier.w_ref) | torque (carrier.tau)",
        None, None, "speed", kind="String", bind="diff.carrierDrive"),
    Var("shaftCoupling", "parameter",
        "Who owns the half-shafts: torque = the wheel side (left.tau / right.tau in, sun speeds and angles out; "
        "stable communication step about 0.45 ms in the vehicle scenes) | wheel = this FMU (leftWheel/rightWheel "
        "angle and speed in, leftShaft.tau / rightShaft.tau out; the stiff sun/shaft mode integrated implicitly "
        "inside the step, stable to 20 ms and beyond)", None, None, "torque", kind="String", bind="shaftCoupling"),
    *[v for side, label in (("left", "left (sun A)"), ("right", "right (sun B)")) for v in (
        _p(f"{side}Shaft.c", f"shafts.{side}.c",
           f"Torsional stiffness of the {label} half-shaft (shaftCoupling = wheel)", "N.m/rad"),
        _p(f"{side}Shaft.d", f"shafts.{side}.d",
           f"Torsional damping of the {label} half-shaft (shaftCoupling = wheel)", "N.m.s/rad"),
        _p(f"{side}Shaft.phi_rel_start", f"shafts.{side}.phi_rel_start",
           f"Twist of the {label} half-shaft at the start (shaftCoupling = wheel)", "rad", "deg"),
    )],
    _p("shafts.h_max", "shafts.h_max",
       "Largest sub-step of the implicit half-shaft integration (shaftCoupling = wheel)", "s", "ms"),
    Var("lockingLaw", "parameter",
        "Locking law of the pin friction: pinFriction (friction torque mu r_d |F_pin| on each planet from its "
        "actual pin load, every level, drive and coast differ) | paper (the paper's K = (mu r_d / n)"
        "(1/(r_a+r_1) + 1/(r_b+r_2)))", None, None, "pinFriction", kind="String", bind="diff.lockingLaw"),
    _p("pinModel", "diff.pinModel", "How a planet's pin carries its loads along the journal (the mesh forces at "
       "their axial positions, spurdiff.gears.axial): endReactions (friction on |R_0| + |R_L|, the rigid planet's end "
       "reactions) | planar (every load in one plane, |F_pin|) | linearPressure (quasi-static law only: refused "
       "here)", kind="String"),
    _p("pairHandedness", "diff.pairHandedness", "Planet 2 leading or trailing planet 1 in the positive sense of "
       "rotation (trailing: the mirrored assembly, drive and coast K swap)", kind="String"),
    _p("leadingSun", "diff.leadingSun", "The sun running ahead for the reported locking coefficients: either (the "
       "smaller K) | A | B", kind="String"),
    _p("pinContactFactor", "diff.pinContactFactor", "Journal friction moment per mu r |F| (1: friction circle, a "
       "lower bound; 4/pi: a run-in bushing)", "1"),
    # --- gear table
    _p("gearing.m", "diff.table.m", "Module of all gears", "m", "mm"),
    _p("gearing.alpha", "diff.table.alpha", "Pressure angle of the basic rack", "rad", "deg"),
    _p("gearing.ha", "diff.table.ha", "Addendum coefficient of the basic rack", "1"),
    _p("gearing.hf", "diff.table.hf", "Dedendum coefficient of the basic rack", "1"),
    _p("gearing.haP0", "diff.table.haP0",
       "Addendum coefficient of the generating tool (rack cutter; ISO 53 A: 1.25)", "1"),
    _p("gearing.rhoaP0", "diff.table.rhoaP0", "Tip radius coefficient of the generating tool (ISO 53 A: 0.38)", "1"),
    *_gear_vars("sunA", "sun A (left)"),
    *_gear_vars("planet1", "planet 1 (meshes sun A and planet 2)"),
    *_gear_vars("sunB", "sun B (right)"),
    *_gear_vars("planet2", "planet 2 (meshes sun B and planet 1)"),
    _p("nPairs", "diff.table.nPairs", "Number of planet pairs (3: the paper's figures)", None, kind="Integer"),
    _p("carrier.wallB", "diff.table.carrier.wallB", "Axial position of carrier wall B's inner face, from wall A's "
       "inner face (axial layout)", "m", "mm"),
    _p("carrier.axialClearance", "diff.table.carrier.axialClearance", "Smallest axial running clearance between "
       "faces that turn relative to each other (gears in different planes, gear and carrier wall; stack-up check)",
       "m", "mm"),
    # --- friction, mass
    _p("mu_pin", "diff.mu_pin", "Friction coefficient of the planet pin bushings at break-away, with the "
       "friction-circle correction mu/sqrt(1+mu^2) where the data set has it (spurdiff/data/pin_bushing.toml); "
       "holds the stuck differential and sets its break-away", "1"),
    _p("mu_pinDynamic", "diff.mu_pinDynamic", "Sliding friction coefficient of the planet pin bushings, the friction "
       "while the differential slips (friction-circle correction as mu_pin); 0 <= mu_pinDynamic <= mu_pin, "
       "0: equal to mu_pin (one coefficient, the paper's data)", "1"),
    _p("pinSpeedLoads", "diff.pinSpeedLoads", "The planets' centrifugal forces m a w_c^2 load their pins (carrier speed "
       "at each step's start; lockingLaw = pinFriction): the locking grows with carrier speed", kind="Boolean"),
    _p("r_collar", "diff.r_collar", "Journal radius of the planet pins, the friction lever's radius (the paper's "
       "r_d, which it calls a thrust-collar radius)", "m", "mm"),
    _p("lockingPreload", "diff.lockingPreload",
       "Spring preload of the locking friction (clutch-type limited slip): torque difference held with no load", "N.m", "N.mm"),
    _p("density", "diff.density", "Density of the gear steel", "kg/m3"),
    _p("J_carrier", "diff.J_carrier", "Carrier inertia without planets (0: estimate from geometry)", "kg.m2"),
    _p("J_sunA", "diff.J_sunA", "Sun A inertia incl. rigidly attached parts (0: from geometry)", "kg.m2"),
    _p("J_sunB", "diff.J_sunB", "Sun B inertia incl. rigidly attached parts (0: from geometry)", "kg.m2"),
    _p("J_planet1", "diff.J_planet1", "Inertia of one planet 1 about its axis (0: from geometry)", "kg.m2"),
    _p("J_planet2", "diff.J_planet2", "Inertia of one planet 2 about its axis (0: from geometry)", "kg.m2"),
    Var("carrier.w_start", "parameter", "Initial carrier speed (carrierDrive = torque)", "rad/s", "rpm", 0.0,
        bind="w_start_carrier"),
    Var("differential.w_start", "parameter", "Initial speed of sun A relative to the carrier (start value: the "
        "default experiment's 20 rad/s, a slip the locking stops)", "rad/s", "rpm", DEFAULT_DIFFERENTIAL_START,
        bind="w_start_differential"),
    # --- mesh data (compliant / contact levels)
    *[v for key, label in (("A1", "sun A / planet 1"), ("B2", "sun B / planet 2"), ("12", "planet 1 / planet 2"))
      for v in (
        _p(f"mesh{key}.backlash", f"mesh.backlash{key}", f"Circumferential backlash of mesh {label} at the "
           "operating pitch circle (used with backlash = true)", "m", "mm"),
        _p(f"mesh{key}.c", f"mesh.stiffness{key}", f"Mean mesh stiffness of mesh {label} per planet pair "
           "(0: ISO 6336-1 c_gamma_alpha times face width)", "N/m", "N/mm"),
        _p(f"mesh{key}.contactStiffness", f"mesh.contactStiffness{key}", f"IMPACT stiffness K of mesh {label}, "
           "the contact force at 1 m of penetration: F = K (delta / 1 m)^e (the value of K in N/m^e)", "N", "kN"),
    )],
    _p("mesh.preload", "mesh.preload", "Start with the meshes statically loaded (false: unloaded, the loads act from "
        "t = 0, a start transient like the paper's ADAMS run)", None, kind="Boolean"),
    _p("mesh.dampingRatio", "mesh.dampingRatio", "Damping ratio of each compliant mesh mode", "1"),
    _p("mesh.E", "mesh.youngsModulus", "Young's modulus of the gear steel (ISO 6336 stiffness)", "Pa", "MPa"),
    _p("mesh.contactExponent", "mesh.contactExponent", "IMPACT force exponent e", "1"),
    _p("mesh.contactDamping", "mesh.contactDamping", "IMPACT maximum damping C", "N.s/m", "N.s/mm"),
    _p("mesh.contactDepth", "mesh.contactDepth", "IMPACT penetration d_max at which the damping is full", "m", "mm"),
    _p("flank.muStatic", "mesh.muStatic", "Static flank friction coefficient", "1"),
    _p("flank.muDynamic", "mesh.muDynamic", "Dynamic flank friction coefficient", "1"),
    _p("flank.vStiction", "mesh.vStiction", "Sliding speed of full static friction", "m/s"),
    _p("flank.vTransition", "mesh.vTransition", "Sliding speed above which friction is dynamic", "m/s"),
    # --- calculated parameters
    *_mesh_vars("A1", "sun A / planet 1"),
    *_mesh_vars("B2", "sun B / planet 2"),
    *_mesh_vars("12", "planet 1 / planet 2"),
    *(Var(f"{gear}.rw", "calculatedParameter", f"Operating pitch radius of {where}, {r}", "m", "mm",
          bind=f"geometry.{r}")
      for gear, where, r in (("sunA", "sun A (mesh A1)", "r_a"), ("planet1", "planet 1 in mesh A1", "r_1"),
                             ("sunB", "sun B (mesh B2)", "r_b"), ("planet2", "planet 2 in mesh B2", "r_2"))),
    Var("lockingCoefficient", "calculatedParameter",
        "Locking coefficient in drive (load on the drive flanks: the carrier drives the suns), |T_A - T_B| / "
        "(T_A + T_B) at break-away; with flankFriction (compliant/contact) it includes the flanks' Coulomb "
        "friction at flank.muStatic, mesh-cycle average (lockingLaw = paper: (mu r_d / n)(1/(r_a+r_1) + "
        "1/(r_b+r_2)), pins only)", "1", bind="K"),
    Var("lockingCoefficientCoast", "calculatedParameter",
        "Locking coefficient in coast (load on the coast flanks: the suns drive the carrier), flank friction "
        "as in lockingCoefficient; equals the drive value with lockingLaw = paper", "1",
        bind="K_coast"),
    Var("lockingCoefficientSliding", "calculatedParameter",
        "Locking coefficient in drive while the differential slips: |T_A - T_B| / (T_A + T_B) with the pins at "
        "mu_pinDynamic (flankFriction: the flanks at flank.muDynamic); equals lockingCoefficient with one "
        "coefficient", "1", bind="K_slide"),
    Var("lockingCoefficientCoastSliding", "calculatedParameter",
        "Locking coefficient in coast while the differential slips (as lockingCoefficientSliding)", "1",
        bind="K_slide_coast"),
    Var("torqueBiasRatio", "calculatedParameter",
        "Torque bias ratio in drive, largest T_slow / T_fast the locking holds: (1 + K) / (1 - K)", "1"),
    Var("torqueBiasRatioCoast", "calculatedParameter",
        "Torque bias ratio in coast: (1 + K_coast) / (1 - K_coast)", "1"),
    Var("inertia.carrier", "calculatedParameter", "Inertia of the carrier mode (everything turning together)", "kg.m2",
        bind="Mcc"),
    Var("inertia.differential", "calculatedParameter", "Inertia of the differential mode (sun A relative to carrier)",
        "kg.m2", bind="Mdd"),
    Var("geometry.warnings", "calculatedParameter", "Number of design-check warnings for this gear set (logged)",
        None, None, 0, kind="Integer"),
]


# ---------------------------------------------------------------------------------------------------
# Load capacity (issue 27 item 4): ISO 6336 safety factors at initialization, the run's largest
# stresses as outputs and one logged warning when a run exceeds the static strength (the rating:
# spurdiff.gears.capacity; the watch on the run: spurdiff.differential.watches; docs/capacity.md).
# Appended after the other variables.
CAPACITY_MESHES = (("A1", "sunA", "planet1"), ("B2", "sunB", "planet2"), ("12", "planet1", "planet2"))
VARIABLES += [
    _p("capacity.T0", "capacity.T0", "Carrier torque at which the ISO 6336 safety factors are rated and from which "
       "the run's stresses are scaled (the paper's load: 2100 N m)", "N.m"),
    _p("capacity.material", "capacity.material", "Gear material of the ISO 6336 check (spurdiff/data/materials.toml): "
       "18CrNiMo7-6 | 20MnCr5 | 40CrNi2Mo-paper", kind="String"),
    _p("capacity.bushingWall", "capacity.bushingWall", "Wall of the planets' pin bushings: the planets' bore is "
       "2 (r_collar + capacity.bushingWall), which sets the rim factor Y_B of their root stress (0: the pin runs "
       "in the planet's bore, the paper's set; 1.5 mm: spurdiff/data/pin_bushing.toml's bronze set)", "m", "mm"),
    _p("capacity.K_gamma", "capacity.K_gamma", "Load-sharing factor of the planet pairs in the ISO 6336 rating (the "
       "most loaded pair carries K_gamma times the mean; 0: the default for nPairs, spurdiff/data/materials.toml "
       "[loadSharing], 1.10 for 3 pairs)", "1"),
    *[Var(f"capacity.mesh{k}.{g}.{S}", "calculatedParameter",
          f"ISO 6336 {what} safety factor of {g} in mesh {k} at capacity.T0, long life (< 1: a finding, logged)", "1")
      for k, g1, g2 in CAPACITY_MESHES for g in (g1, g2)
      for S, what in (("S_H", "contact (pitting, method B)"), ("S_F", "root (bending, method B)"))],
    Var("capacity.S_H_static", "calculatedParameter", "Smallest ISO 6336 contact safety factor against the static "
        "strength (Z_NT for N <= 1e5) at capacity.T0, over all meshes and gears", "1"),
    Var("capacity.S_F_static", "calculatedParameter", "Smallest ISO 6336 root safety factor against the static "
        "strength (Y_NT for N <= 1e3) at capacity.T0, over all meshes and gears", "1"),
    Var("capacity.sigmaHMax", "output", "Largest contact stress of the run so far (ISO 6336-2 from the mesh forces at "
        "the communication points, load factors of capacity.T0)", "Pa", "MPa", bind="capacity_watch.sigma_H_max"),
    Var("capacity.sigmaFMax", "output", "Largest tooth-root stress of the run so far (ISO 6336-3, as "
        "capacity.sigmaHMax)", "Pa", "MPa", bind="capacity_watch.sigma_F_max"),
    Var("capacity.exceeded", "output", "1 once the run exceeded the static contact or root strength of "
        "capacity.material (logged once), else 0", "1", bind="capacity_watch.exceeded_indicator"),
]


def _set_capacity(watch, values: dict) -> None:
    """The load-capacity calculated parameters: the safety factors of the watch's rating."""
    rep = watch.report
    for r in rep.meshes:
        for g in r.gears:
            values[f"capacity.mesh{r.mesh}.{g.gear}.S_H"] = g.S_H
            values[f"capacity.mesh{r.mesh}.{g.gear}.S_F"] = g.S_F
    values["capacity.S_H_static"] = rep.S_H_static
    values["capacity.S_F_static"] = rep.S_F_static
# ---------------------------------------------------------------------------------------------------


def setup(values: dict) -> Setup:
    """The parameter objects from FMI variable values, by the parameters' bindings."""
    return build_params(VARIABLES, values, Setup())


def differential_params(values: dict) -> DifferentialParams:
    return setup(values).diff


def _validated_mesh(mp: MeshParams) -> None:
    """Validate the mesh parameters; an error names the FMU parameter (``mesh.contactExponent``,
    ``meshA1.backlash``), not the field."""
    try:
        mp.validate()
    except ParameterError as e:
        raise renamed(e, VARIABLES, "mesh") from None


def build_model(values: dict):
    """Build and initialize the model selected by ``meshModel`` from FMI variable values."""
    io = bindings(VARIABLES)
    s = setup(values)
    if s.mesh.level not in MESH_MODELS:
        raise ParameterError("meshModel", s.mesh.level, " | ".join(MESH_MODELS))
    params = s.diff
    if s.mesh.level == "rigid":
        if not s.mesh.pinFriction:
            params = replace(params, mu_pin=0.0, mu_pinDynamic=0.0, lockingPreload=0.0)
        model = RigidDifferential(params)
        model.kernel = s.mesh.kernel     # the pin-load solve's implementation (spurdiff.differential.rigid_kernel)
        model.native = bool(s.mesh.nativeStep)     # the whole step in C (spurdiff.differential.rigid_native)
    else:
        _validated_mesh(s.mesh)
        from spurdiff.differential.mesh.model import MeshDifferential   # (loaded for the mesh levels only)
        model = MeshDifferential(params, s.mesh)
        model.input_names = {v.bind: v.name for v in io.inputs}   # errors name the FMU's inputs
    io.push(model, values)
    model.w_start_carrier = s.w_start_carrier
    wc0 = model.w_ref if model.params.carrierDrive == "speed" else model.w_start_carrier
    model.w_start_left = wc0 + s.w_start_differential
    if s.shaftCoupling not in SHAFT_COUPLINGS:
        raise ParameterError("shaftCoupling", s.shaftCoupling, " | ".join(SHAFT_COUPLINGS))
    if s.shaftCoupling == "wheel":
        from spurdiff.differential.shafts import ShaftedDifferential   # (the wheel coupling only)
        model = ShaftedDifferential(model, s.shafts)
        model.native = bool(s.mesh.nativeStep)
        io.push(model, values)
    model.initialize(0.0)
    io.pull_calculated(model, values)
    _set_calculated(model, values)
    # the watches (spurdiff.differential.watches), in the order they look at a step; the adapter
    # gives the model its logger (model.log_to)
    capacity = CapacityWatch(model, s.capacity)   # load capacity (the block after VARIABLES)
    _set_capacity(capacity, values)
    overspeed = OverspeedWatch(model, s.overspeedLimit)
    values["overspeedLimitInUse"] = overspeed.limit
    attach(model, (capacity, overspeed))
    return model


def build_message(values: dict) -> str | None:
    """What the FMU logs once the model is built: which implementation runs the mesh level or the rigid
    level's pin-load solve, and why; then the axial stack-up findings of the gear set (issue 41,
    spurdiff.gears.axial; the errors among them refused the set already)."""
    lines = []
    if not values["solver.kernelInUse"].startswith("none"):
        lines.append(f"meshModel = {values['meshModel']}: {values['solver.kernelInUse']} implementation")
    table = setup(values).diff.table
    lines += [f"axial stack-up: {f}" for f in AxialLayout.of(table).findings(derive(table))]
    return "\n".join(lines) or None


def _set_calculated(model, values: dict) -> None:
    """The calculated parameters that are computed from the model rather than read off it."""
    geo = model.geometry
    phases = mesh_phases(geo)
    for name, g in geo.gears.items():
        values[f"{name}.dF"] = 2.0 * g.rF
    axial = AxialLayout.of(geo.table)
    for key in ("A1", "B2", "12"):
        values[f"mesh{key}.phase"] = phases[key].drive
        values[f"mesh{key}.b"] = axial.mesh_width(key)
        values[f"mesh{key}.axialCentre"] = axial.meshes[key].centre
    values["torqueBiasRatio"] = torque_bias_ratio(model.K)
    values["torqueBiasRatioCoast"] = torque_bias_ratio(model.K_coast)
    values["geometry.warnings"] = len(geo.warnings)
    values["nStates"] = int(getattr(model, "n_states", 2))
    values["activeEffects"] = ",".join(active_effects(model))
    inner = getattr(model, "inner", model)
    values["solver.kernelInUse"] = getattr(inner, "kernel_in_use", None) or getattr(inner, "kernel_note", "none")
    if inner is not model:      # the half-shafts' step (spurdiff.differential.shaft_kernel)
        values["solver.kernelInUse"] += f"; half-shafts: {model.shaft_kernel_note}"


def active_effects(model) -> tuple[str, ...]:
    """The effects that act in ``model``: the mesh law, then the enabled effects."""
    eff = getattr(model, "active_effects", None)
    if eff is not None:
        return tuple(eff)
    return ("rigid",) + (("pinFriction",) if model.K > 0.0 or model.preload > 0.0 else ())
