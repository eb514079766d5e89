"""FMI interface of WheelLoad.fmu, declared once: name, description, the variables bound to
:mod:`spurdiff.vehicle.wheel` (inputs and outputs to the model's attributes, parameters to the fields of
:class:`spurdiff.vehicle.wheel.WheelLoadParams`; see :mod:`spurdiff.fmi.variables`), and ``build_model``.

Kept free of pythonfmu so the build step, the direct runner and the tests can read it. One
instance per driven wheel: compliant half-shaft, wheel inertia and transient-slip longitudinal
tyre. Causality: the differential's flange angle and speed in, the torque on that flange out
(Modelica sign: connect ``flange.tau`` to the differential's ``left.tau`` / ``right.tau``); the
vehicle's wheel-centre speed and wheel load in, the tyre force out.

Parameter start values are read from the bundled data file ``spurdiff/data/passenger_car.toml``
(sections ``[halfShaft]``, ``[wheel]``, ``[tyre]``, ``[wheelLoad]``), so the modelDescription.xml
shows the sourced defaults. ``build_model`` reads that file again inside the FMU and overrides it
with the FMI values. The data file's "NaN = automatic" start values become a Boolean switch plus a
number in FMI (``wheel.w_startFromFlange`` / ``wheel.w_start``, ``tyre.k_startSteady`` /
``tyre.k_start``), since FMI start values must be finite.
"""
from __future__ import annotations

import math

from spurdiff.fmi.binding import build_params
from spurdiff.fmi.kernel_vars import initialized, kernel_message, kernel_variables
from spurdiff.datafile import read_data
from spurdiff.fmi.variables import Var, magic_formula_factors
from spurdiff.vehicle.wheel import WheelLoad, WheelLoadParams

FMU_NAME = "WheelLoad"
DESCRIPTION = ("Wheel load of one driven wheel: compliant half-shaft, wheel inertia and transient-slip "
               "Magic Formula longitudinal tyre")
# The default experiment, what any host runs with nothing connected: a locked-wheel skid test (as a
# skid trailer does it): the wheel dragged at 10 m/s under 3000 N (about the sedan's static rear wheel
# load) with its flange held (flange.phi, flange.w = 0; the angle input held is a clamped flange), so
# the tyre slides (slip -1), the shaft twists against the tyre torque and the wheel settles stopped
# with Fx at the sliding force. A driven, rolling wheel needs the flange angle to advance (an input
# that changes) or shaftCoupling = wheel with a torque on shaftIn.tau: docs/use-the-fmu.md.
DEFAULT_EXPERIMENT = {"startTime": 0.0, "stopTime": 1.0, "stepSize": 1e-3}
DEFAULT_FZ = 3000.0     # N
DEFAULT_VX = 10.0       # m/s

_DATA = read_data()                            # the bundled TOML data
_D = WheelLoadParams.from_data(_DATA)
ROAD_MU = float(_DATA.get("road", {}).get("mu", 1.0))   # start value of the mu input


def _num(x: float) -> float:
    return 0.0 if math.isnan(x) else float(x)


def _p(group: str | None, field: str, description: str, unit: str | None, display: str | None = None,
       kind: str = "Real") -> Var:
    """The parameter bound to ``group.field`` of WheelLoadParams (named ``wheelLoad.field`` without
    a group), its start value from the data file."""
    obj = getattr(_D, group) if group else _D
    start = getattr(obj, field)
    start = bool(start) if kind == "Boolean" else _num(start)
    b = getattr(type(obj), "BOUNDS", {}).get(field)     # the range the field's class checks (spurdiff.errors)
    return Var(f"{group or 'wheelLoad'}.{field}", "parameter", description, unit, display, start, kind=kind,
               bind=f"{group}.{field}" if group else field, min=None if b is None else b.lo,
               max=None if b is None else b.hi)


STEP = "the wheel's implicit-midpoint sub-steps"   # what the compiled kernel runs (solver.kernel)

VARIABLES: list[Var] = [
    # --- inputs
    Var("flange.phi", "input", "Angle of the differential's sun flange driving this half-shaft (its left.phi / right.phi)",
        "rad", "deg", 0.0, bind="flange_phi"),
    Var("flange.w", "input", "Speed of the differential's sun flange driving this half-shaft (its left.w / right.w)",
        "rad/s", "rpm", 0.0, min=-1e4, max=1e4, bind="flange_w"),
    Var("Fz", "input", "Normal load on the wheel (negative is treated as 0: a lifted wheel; start value: the "
        "default experiment's)", "N", None, DEFAULT_FZ, min=-1e6, max=1e6, bind="Fz"),
    Var("mu", "input", "Road friction coefficient (>= 0)", "1", None, ROAD_MU, min=0.0, max=10.0, bind="mu"),
    Var("shaftIn.tau", "input",
        "shaftCoupling = wheel: torque of the differential's half-shaft on this wheel, positive drives it forward "
        "(connect the differential's leftShaft.tau / rightShaft.tau); ignored with shaftCoupling = torque",
        "N.m", "N.mm", 0.0, min=-1e6, max=1e6, bind="tau_in"),
    Var("shaftIn.dw", "input",
        "shaftCoupling = wheel: change of the wheel speed over the step that the differential predicted when it "
        "computed shaftIn.tau (connect the differential's leftShaft.dwWheel / rightShaft.dwWheel; 0: the wheel "
        "speed held, the linear extrapolation); the interface stiffness acts on the deviation from that motion",
        "rad/s", "rpm", 0.0, min=-1e4, max=1e4, bind="dw_in"),
    Var("vx", "input", "Longitudinal velocity of the wheel centre along the wheel heading (start value: the "
        "default experiment's)", "m/s", "km/h", DEFAULT_VX, min=-1e3, max=1e3, bind="vx"),
    Var("FzRate", "input", "Rate of the normal load over the step: Fz ramps at this rate, from the Fz input "
        "(wheelLoad.rampAnchor = start) or to it (= end); connect the vehicle's rearLeft.FzRate / rearRight.FzRate; "
        "0: Fz held", "N/s", None, 0.0, min=-1e8, max=1e8, bind="dFz"),
    Var("vxRate", "input", "Rate of the wheel-centre velocity over the step: vx ramps at this rate, from the vx "
        "input (wheelLoad.rampAnchor = start) or to it (= end); connect the vehicle's rearLeft.vxRate / "
        "rearRight.vxRate; 0: vx held", "m/s2", None, 0.0, min=-1e4, max=1e4, bind="dvx"),
    # --- outputs (values at the end of the last step; no direct feedthrough)
    Var("flange.tau", "output",
        "Torque of the half-shaft on the differential's flange, Modelica sign (negative while driving): "
        "connect to the differential's left.tau / right.tau", "N.m", "N.mm", bind="flange_tau"),
    Var("Fx", "output", "Longitudinal tyre force on the vehicle (positive forward)", "N", bind="Fx"),
    Var("wheel.w", "output", "Wheel spin speed", "rad/s", "rpm", bind="wheel_w"),
    Var("wheel.phi", "output",
        "Wheel angle since the start (shaftCoupling = wheel: connect to the differential's leftWheel.phi / "
        "rightWheel.phi; 0 with shaftCoupling = torque)", "rad", "deg", bind="phi"),
    # the wheel side's linear model for the coming step (shaftCoupling = wheel; spurdiff.differential.shafts.WheelSurrogate)
    Var("wheel.aFree", "output", "Interface model: wheel acceleration without the shaft torque (tyre and rolling "
        "resistance at the present state; connect to the differential's leftWheel.aFree / rightWheel.aFree)",
        "rad/s2", bind="sur_a"),
    Var("wheel.invJ", "output", "Interface model: change of the wheel acceleration per N m of shaft torque, 1 / wheel.J",
        "1/(kg.m2)", bind="sur_invJ"),
    Var("wheel.dadw", "output", "Interface model: change of the wheel acceleration per rad/s of wheel speed "
        "(rolling resistance; <= 0)", "1/s", bind="sur_dadw"),
    Var("tyre.torqueRate", "output", "Interface model: rate of the tyre torque R Fx at the present state (relaxation)",
        "N.m/s", bind="sur_qrate"),
    Var("tyre.torqueStiffness", "output", "Interface model: change of the tyre torque's rate per rad/s of wheel "
        "speed, R^2 dFx/dk / sigma (>= 0)", "N.m/rad", bind="sur_ct"),
    Var("tyre.relaxationRate", "output", "Interface model: relaxation rate of the tyre torque, |vx| / sigma", "1/s",
        bind="sur_rt"),
    Var("slip", "output", "Transient longitudinal slip ratio k (steady state: (R w - vx) / |vx|)", "1", "%",
        bind="slip"),
    Var("shaft.tau", "output", "Half-shaft torque on the wheel, c theta + d (flange.w - wheel.w)", "N.m", "N.mm",
        bind="shaft_tau"),
    Var("shaft.power", "output", "Power the differential's flange delivers into the half-shaft (shaft.tau * flange.w)",
        "W", "kW", bind="shaft_power"),
    Var("shaft.phi_rel", "output", "Half-shaft twist theta = flange angle - wheel angle", "rad", "deg", bind="theta"),
    Var("workFlange", "output", "Work done on this model at the flange since the start", "J", "kJ", bind="work_flange"),
    Var("workRoad", "output", "Work delivered to the vehicle, integral of Fx vx, since the start", "J", "kJ",
        bind="work_road"),
    Var("lossDamping", "output", "Energy dissipated by the half-shaft damping since the start", "J", "kJ",
        bind="loss_damping"),
    Var("lossSlip", "output", "Energy dissipated by tyre slip, integral of Fx (R w - vx), since the start", "J", "kJ",
        bind="loss_slip"),
    Var("lossRolling", "output", "Energy dissipated by rolling resistance since the start", "J", "kJ",
        bind="loss_rolling"),
    Var("energyLoss", "output", "Total energy dissipated since the start (damping + slip + rolling)", "J", "kJ",
        bind="energy_dissipated"),
    Var("kineticEnergy", "output", "Spin kinetic energy of the wheel", "J", "kJ", bind="kinetic_energy"),
    Var("potentialEnergy", "output", "Elastic energy of the half-shaft twist", "J", "kJ", bind="potential_energy"),
    Var("energyResidual", "output",
        "Energy balance workFlange - workRoad - (change of kinetic + potential energy) - energyLoss (rounding level)",
        "J", bind="energy_residual"),
    Var("internalSteps", "output", "Number of internal (implicit midpoint) sub-steps since the start",
        None, None, 0, kind="Integer", bind="n_substeps"),
    # --- parameters (start values: spurdiff/data/passenger_car.toml)
    _p("halfShaft", "c", "Torsional stiffness of the half-shaft", "N.m/rad"),
    _p("halfShaft", "d", "Torsional damping of the half-shaft", "N.m.s/rad"),
    _p("halfShaft", "phi_rel_start", "Half-shaft twist at the start", "rad", "deg"),
    _p("wheel", "J", "Spin inertia of wheel and tyre", "kg.m2"),
    _p("wheel", "R", "Rolling radius", "m", "mm"),
    Var("wheel.w_startFromFlange", "parameter",
        "true: the wheel starts at the flange speed (wheel.w_start ignored); false: at wheel.w_start",
        None, None, bool(math.isnan(_D.wheel.w_start)), kind="Boolean"),
    _p("wheel", "w_start", "Wheel speed at the start (used when wheel.w_startFromFlange = false)", "rad/s", "rpm"),
    *magic_formula_factors(_p, "tyre"),
    _p("tyre", "sigma", "Longitudinal relaxation length of the tyre", "m", "mm"),
    _p("tyre", "f_rr", "Rolling-resistance coefficient", "1"),
    _p("tyre", "w_eps", "Wheel speed below which rolling resistance fades to zero (tanh)", "rad/s", "rpm"),
    _p("tyre", "k_max", "Largest |transient slip|", "1"),
    Var("tyre.k_startSteady", "parameter",
        "true: the slip starts at the steady value for the start speeds (tyre.k_start ignored); false: at tyre.k_start",
        None, None, bool(math.isnan(_D.tyre.k_start)), kind="Boolean"),
    _p("tyre", "k_start", "Slip at the start (used when tyre.k_startSteady = false)", "1"),
    Var("shaftCoupling", "parameter",
        "Who owns the half-shaft: torque = this model (flange angle and speed in, flange torque out; stable "
        "step about 0.45 ms with the differential) | wheel = the differential (shaftIn.tau in, wheel.phi and "
        "wheel.w out; pairs with the differential's shaftCoupling = wheel, stable to 20 ms and beyond)",
        None, None, _D.shaftCoupling, kind="String", bind="shaftCoupling"),
    Var("wheelLoad.interfaceStiffness", "parameter",
        "shaftCoupling = wheel: the shaft's c and d (halfShaft.c, halfShaft.d, equal to the differential's "
        "leftShaft/rightShaft values) act inside the step on the wheel's deviation from the motion the "
        "differential extrapolated (implicit wheel mode); false: shaftIn.tau is held as given",
        None, None, bool(_D.interfaceStiffness), kind="Boolean", bind="interfaceStiffness"),
    Var("wheelLoad.rampAnchor", "parameter",
        "Where the Fz and vx inputs lie on their ramps (FzRate, vxRate) over the step: start = the values at the "
        "step's start (Jacobi, or the vehicle stepped after this wheel) | end = the values at its end "
        "(Gauss-Seidel with the vehicle stepped before this wheel, as the vehicle scenes do)",
        None, None, _D.rampAnchor, kind="String", bind="rampAnchor"),
    _p(None, "h_max", "Largest internal step of the implicit-midpoint integrator", "s", "ms"),
    _p(None, "followFlangeAngle",
       "true: the half-shaft twist follows the flange angle input (no drift); false: integrate flange.w only",
       None, None, kind="Boolean"),
    *kernel_variables(STEP),
]


def wheel_params(values: dict) -> WheelLoadParams:
    """WheelLoadParams from the bundled data file, overridden by the FMI parameter values (by their
    bindings); the two "automatic start" switches stand for the data file's NaN."""
    p = build_params(VARIABLES, values, WheelLoadParams.defaults())   # reads spurdiff/data/passenger_car.toml
    if values["wheel.w_startFromFlange"]:
        p.wheel.w_start = math.nan
    if values["tyre.k_startSteady"]:
        p.tyre.k_start = math.nan
    return p


def build_model(values: dict) -> WheelLoad:
    """Build and initialize the wheel-load model from FMI variable values (ParameterError if invalid)."""
    return initialized(WheelLoad(wheel_params(values)), VARIABLES, values)


def build_message(values: dict) -> str | None:
    """What the FMU logs once the model is built: which implementation runs its step."""
    return kernel_message(values, STEP)
