"""FMI interface of SpurDifferential.fmu: the variable list and its mapping onto the physics.

Kept free of pythonfmu so the build step and the tests can read it. Names are Modelica-style
(``carrier.w``, ``left.tau``, ``sunA.z``); units are SI with engineering display units.
"""
from __future__ import annotations

from dataclasses import replace

from .fmi_vars import Var
from .geometry import Gear, GearTable
from .locking import torque_bias_ratio
from .phasing import mesh_phases
from .mesh import MeshDifferential, MeshParams
from .params import DifferentialParams
from .rigid import RigidDifferential
from .shafts import SHAFT_COUPLINGS, ShaftedDifferential, ShaftParams, ShaftsParams, WheelSurrogate

MESH_MODELS = ("rigid", "compliant", "contact")
EFFECTS = ("backlash", "meshStiffnessVariation", "pinFriction", "flankFriction")

_T = GearTable()
_M = MeshParams()


def _gear_vars(name: str, label: str, g: Gear) -> list[Var]:
    return [
        Var(f"{name}.z", "parameter", f"Number of teeth of {label}", None, None, g.z, kind="Integer"),
        Var(f"{name}.x", "parameter", f"Profile-shift coefficient of {label}", "1", None, g.x),
        Var(f"{name}.b", "parameter", f"Face width of {label}", "m", "mm", g.b),
        Var(f"{name}.da", "parameter", f"Tip diameter of {label} (0: untrimmed m (z + 2 ha + 2 x))", "m", "mm", g.da),
        Var(f"{name}.dF", "calculatedParameter",
            f"Form diameter of {label}: where its involute starts (generating rack, undercut included)", "m", "mm"),
    ]


def _mesh_vars(mesh: str, label: str) -> list[Var]:
    return [
        Var(f"mesh{mesh}.alpha_w", "calculatedParameter", f"Operating pressure angle of mesh {label}", "rad", "deg"),
        Var(f"mesh{mesh}.a", "calculatedParameter", f"Operating centre distance of mesh {label}", "m", "mm"),
        Var(f"mesh{mesh}.rw1", "calculatedParameter", f"Operating pitch radius of the first gear of mesh {label}", "m", "mm"),
        Var(f"mesh{mesh}.rw2", "calculatedParameter", f"Operating pitch radius of the second gear of mesh {label}", "m", "mm"),
        Var(f"mesh{mesh}.epsilon_alpha", "calculatedParameter", f"Transverse contact ratio of mesh {label}", "1"),
        Var(f"mesh{mesh}.epsilon_usable", "calculatedParameter",
            f"Usable transverse contact ratio of mesh {label} (involute from form circle to tip on both gears; "
            "used by the ISO stiffness and the stiffness wave)", "1"),
        Var(f"mesh{mesh}.phase", "calculatedParameter",
            f"Initial phase of the drive flanks of mesh {label} along its usable path, in base pitches "
            "(tooth positions; an A1 drive pair starts at its pitch point)", "1"),
    ]


VARIABLES: list[Var] = [
    # --- inputs
    Var("carrier.w_ref", "input", "Carrier speed target (carrierDrive = speed); reached linearly over each step",
        "rad/s", "rpm", 0.0, min=-1e4, max=1e4),
    Var("carrier.tau", "input", "External torque driving the carrier (carrierDrive = torque)", "N.m", "N.mm", 0.0, min=-1e6, max=1e6),
    Var("left.tau", "input", "External torque on the left half-shaft flange (sun A), Modelica sign: a load is negative",
        "N.m", "N.mm", 0.0, min=-1e6, max=1e6),
    Var("right.tau", "input", "External torque on the right half-shaft flange (sun B), Modelica sign: a load is negative",
        "N.m", "N.mm", 0.0, min=-1e6, max=1e6),
    Var("leftWheel.phi", "input", "shaftCoupling = wheel: angle of the wheel end of the left half-shaft "
        "(WheelLoad's wheel.phi)", "rad", "deg", 0.0, min=-1e9, max=1e9),
    Var("leftWheel.w", "input", "shaftCoupling = wheel: speed of the wheel end of the left half-shaft "
        "(WheelLoad's wheel.w)", "rad/s", "rpm", 0.0, min=-1e4, max=1e4),
    Var("rightWheel.phi", "input", "shaftCoupling = wheel: angle of the wheel end of the right half-shaft",
        "rad", "deg", 0.0, min=-1e9, max=1e9),
    Var("rightWheel.w", "input", "shaftCoupling = wheel: speed of the wheel end of the right half-shaft",
        "rad/s", "rpm", 0.0, min=-1e4, max=1e4),
    # the wheel side's linear model over the coming step (WheelLoad's outputs of the same names; all 0:
    # the wheel side keeps its speed over the step, the linear extrapolation; spurdiff.shafts.WheelSurrogate)
    *[v for side in ("left", "right") for v in (
        Var(f"{side}Wheel.aFree", "input", f"shaftCoupling = wheel, interface model of the {side} wheel: its "
            "acceleration without the shaft torque (WheelLoad's wheel.aFree; 0 with the defaults: speed held)",
            "rad/s2", None, 0.0, min=-1e7, max=1e7),
        Var(f"{side}Wheel.invJ", "input", f"Interface model of the {side} wheel: acceleration per N m of shaft "
            "torque (WheelLoad's wheel.invJ; 0: speed held)", "1/(kg.m2)", None, 0.0, min=0.0, max=1e6),
        Var(f"{side}Wheel.dadw", "input", f"Interface model of the {side} wheel: acceleration per rad/s of "
            "wheel speed (WheelLoad's wheel.dadw, <= 0)", "1/s", None, 0.0, min=-1e6, max=0.0),
        Var(f"{side}Wheel.tyreTorqueRate", "input", f"Interface model of the {side} wheel: rate of its tyre "
            "torque (WheelLoad's tyre.torqueRate)", "N.m/s", None, 0.0, min=-1e9, max=1e9),
        Var(f"{side}Wheel.tyreStiffness", "input", f"Interface model of the {side} wheel: change of the tyre "
            "torque's rate per rad/s of wheel speed (WheelLoad's tyre.torqueStiffness, >= 0)", "N.m/rad", None,
            0.0, min=0.0, max=1e9),
        Var(f"{side}Wheel.tyreRelaxation", "input", f"Interface model of the {side} wheel: relaxation rate of "
            "its tyre torque (WheelLoad's tyre.relaxationRate, >= 0)", "1/s", None, 0.0, min=0.0, max=1e6),
    )],
    # --- outputs (values at the end of the last step; no direct feedthrough)
    Var("leftShaft.tau", "output", "shaftCoupling = wheel: torque of the left half-shaft on its wheel, mean over "
        "the last step (positive drives the wheel forward; connect to WheelLoad's shaftIn.tau); "
        "torque: -left.tau", "N.m", "N.mm"),
    Var("rightShaft.tau", "output", "shaftCoupling = wheel: torque of the right half-shaft on its wheel, mean over "
        "the last step; torque: -right.tau", "N.m", "N.mm"),
    Var("leftShaft.dwWheel", "output", "shaftCoupling = wheel: change of the left wheel's speed over the last "
        "step that leftShaft.tau was computed for (from the interface model; connect to WheelLoad's "
        "shaftIn.dw)", "rad/s", "rpm"),
    Var("rightShaft.dwWheel", "output", "shaftCoupling = wheel: change of the right wheel's speed over the "
        "last step that rightShaft.tau was computed for (connect to WheelLoad's shaftIn.dw)", "rad/s", "rpm"),
    Var("leftShaft.tauEnd", "output", "Torque of the left half-shaft on its wheel at the end of the last step",
        "N.m", "N.mm"),
    Var("rightShaft.tauEnd", "output", "Torque of the right half-shaft on its wheel at the end of the last step",
        "N.m", "N.mm"),
    Var("leftShaft.phi_rel", "output", "Twist of the left half-shaft, sun angle - wheel angle (0 with "
        "shaftCoupling = torque)", "rad", "deg"),
    Var("rightShaft.phi_rel", "output", "Twist of the right half-shaft (0 with shaftCoupling = torque)", "rad", "deg"),
    Var("carrier.w", "output", "Carrier speed", "rad/s", "rpm"),
    Var("carrier.phi", "output", "Carrier angle", "rad", "deg"),
    Var("left.w", "output", "Left flange (sun A) speed", "rad/s", "rpm"),
    Var("left.phi", "output", "Left flange (sun A) angle", "rad", "deg"),
    Var("right.w", "output", "Right flange (sun B) speed", "rad/s", "rpm"),
    Var("right.phi", "output", "Right flange (sun B) angle", "rad", "deg"),
    Var("carrier.tauDrive", "output", "Torque the carrier drive delivers", "N.m", "N.mm"),
    Var("left.tauMesh", "output", "Torque the meshes deliver to sun A", "N.m", "N.mm"),
    Var("right.tauMesh", "output", "Torque the meshes deliver to sun B", "N.m", "N.mm"),
    Var("mesh.F_A1", "output", "Normal tooth force of mesh sun A / planet 1, per planet pair", "N"),
    Var("mesh.F_B2", "output", "Normal tooth force of mesh sun B / planet 2, per planet pair", "N"),
    Var("mesh.F_12", "output", "Normal tooth force of mesh planet 1 / planet 2, per planet pair", "N"),
    Var("lockingTorque", "output",
        "Pin-bushing friction torque on the differential motion, as a sun-torque difference (positive speeds sun A up)",
        "N.m", "N.mm"),
    Var("lockingCapacity", "output",
        "Largest torque difference the friction can hold now: n sum_i |rho_i| (mu r_d |F_pin,i| + preload share) "
        "from the pin loads (lockingLaw = pinFriction), K |T_A + T_B| + preload (paper)", "N.m", "N.mm"),
    Var("powerLoss", "output", "Friction power, mean over the last step (>= 0)", "W"),
    Var("energyLoss", "output", "Friction energy dissipated since the start", "J"),
    Var("workIn", "output", "Work done on the differential by the carrier drive and the flange torques since the start", "J"),
    Var("kineticEnergy", "output", "Kinetic energy of all parts", "J"),
    Var("stuck", "output", "1 while the differential is locked by friction (no relative motion), else 0", "1"),
    Var("modeSwitches", "output", "Number of stick/slip mode switches since the start", None, None, 0, kind="Integer"),
    Var("internalSteps", "output", "Number of internal integration steps since the start", None, None, 0, kind="Integer"),
    Var("contactTransitions", "output",
        "Number of tooth contact losses and re-engagements since the start (backlash, compliant/contact)",
        None, None, 0, kind="Integer"),
    Var("potentialEnergy", "output", "Elastic energy stored in the mesh springs (0 at rigid)", "J"),
    Var("nStates", "calculatedParameter", "Number of continuous states of the selected fidelity", None, None, 0,
        kind="Integer"),
    Var("activeEffects", "calculatedParameter",
        "Effects in use, comma separated: the mesh model, then the enabled effects that act", None, None, "",
        kind="String"),
    # --- structural parameters (fidelity: only what is switched on allocates states and costs time)
    Var("meshModel", "parameter",
        "Mesh fidelity: rigid (kinematic, 2 states) | compliant (linear mesh springs, planets free) | "
        "contact (ADAMS IMPACT law, planets free)", None, None, "rigid", kind="String"),
    Var("backlash", "parameter", "Circumferential backlash per mesh: contact loss and impacts (compliant/contact)",
        None, None, False, kind="Boolean"),
    Var("meshStiffnessVariation", "parameter",
        "Mesh stiffness varies with single/double tooth contact as the gears turn (compliant/contact)",
        None, None, False, kind="Boolean"),
    Var("pinFriction", "parameter", "Load-dependent pin-bushing friction (the locking friction), every level",
        None, None, True, kind="Boolean"),
    Var("flankFriction", "parameter", "Coulomb friction on the tooth flanks (compliant/contact)",
        None, None, False, kind="Boolean"),
    Var("tolerance", "parameter", "Relative accuracy of the internal integrator (compliant/contact)", "1", None,
        _M.tolerance),
    Var("maxInternalSteps", "parameter", "Internal steps allowed per communication step before doStep discards",
        None, None, _M.maxInternalSteps, kind="Integer"),
    Var("solver.kernel", "parameter", "Implementation of the compliant/contact levels: auto (the compiled kernel "
        "shipped in the FMU when it loads, else the Python reference, with the reason logged) | compiled (refuse "
        "to start without it) | python (the pure-Python reference; same results, slower)", None, None,
        _M.kernel, kind="String"),
    Var("solver.kernelInUse", "calculatedParameter", "Implementation that runs the compliant/contact levels: "
        "compiled | python (and why) | none (rigid)", None, None, "", kind="String"),
    Var("carrierDrive", "parameter", "How the carrier is driven: speed (carrier.w_ref) | torque (carrier.tau)",
        None, None, "speed", kind="String"),
    Var("shaftCoupling", "parameter",
        "Who owns the half-shafts: torque = the wheel side (left.tau / right.tau in, sun speeds and angles out; "
        "stable communication step about 0.45 ms in the vehicle scenes) | wheel = this FMU (leftWheel/rightWheel "
        "angle and speed in, leftShaft.tau / rightShaft.tau out; the stiff sun/shaft mode integrated implicitly "
        "inside the step, stable to 20 ms and beyond)", None, None, "torque", kind="String"),
    *[v for side, label in (("left", "left (sun A)"), ("right", "right (sun B)")) for v in (
        Var(f"{side}Shaft.c", "parameter", f"Torsional stiffness of the {label} half-shaft (shaftCoupling = wheel)",
            "N.m/rad", None, 8000.0),
        Var(f"{side}Shaft.d", "parameter", f"Torsional damping of the {label} half-shaft (shaftCoupling = wheel)",
            "N.m.s/rad", None, 10.0),
        Var(f"{side}Shaft.phi_rel_start", "parameter",
            f"Twist of the {label} half-shaft at the start (shaftCoupling = wheel)", "rad", "deg", 0.0),
    )],
    Var("shafts.h_max", "parameter", "Largest sub-step of the implicit half-shaft integration (shaftCoupling = wheel)",
        "s", "ms", 5e-3),
    Var("lockingLaw", "parameter",
        "Locking law of the pin friction: pinFriction (friction torque mu r_d |F_pin| on each planet from its "
        "actual pin load, every level, drive and coast differ) | paper (the paper's K = (mu r_d / n)"
        "(1/(r_a+r_1) + 1/(r_b+r_2)))", None, None, "pinFriction", kind="String"),
    # --- gear table
    Var("gearing.m", "parameter", "Module of all gears", "m", "mm", _T.m),
    Var("gearing.alpha", "parameter", "Pressure angle of the basic rack", "rad", "deg", _T.alpha),
    Var("gearing.ha", "parameter", "Addendum coefficient of the basic rack", "1", None, _T.ha),
    Var("gearing.hf", "parameter", "Dedendum coefficient of the basic rack", "1", None, _T.hf),
    Var("gearing.haP0", "parameter", "Addendum coefficient of the generating tool (rack cutter; ISO 53 A: 1.25)",
        "1", None, _T.haP0),
    Var("gearing.rhoaP0", "parameter", "Tip radius coefficient of the generating tool (ISO 53 A: 0.38)", "1", None,
        _T.rhoaP0),
    *_gear_vars("sunA", "sun A (left)", _T.sunA),
    *_gear_vars("planet1", "planet 1 (meshes sun A and planet 2)", _T.planet1),
    *_gear_vars("sunB", "sun B (right)", _T.sunB),
    *_gear_vars("planet2", "planet 2 (meshes sun B and planet 1)", _T.planet2),
    Var("nPairs", "parameter", "Number of planet pairs (3: the paper's figures)", None, None, _T.nPairs, kind="Integer"),
    # --- friction, mass
    Var("mu_pin", "parameter", "Sliding friction coefficient of the planet pin bushings", "1", None, 0.26),
    Var("r_collar", "parameter", "Thrust-collar radius r_d of the pinion shaft", "m", "mm", 0.012),
    Var("lockingPreload", "parameter",
        "Spring preload of the locking friction (clutch-type limited slip): torque difference held with no load",
        "N.m", "N.mm", 0.0),
    Var("density", "parameter", "Density of the gear steel", "kg/m3", None, 7850.0),
    Var("J_carrier", "parameter", "Carrier inertia without planets (0: estimate from geometry)", "kg.m2", None, 0.0),
    Var("J_sunA", "parameter", "Sun A inertia incl. rigidly attached parts (0: from geometry)", "kg.m2", None, 0.0),
    Var("J_sunB", "parameter", "Sun B inertia incl. rigidly attached parts (0: from geometry)", "kg.m2", None, 0.0),
    Var("J_planet1", "parameter", "Inertia of one planet 1 about its axis (0: from geometry)", "kg.m2", None, 0.0),
    Var("J_planet2", "parameter", "Inertia of one planet 2 about its axis (0: from geometry)", "kg.m2", None, 0.0),
    Var("carrier.w_start", "parameter", "Initial carrier speed (carrierDrive = torque)", "rad/s", "rpm", 0.0),
    Var("differential.w_start", "parameter", "Initial speed of sun A relative to the carrier", "rad/s", "rpm", 0.0),
    # --- mesh data (compliant / contact levels)
    *[v for key, label in (("A1", "sun A / planet 1"), ("B2", "sun B / planet 2"), ("12", "planet 1 / planet 2"))
      for v in (
        Var(f"mesh{key}.backlash", "parameter", f"Circumferential backlash of mesh {label} at the operating pitch circle "
            "(used with backlash = true)", "m", "mm", getattr(_M, f"backlash{key}")),
        Var(f"mesh{key}.c", "parameter", f"Mean mesh stiffness of mesh {label} per planet pair "
            "(0: ISO 6336-1 c_gamma_alpha times face width)", "N/m", "N/mm", getattr(_M, f"stiffness{key}")),
        Var(f"mesh{key}.contactStiffness", "parameter", f"IMPACT stiffness K of mesh {label} (F = K delta^e; "
            "unit for the default e = 1.5)", "N/m1.5", "N/mm1.5", getattr(_M, f"contactStiffness{key}")),
    )],
    Var("mesh.preload", "parameter", "Start with the meshes statically loaded (false: unloaded, the loads act from "
        "t = 0, a start transient like the paper's ADAMS run)", None, None, _M.preload, kind="Boolean"),
    Var("mesh.dampingRatio", "parameter", "Damping ratio of each compliant mesh mode", "1", None, _M.dampingRatio),
    Var("mesh.E", "parameter", "Young's modulus of the gear steel (ISO 6336 stiffness)", "Pa", "MPa", _M.youngsModulus),
    Var("mesh.contactExponent", "parameter", "IMPACT force exponent e", "1", None, _M.contactExponent),
    Var("mesh.contactDamping", "parameter", "IMPACT maximum damping C", "N.s/m", "N.s/mm", _M.contactDamping),
    Var("mesh.contactDepth", "parameter", "IMPACT penetration d_max at which the damping is full", "m", "mm",
        _M.contactDepth),
    Var("flank.muStatic", "parameter", "Static flank friction coefficient", "1", None, _M.muStatic),
    Var("flank.muDynamic", "parameter", "Dynamic flank friction coefficient", "1", None, _M.muDynamic),
    Var("flank.vStiction", "parameter", "Sliding speed of full static friction", "m/s", None, _M.vStiction),
    Var("flank.vTransition", "parameter", "Sliding speed above which friction is dynamic", "m/s", None,
        _M.vTransition),
    # --- calculated parameters
    *_mesh_vars("A1", "sun A / planet 1"),
    *_mesh_vars("B2", "sun B / planet 2"),
    *_mesh_vars("12", "planet 1 / planet 2"),
    Var("sunA.rw", "calculatedParameter", "Operating pitch radius of sun A (mesh A1), r_a", "m", "mm"),
    Var("planet1.rw", "calculatedParameter", "Operating pitch radius of planet 1 in mesh A1, r_1", "m", "mm"),
    Var("sunB.rw", "calculatedParameter", "Operating pitch radius of sun B (mesh B2), r_b", "m", "mm"),
    Var("planet2.rw", "calculatedParameter", "Operating pitch radius of planet 2 in mesh B2, r_2", "m", "mm"),
    Var("lockingCoefficient", "calculatedParameter",
        "Locking coefficient in drive, |T_A - T_B| / (T_A + T_B) at break-away (lockingLaw = paper: "
        "(mu r_d / n)(1/(r_a+r_1) + 1/(r_b+r_2)))", "1"),
    Var("lockingCoefficientCoast", "calculatedParameter",
        "Locking coefficient in coast (suns drive the carrier); equals the drive value with lockingLaw = paper", "1"),
    Var("torqueBiasRatio", "calculatedParameter",
        "Torque bias ratio in drive, largest T_slow / T_fast the locking holds: (1 + K) / (1 - K)", "1"),
    Var("torqueBiasRatioCoast", "calculatedParameter",
        "Torque bias ratio in coast: (1 + K_coast) / (1 - K_coast)", "1"),
    Var("inertia.carrier", "calculatedParameter", "Inertia of the carrier mode (everything turning together)", "kg.m2"),
    Var("inertia.differential", "calculatedParameter", "Inertia of the differential mode (sun A relative to carrier)",
        "kg.m2"),
    Var("geometry.warnings", "calculatedParameter", "Number of design-check warnings for this gear set (logged)",
        None, None, 0, kind="Integer"),
]


def gear_table(values: dict) -> GearTable:
    def gear(name: str) -> Gear:
        return Gear(z=int(values[f"{name}.z"]), x=float(values[f"{name}.x"]), b=float(values[f"{name}.b"]),
                    da=float(values[f"{name}.da"]))

    return GearTable(m=float(values["gearing.m"]), alpha=float(values["gearing.alpha"]),
                     ha=float(values["gearing.ha"]), hf=float(values["gearing.hf"]),
                     haP0=float(values["gearing.haP0"]), rhoaP0=float(values["gearing.rhoaP0"]),
                     sunA=gear("sunA"), planet1=gear("planet1"), sunB=gear("sunB"), planet2=gear("planet2"),
                     nPairs=int(values["nPairs"]))


def differential_params(values: dict) -> DifferentialParams:
    return DifferentialParams(
        table=gear_table(values), mu_pin=float(values["mu_pin"]), r_collar=float(values["r_collar"]),
        density=float(values["density"]), carrierDrive=str(values["carrierDrive"]),
        lockingLaw=str(values["lockingLaw"]), lockingPreload=float(values["lockingPreload"]),
        J_carrier=float(values["J_carrier"]), J_sunA=float(values["J_sunA"]), J_sunB=float(values["J_sunB"]),
        J_planet1=float(values["J_planet1"]), J_planet2=float(values["J_planet2"]))


# FMU parameter name -> MeshParams field
MESH_FIELDS: dict[str, str] = {
    "meshModel": "level", "tolerance": "tolerance", "maxInternalSteps": "maxInternalSteps", "solver.kernel": "kernel",
    **{e: e for e in EFFECTS},
    "mesh.preload": "preload", "mesh.dampingRatio": "dampingRatio", "mesh.E": "youngsModulus",
    "mesh.contactExponent": "contactExponent", "mesh.contactDamping": "contactDamping",
    "mesh.contactDepth": "contactDepth", "flank.muStatic": "muStatic", "flank.muDynamic": "muDynamic",
    "flank.vStiction": "vStiction", "flank.vTransition": "vTransition",
    **{f"mesh{k}.{a}": f"{b}{k}" for k in ("A1", "B2", "12")
       for a, b in (("backlash", "backlash"), ("c", "stiffness"), ("contactStiffness", "contactStiffness"))},
}
_FMU_NAME = {field: name for name, field in MESH_FIELDS.items()}
# the physics' input names -> the FMU's (named in the error of a non-finite input)
INPUT_NAMES = {"w_ref": "carrier.w_ref", "tau_c": "carrier.tau", "tau_L": "left.tau", "tau_R": "right.tau"}


def mesh_params(values: dict) -> MeshParams:
    """Mesh effects and data for the compliant and contact levels, validated; errors name the FMU
    parameter (``mesh.contactExponent``, ``meshA1.backlash``)."""
    from .errors import ParameterError

    kw = {}
    for name, field in MESH_FIELDS.items():
        default = getattr(_M, field)
        v = values[name]
        kw[field] = (bool(v) if isinstance(default, bool) else int(v) if isinstance(default, int)
                     else str(v) if isinstance(default, str) else float(v))
    mp = MeshParams(**kw)
    try:
        mp.validate()
    except ParameterError as e:
        raise ParameterError(_FMU_NAME.get(e.name, e.name), e.value, e.allowed, e.hint) from None
    return mp


def build_model(values: dict):
    """Build and initialize the model selected by ``meshModel`` from FMI variable values."""
    from .errors import ParameterError

    mesh_model = str(values["meshModel"])
    if mesh_model not in MESH_MODELS:
        raise ParameterError("meshModel", mesh_model, " | ".join(MESH_MODELS))
    params = differential_params(values)
    if mesh_model == "rigid":
        if not bool(values["pinFriction"]):
            params = replace(params, mu_pin=0.0, lockingPreload=0.0)
        model = RigidDifferential(params)
    else:
        model = MeshDifferential(params, mesh_params(values))
        model.input_names = INPUT_NAMES
    push_inputs(model, values)
    model.w_start_carrier = float(values["carrier.w_start"])
    wc0 = model.w_ref if model.params.carrierDrive == "speed" else model.w_start_carrier
    model.w_start_left = wc0 + float(values["differential.w_start"])
    coupling = str(values["shaftCoupling"])
    if coupling not in SHAFT_COUPLINGS:
        raise ParameterError("shaftCoupling", coupling, " | ".join(SHAFT_COUPLINGS))
    if coupling == "wheel":
        model = ShaftedDifferential(model, ShaftsParams(
            left=ShaftParams(float(values["leftShaft.c"]), float(values["leftShaft.d"]),
                             float(values["leftShaft.phi_rel_start"])),
            right=ShaftParams(float(values["rightShaft.c"]), float(values["rightShaft.d"]),
                              float(values["rightShaft.phi_rel_start"])),
            h_max=float(values["shafts.h_max"])))
        push_inputs(model, values)
    model.initialize(0.0)
    _set_calculated(model, values)
    return model


def _set_calculated(model, values: dict) -> None:
    geo = model.geometry
    phases = mesh_phases(geo)
    for name, g in geo.gears.items():
        values[f"{name}.dF"] = 2.0 * g.rF
    for key, me in (("A1", geo.meshA1), ("B2", geo.meshB2), ("12", geo.mesh12)):
        values[f"mesh{key}.epsilon_usable"] = me.epsilon_usable
        values[f"mesh{key}.phase"] = phases[key].drive
        values[f"mesh{key}.alpha_w"] = me.alpha_w
        values[f"mesh{key}.a"] = me.a
        values[f"mesh{key}.rw1"] = me.rw1
        values[f"mesh{key}.rw2"] = me.rw2
        values[f"mesh{key}.epsilon_alpha"] = me.epsilon_alpha
    values["sunA.rw"], values["planet1.rw"] = geo.r_a, geo.r_1
    values["sunB.rw"], values["planet2.rw"] = geo.r_b, geo.r_2
    values["lockingCoefficient"] = model.K
    values["lockingCoefficientCoast"] = model.K_coast
    values["torqueBiasRatio"] = torque_bias_ratio(model.K)
    values["torqueBiasRatioCoast"] = torque_bias_ratio(model.K_coast)
    values["inertia.carrier"] = model.Mcc
    values["inertia.differential"] = model.Mdd
    values["geometry.warnings"] = len(geo.warnings)
    values["nStates"] = int(getattr(model, "n_states", 2))
    values["activeEffects"] = ",".join(active_effects(model))
    inner = getattr(model, "inner", model)
    values["solver.kernelInUse"] = getattr(inner, "kernel_in_use", "none")


def active_effects(model) -> tuple[str, ...]:
    """The effects that act in ``model``: the mesh law, then the enabled effects."""
    eff = getattr(model, "active_effects", None)
    if eff is not None:
        return tuple(eff)
    return ("rigid",) + (("pinFriction",) if model.K > 0.0 or model.preload > 0.0 else ())


_SURROGATE = ("aFree", "invJ", "dadw", "tyreTorqueRate", "tyreStiffness", "tyreRelaxation")


def push_inputs(model, values: dict) -> None:
    model.w_ref = values["carrier.w_ref"]
    model.tau_c = values["carrier.tau"]
    if isinstance(model, ShaftedDifferential):   # the sun torques come from the shafts
        model.wheelL_phi = values["leftWheel.phi"]
        model.wheelL_w = values["leftWheel.w"]
        model.wheelR_phi = values["rightWheel.phi"]
        model.wheelR_w = values["rightWheel.w"]
        for side, attr in (("left", "wheelL_model"), ("right", "wheelR_model")):
            setattr(model, attr, WheelSurrogate(*(float(values[f"{side}Wheel.{n}"]) for n in _SURROGATE)))
        return
    model.tau_L = values["left.tau"]
    model.tau_R = values["right.tau"]


def pull_outputs(model, values: dict) -> None:
    if isinstance(model, ShaftedDifferential):
        values["leftShaft.tau"], values["rightShaft.tau"] = model.tau_mean_L, model.tau_mean_R
        values["leftShaft.tauEnd"], values["rightShaft.tauEnd"] = model.tau_end_L, model.tau_end_R
        values["leftShaft.phi_rel"], values["rightShaft.phi_rel"] = model.theta_L, model.theta_R
        values["leftShaft.dwWheel"], values["rightShaft.dwWheel"] = model.dw_pred_L, model.dw_pred_R
    else:
        values["leftShaft.dwWheel"] = values["rightShaft.dwWheel"] = 0.0
        values["leftShaft.tau"] = values["leftShaft.tauEnd"] = -model.tau_L
        values["rightShaft.tau"] = values["rightShaft.tauEnd"] = -model.tau_R
        values["leftShaft.phi_rel"] = values["rightShaft.phi_rel"] = 0.0
    values["carrier.w"] = model.wc
    values["carrier.phi"] = model.phic
    values["left.w"] = model.w_L
    values["left.phi"] = model.phi_L
    values["right.w"] = model.w_R
    values["right.phi"] = model.phi_R
    values["carrier.tauDrive"] = model.tau_drive
    tl, tr = model.tau_mesh_L, model.tau_mesh_R
    values["left.tauMesh"] = tl
    values["right.tauMesh"] = tr
    f = model.mesh_forces
    values["mesh.F_A1"] = f.F_A1
    values["mesh.F_B2"] = f.F_B2
    values["mesh.F_12"] = f.F_12
    values["lockingTorque"] = model.locking_torque
    values["lockingCapacity"] = model.locking_capacity
    values["powerLoss"] = model.power_loss
    values["energyLoss"] = model.energy_loss
    values["workIn"] = model.work_in
    values["kineticEnergy"] = model.kinetic_energy
    values["stuck"] = 1.0 if model.stuck else 0.0
    values["modeSwitches"] = int(model.n_mode_switches)
    values["internalSteps"] = int(getattr(model, "n_internal_steps", model.n_steps))
    values["contactTransitions"] = int(getattr(model, "n_contact_transitions", 0))
    values["potentialEnergy"] = float(getattr(model, "potential_energy", 0.0))

