"""Parameters of the WheelLoad (:mod:`spurdiff.vehicle.wheel`) with their validation: the half-shaft, the wheel,
the tyre (:class:`spurdiff.vehicle.tyre.TyreParams`) and the solver settings, read from the ``[halfShaft]``,
``[wheel]``, ``[tyre]`` and ``[wheelLoad]`` sections of the passenger-car data
(``spurdiff/data/passenger_car.toml``, values and their sources there).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from spurdiff.errors import Bound, check_fields
from spurdiff.datafile import read_data, section
from spurdiff.errors import ParameterError, require_finite
from spurdiff.vehicle.tyre import TyreParams

SHAFT_COUPLINGS = ("torque", "wheel")
RAMP_ANCHORS = ("start", "end")   # where the Fz, vx inputs lie on their ramps over the step

@dataclass
class HalfShaftParams:
    """c: torsional stiffness (N m/rad); d: torsional damping (N m s/rad);
    phi_rel_start: twist at the start (rad)."""

    c: float = 8000.0
    d: float = 10.0
    phi_rel_start: float = 0.0

    BOUNDS = {"c": Bound(0.0, lo_open=True), "d": Bound(0.0)}   # spurdiff.errors: validate and the FMU's min/max

    def validate(self) -> None:
        check_fields(self, "halfShaft.")
        require_finite("halfShaft.phi_rel_start", self.phi_rel_start)


@dataclass
class WheelParams:
    """J: spin inertia of wheel and tyre (kg m^2); R: rolling radius (m);
    w_start: wheel speed at the start (rad/s), NaN = the flange speed."""

    J: float = 0.779
    R: float = 0.3266
    w_start: float = math.nan

    BOUNDS = {"J": Bound(0.0, lo_open=True), "R": Bound(0.0, lo_open=True)}   # spurdiff.errors

    def validate(self) -> None:
        check_fields(self, "wheel.")
        if not math.isnan(self.w_start):
            require_finite("wheel.w_start", self.w_start)


@dataclass
class WheelLoadParams:
    """All parameters of :class:`WheelLoad`. h_max: largest internal step (s);
    followFlangeAngle: 1 = the twist follows the flange angle input, 0 = flange speed only;
    rampAnchor: the Fz and vx inputs are the values at the step's "start" or "end" of their ramps
    (rates FzRate, vxRate)."""

    halfShaft: HalfShaftParams = field(default_factory=HalfShaftParams)
    wheel: WheelParams = field(default_factory=WheelParams)
    tyre: TyreParams = field(default_factory=TyreParams)
    h_max: float = 1e-3
    followFlangeAngle: int = 1
    shaftCoupling: str = "torque"
    interfaceStiffness: int = 1
    rampAnchor: str = "start"
    # implementation of the sub-steps (FMI solver.kernel; not data): auto | compiled | python (spurdiff.vehicle.kernel)
    kernel: str = "auto"
    # the whole step in C without Python when the compiled kernel is in use (FMI solver.nativeStep; spurdiff.native_step)
    nativeStep: int = 1

    BOUNDS = {"h_max": Bound(0.0, 0.1, lo_open=True, allowed="between 0 and 0.1 s")}   # spurdiff.errors

    @classmethod
    def from_data(cls, data: dict) -> "WheelLoadParams":
        solver = dict(data.get("wheelLoad", {}))
        for key in solver:
            if key not in ("h_max", "followFlangeAngle", "shaftCoupling", "interfaceStiffness", "rampAnchor"):
                raise ParameterError(f"wheelLoad.{key}", solver[key],
                                     "h_max, followFlangeAngle, shaftCoupling, interfaceStiffness or rampAnchor",
                                     "unknown parameter")
        return cls(halfShaft=section(HalfShaftParams, data, "halfShaft"),
                   wheel=section(WheelParams, data, "wheel"),
                   tyre=section(TyreParams, data, "tyre"), **solver)

    @classmethod
    def defaults(cls, path: str | Path | None = None) -> "WheelLoadParams":
        """Parameters from the passenger-car TOML data (or the TOML file at ``path``)."""
        return cls.from_data(read_data(path))

    def validate(self) -> None:
        self.halfShaft.validate()
        self.wheel.validate()
        self.tyre.validate("tyre")
        check_fields(self, "wheelLoad.")
        if self.followFlangeAngle not in (0, 1):
            raise ParameterError("wheelLoad.followFlangeAngle", self.followFlangeAngle, "0 or 1")
        if self.shaftCoupling not in SHAFT_COUPLINGS:
            raise ParameterError("shaftCoupling", self.shaftCoupling, " or ".join(SHAFT_COUPLINGS))
        if self.interfaceStiffness not in (0, 1):
            raise ParameterError("wheelLoad.interfaceStiffness", self.interfaceStiffness, "0 or 1")
        if self.rampAnchor not in RAMP_ANCHORS:
            raise ParameterError("wheelLoad.rampAnchor", self.rampAnchor, " or ".join(RAMP_ANCHORS))
        if self.nativeStep not in (0, 1):
            raise ParameterError("solver.nativeStep", self.nativeStep, "0 or 1 (false or true)")


__all__ = ["RAMP_ANCHORS", "SHAFT_COUPLINGS", "WheelLoadParams", "HalfShaftParams", "WheelParams"]
