"""FMI interface of Vehicle.fmu, declared once: name, description, the variables bound to
:mod:`spurdiff.vehicle.car` (inputs and outputs to the model's attributes, parameters to the fields of
:class:`spurdiff.vehicle.car.VehicleParams`; see :mod:`spurdiff.fmi.variables`), and ``build_model``.

Kept free of pythonfmu so the build step, the direct runner and the tests can read it. A planar
rear-wheel-drive car: the rear tyre forces come in from the two WheelLoad FMUs, the wheel-centre
speeds and wheel loads go out to them, and ``driveTorque`` (the axle torque the speed controller
asks for, at the differential carrier) goes to the differential's ``carrier.tau``.

Parameter start values are read from the bundled data file ``spurdiff/data/passenger_car.toml``
(sections ``[vehicle]``, ``[lateralTyre]``, ``[steering]``, ``[speedControl]``; ``vehicle.R_wheel``
defaults to ``[wheel] R``); ``build_model`` reads that file again inside the FMU and overrides it
with the FMI values.
"""
from __future__ import annotations

from spurdiff.fmi.binding import build_params
from spurdiff.fmi.kernel_vars import initialized, kernel_message, kernel_variables
from spurdiff.datafile import read_data
from spurdiff.fmi.variables import Var, magic_formula_factors
from spurdiff.vehicle.car import Vehicle, VehicleParams

FMU_NAME = "Vehicle"
DESCRIPTION = ("Planar rear-wheel-drive vehicle: body, axle lateral tyres, load transfer, "
               "speed and path-following steering control")
# The default experiment, what any host runs with nothing connected: the car of the main job alone
# (scene vehicle-cornering): a steady left turn, R = 20 m at 10 m/s, the rear tyre forces held at
# the values the wheels deliver there (means over 1 to 3 s of `spurdiff run vehicle-cornering`:
# 240.9 N inner, 134.4 N outer); the car keeps its turn (lateral acceleration 5 m/s^2, yaw rate
# 0.5 rad/s) and driveTorque shows the axle torque the speed controller asks for (about 152 N m).
# The FMU's vehicle.vx_start is 10 m/s for it: a choice of the experiment, not vehicle data (the data
# file's and the physics' default is 0, a car at rest).
DEFAULT_EXPERIMENT = {"startTime": 0.0, "stopTime": 10.0, "stepSize": 1e-3}
DEFAULT_SPEED = 10.0             # m/s: speedTarget and vehicle.vx_start
DEFAULT_PATH_RADIUS = 20.0       # m, left turn
DEFAULT_FX = (240.9, 134.4)      # N, rear left (inner) and rear right tyre forces of that turn

_DATA = read_data()                             # the bundled TOML data
_D = VehicleParams.from_data(_DATA)
ROAD_MU = float(_DATA.get("road", {}).get("mu", 1.0))   # start value of the mu input

def _p(group: str, field: str, description: str, unit: str | None, display: str | None = None,
       kind: str = "Real", start=None) -> Var:
    """The parameter bound to ``group.field`` of VehicleParams, its start value from the data file
    (or ``start``: a choice of the default experiment, not data)."""
    start = getattr(getattr(_D, group), field) if start is None else start
    start = int(start) if kind == "Integer" else float(start)
    b = getattr(type(getattr(_D, group)), "BOUNDS", {}).get(field)   # the range its class checks (spurdiff.errors)
    return Var(f"{group}.{field}", "parameter", description, unit, display, start, kind=kind, bind=f"{group}.{field}",
               min=None if b is None else b.lo, max=None if b is None else b.hi)


STEP = "the car's Runge-Kutta step"   # what the compiled kernel runs (solver.kernel)

VARIABLES: list[Var] = [
    # --- inputs
    Var("rearLeft.Fx", "input", "Longitudinal tyre force of the rear left wheel on the body (its WheelLoad Fx; "
        "start value: the default experiment's steady turn)", "N", None, DEFAULT_FX[0], min=-1e6, max=1e6, bind="rearLeft_Fx"),
    Var("rearRight.Fx", "input", "Longitudinal tyre force of the rear right wheel on the body (its WheelLoad Fx; "
        "start value: the default experiment's steady turn)", "N", None, DEFAULT_FX[1], min=-1e6, max=1e6, bind="rearRight_Fx"),
    Var("speedTarget", "input", "Target of the speed controller (longitudinal speed v_x)", "m/s", "km/h", DEFAULT_SPEED,
        min=-1e3, max=1e3, bind="speedTarget"),
    Var("pathRadius", "input", "Path radius the steering controller follows (steering.mode = 0); "
        "positive: left turn; 0: straight", "m", None, DEFAULT_PATH_RADIUS, bind="pathRadius"),
    Var("speedTargetRate", "input", "Rate of speedTarget over the step: the target ramps from its input value at "
        "this rate (the input's own rate at the step's start; 0: held)", "m/s2", None, 0.0, min=-1e4, max=1e4,
        bind="speedTargetRate"),
    Var("pathRadiusRate", "input", "Rate of pathRadius over the step: the radius ramps from its input value at "
        "this rate (the input's own rate at the step's start; 0: held; no ramp from a straight path)", "m/s",
        None, 0.0, min=-1e6, max=1e6, bind="pathRadiusRate"),
    Var("steeringAngleCommand", "input", "Road-wheel steering angle command (steering.mode = 1), positive left",
        "rad", "deg", 0.0, min=-3.15, max=3.15, bind="steering_angle_cmd"),
    Var("grade", "input", "Road grade angle, uphill positive (|grade| <= pi/4)", "rad", "deg", 0.0,
        min=-0.786, max=0.786, bind="grade"),
    Var("mu", "input", "Road friction coefficient for the lateral tyres (>= 0)", "1", None, ROAD_MU, min=0.0, max=10.0,
        bind="mu"),
    # --- outputs (values at the end of the last step; no direct feedthrough)
    Var("rearLeft.vx", "output", "Velocity of the rear left wheel centre along the wheel (v_x - r t_r / 2)",
        "m/s", "km/h", bind="rearLeft_vx"),
    Var("rearRight.vx", "output", "Velocity of the rear right wheel centre along the wheel (v_x + r t_r / 2)",
        "m/s", "km/h", bind="rearRight_vx"),
    Var("rearLeft.Fz", "output", "Normal load of the rear left wheel (>= 0)", "N", bind="rearLeft_Fz"),
    Var("rearRight.Fz", "output", "Normal load of the rear right wheel (>= 0)", "N", bind="rearRight_Fz"),
    # their rates (connect to the WheelLoads' vxRate / FzRate: first-order hold over the step)
    Var("rearLeft.vxRate", "output", "Mean rate of change of rearLeft.vx over the last step ((end - start) / step; "
        "at initialization its derivative)", "m/s2", bind="rearLeft_dvx"),
    Var("rearRight.vxRate", "output", "Mean rate of change of rearRight.vx over the last step ((end - start) / step; "
        "at initialization its derivative)", "m/s2", bind="rearRight_dvx"),
    Var("rearLeft.FzRate", "output", "Mean rate of change of rearLeft.Fz over the last step ((end - start) / step; "
        "0 at initialization, the load transfer at its fixed point)", "N/s", bind="rearLeft_dFz"),
    Var("rearRight.FzRate", "output", "Mean rate of change of rearRight.Fz over the last step ((end - start) / step; "
        "0 at initialization, the load transfer at its fixed point)", "N/s", bind="rearRight_dFz"),
    Var("frontAxle.Fz", "output", "Normal load of the front axle", "N", bind="frontAxle_Fz"),
    Var("rearAxle.Fz", "output", "Normal load of the rear axle", "N", bind="rearAxle_Fz"),
    Var("frontAxle.Fy", "output", "Side force of the front axle in its wheel frame", "N", bind="Fy_front"),
    Var("rearAxle.Fy", "output", "Side force of the rear axle", "N", bind="Fy_rear"),
    Var("speed", "output", "Magnitude of the centre-of-gravity velocity", "m/s", "km/h", bind="speed"),
    Var("vx", "output", "Longitudinal velocity of the body (body frame, also that of the rear axle centre)",
        "m/s", "km/h", bind="vx"),
    Var("vy", "output", "Lateral velocity of the centre of gravity (body frame, positive left)", "m/s", "km/h",
        bind="vy"),
    Var("yawRate", "output", "Yaw rate, positive to the left", "rad/s", "deg/s", bind="yawRate"),
    Var("ax", "output", "Longitudinal acceleration of the centre of gravity (body frame)", "m/s2", bind="ax"),
    Var("ay", "output", "Lateral acceleration of the centre of gravity (body frame, positive left)", "m/s2", bind="ay"),
    Var("driveTorque", "output", "Axle drive torque the speed controller demands, at the differential carrier",
        "N.m", "N.mm", bind="driveTorque"),
    Var("x", "output", "Position of the centre of gravity, ground x", "m", bind="x"),
    Var("y", "output", "Position of the centre of gravity, ground y", "m", bind="y"),
    Var("psi", "output", "Heading (yaw angle)", "rad", "deg", bind="psi"),
    Var("steeringAngle", "output", "Road-wheel steering angle applied (positive left)", "rad", "deg",
        bind="steering_angle"),
    Var("kineticEnergy", "output", "Translational and yaw kinetic energy of the body", "J", "kJ",
        bind="kinetic_energy"),
    Var("internalSteps", "output", "Number of internal (Runge-Kutta) sub-steps since the start",
        None, None, 0, kind="Integer", bind="n_substeps"),
    # --- parameters (start values: spurdiff/data/passenger_car.toml)
    _p("vehicle", "m", "Vehicle mass", "kg"),
    _p("vehicle", "Iz", "Yaw moment of inertia", "kg.m2"),
    _p("vehicle", "L", "Wheelbase", "m", "mm"),
    _p("vehicle", "l_f", "Distance from the centre of gravity to the front axle (0 < l_f < L)", "m", "mm"),
    _p("vehicle", "trackFront", "Front track width", "m", "mm"),
    _p("vehicle", "trackRear", "Rear track width", "m", "mm"),
    _p("vehicle", "h_cg", "Height of the centre of gravity", "m", "mm"),
    _p("vehicle", "CdA", "Drag area Cd A", "m2"),
    _p("vehicle", "rho_air", "Air density", "kg/m3"),
    _p("vehicle", "f_rr", "Rolling-resistance coefficient of the undriven front tyres", "1"),
    _p("vehicle", "v_rr", "Speed below which the front rolling resistance fades to zero (tanh)", "m/s", "km/h"),
    _p("vehicle", "rollStiffnessShareRear", "Share of the total roll stiffness on the rear axle (0..1)", "1"),
    _p("vehicle", "tau_load", "Time constant of the load transfer following the accelerations", "s", "ms"),
    _p("vehicle", "vx_start", "Longitudinal speed at the start (with pathRadius: the steady turn at this speed; "
       "10 m/s for the default experiment, 0 to launch)", "m/s", "km/h", start=DEFAULT_SPEED),
    _p("vehicle", "h_max", "Largest internal step of the Runge-Kutta integrator", "s", "ms"),
    _p("vehicle", "R_wheel", "Rear rolling radius (only to start the speed controller at the holding torque)",
       "m", "mm"),
    *magic_formula_factors(_p, "lateralTyre", "Axle lateral "),
    _p("lateralTyre", "sigma", "Lateral relaxation length", "m", "mm"),
    _p("lateralTyre", "alpha_max", "Largest |slip angle| state", "rad", "deg"),
    _p("steering", "mode", "0: follow pathRadius (feed-forward + yaw-rate PI); 1: use steeringAngleCommand",
       None, kind="Integer"),
    _p("steering", "K_r", "Yaw-rate feedback, proportional gain (rad of steering per rad/s of yaw-rate error)", "s"),
    _p("steering", "K_ri", "Yaw-rate feedback, integral gain (rad of steering per rad of integrated yaw error)", "1"),
    _p("steering", "delta_max", "Largest road-wheel steering angle", "rad", "deg"),
    _p("speedControl", "Kp", "Speed controller proportional gain (axle torque per speed error)", "N.m.s/m"),
    _p("speedControl", "Ki", "Speed controller integral gain (axle torque per integrated speed error)", "N.m/m"),
    _p("speedControl", "driveTorqueMax", "Largest axle drive torque (> 0)", "N.m", "N.mm"),
    _p("speedControl", "driveTorqueMin", "Most negative axle torque, engine braking (<= 0)", "N.m", "N.mm"),
    *kernel_variables(STEP),
]


def vehicle_params(values: dict) -> VehicleParams:
    """VehicleParams from the bundled data file, overridden by the FMI parameter values (by their bindings)."""
    return build_params(VARIABLES, values, VehicleParams.defaults())   # reads spurdiff/data/passenger_car.toml


def build_model(values: dict) -> Vehicle:
    """Build and initialize the vehicle model from FMI variable values (ParameterError if invalid)."""
    return initialized(Vehicle(vehicle_params(values)), VARIABLES, values)


def build_message(values: dict) -> str | None:
    """What the FMU logs once the model is built: which implementation runs its step."""
    return kernel_message(values, STEP)
