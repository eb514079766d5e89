"""Parameters of the vehicle (:mod:`spurdiff.vehicle.car`) with their validation: the body, the axle
lateral tyres, the steering and the speed controller, read from the ``[vehicle]``, ``[lateralTyre]``,
``[steering]`` and ``[speedControl]`` sections of the passenger-car data (values and their sources in
``spurdiff/data/passenger_car.toml``; their roles in the equations of :mod:`spurdiff.vehicle.car_rates`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from spurdiff.datafile import read_data, section
from spurdiff.errors import Bound, check_fields
from spurdiff.errors import ParameterError, require_finite
from spurdiff.vehicle.tyre import SHAPE_BOUNDS

G = 9.80665  # standard gravity, m/s^2

STEER_PATH = 0
STEER_ANGLE = 1


@dataclass
class BodyParams:
    """Section ``[vehicle]``. m (kg), Iz (kg m^2), L wheelbase (m), l_f CG to front axle (m),
    trackFront / trackRear (m), h_cg CG height (m), CdA (m^2), rho_air (kg/m^3), f_rr front rolling
    resistance (1), v_rr its fade-in speed (m/s), rollStiffnessShareRear (1), tau_load (s),
    vx_start (m/s), h_max largest internal step (s), R_wheel rear rolling radius (m; default: the
    ``[wheel] R`` of the same data, used only to start the speed controller at the holding torque).
    """

    m: float = 1250.0
    Iz: float = 1053.5
    L: float = 2.776
    l_f: float = 1.388
    trackFront: float = 1.5958
    trackRear: float = 1.6
    h_cg: float = 0.40
    CdA: float = 0.66
    rho_air: float = 1.225
    f_rr: float = 0.015
    v_rr: float = 0.1
    rollStiffnessShareRear: float = 0.5
    tau_load: float = 0.05
    vx_start: float = 0.0
    h_max: float = 0.002
    R_wheel: float = 0.3266

    # the fields' fixed ranges (spurdiff.errors: validate and the FMU's min/max); l_f < L in validate
    BOUNDS = {
        **{name: Bound(0.0, lo_open=True) for name in ("m", "Iz", "L", "trackFront", "trackRear", "v_rr", "tau_load",
                                                       "R_wheel")},
        **{name: Bound(0.0) for name in ("h_cg", "CdA", "rho_air", "f_rr")},
        "l_f": Bound(0.0, lo_open=True),
        "rollStiffnessShareRear": Bound(0.0, 1.0),
        "h_max": Bound(0.0, 0.1, lo_open=True, allowed="between 0 and 0.1 s"),
    }

    def validate(self) -> None:
        check_fields(self, "vehicle.")
        if not self.l_f < self.L:
            raise ParameterError("vehicle.l_f", self.l_f, f"0 < l_f < L = {self.L:g} m")
        require_finite("vehicle.vx_start", self.vx_start)


@dataclass
class LateralTyreParams:
    """Section ``[lateralTyre]``: axle Magic Formula B, C, E; relaxation length sigma (m);
    alpha_max largest |slip angle| (rad)."""

    B: float = 11.0
    C: float = 1.37
    E: float = 0.0
    sigma: float = 0.10
    alpha_max: float = 1.0

    BOUNDS = {**SHAPE_BOUNDS, "sigma": Bound(0.0, lo_open=True), "alpha_max": Bound(1e-6, 0.5 * math.pi)}

    def validate(self) -> None:
        check_fields(self, "lateralTyre.")


@dataclass
class SteeringParams:
    """Section ``[steering]``: mode (0 = path radius, 1 = steering-angle input); K_r (rad per
    rad/s), K_ri (rad per rad): yaw-rate PI gains; delta_max (rad)."""

    mode: int = STEER_PATH
    K_r: float = 0.1
    K_ri: float = 0.5
    delta_max: float = 0.6

    BOUNDS = {"mode": Bound(STEER_PATH, STEER_ANGLE, integer=True, allowed="0 (path radius) or 1 (steering angle)"),
              "K_r": Bound(0.0), "K_ri": Bound(0.0), "delta_max": Bound(1e-6, 1.2)}

    def validate(self) -> None:
        check_fields(self, "steering.")


@dataclass
class SpeedControlParams:
    """Section ``[speedControl]``: Kp (N m per m/s), Ki (N m per m), driveTorqueMax (N m, > 0),
    driveTorqueMin (N m, <= 0: engine braking)."""

    Kp: float = 400.0
    Ki: float = 200.0
    driveTorqueMax: float = 2000.0
    driveTorqueMin: float = -600.0

    BOUNDS = {"Kp": Bound(0.0), "Ki": Bound(0.0), "driveTorqueMax": Bound(0.0, lo_open=True),
              "driveTorqueMin": Bound(None, 0.0)}

    def validate(self) -> None:
        check_fields(self, "speedControl.")


@dataclass
class VehicleParams:
    vehicle: BodyParams = field(default_factory=BodyParams)
    lateralTyre: LateralTyreParams = field(default_factory=LateralTyreParams)
    steering: SteeringParams = field(default_factory=SteeringParams)
    speedControl: SpeedControlParams = field(default_factory=SpeedControlParams)
    # implementation of the step (FMI solver.kernel; not data): auto | compiled | python (spurdiff.vehicle.kernel)
    kernel: str = "auto"
    # the whole step in C without Python when the compiled kernel is in use (FMI solver.nativeStep; spurdiff.native_step)
    nativeStep: int = 1

    @classmethod
    def from_data(cls, data: dict) -> "VehicleParams":
        body = dict(data.get("vehicle", {}))
        if "R_wheel" not in body and "R" in data.get("wheel", {}):
            body["R_wheel"] = data["wheel"]["R"]
        return cls(vehicle=section(BodyParams, {"vehicle": body}, "vehicle"),
                   lateralTyre=section(LateralTyreParams, data, "lateralTyre"),
                   steering=section(SteeringParams, data, "steering"),
                   speedControl=section(SpeedControlParams, data, "speedControl"))

    @classmethod
    def defaults(cls, path: str | Path | None = None) -> "VehicleParams":
        """Parameters from the passenger-car TOML data (or the TOML file at ``path``)."""
        return cls.from_data(read_data(path))

    def validate(self) -> None:
        self.vehicle.validate()
        self.lateralTyre.validate()
        self.steering.validate()
        self.speedControl.validate()
        sc = self.speedControl
        if sc.driveTorqueMin > sc.driveTorqueMax:
            raise ParameterError("speedControl.driveTorqueMin", sc.driveTorqueMin, "<= driveTorqueMax")
        if self.nativeStep not in (0, 1):
            raise ParameterError("solver.nativeStep", self.nativeStep, "0 or 1 (false or true)")


__all__ = [
    "VehicleParams", "BodyParams", "LateralTyreParams", "SteeringParams", "SpeedControlParams",
    "STEER_PATH", "STEER_ANGLE", "G",
]
