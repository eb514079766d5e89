"""Parameters of the half-shafts owned by the differential (:mod:`spurdiff.differential.shafts`) with their
validation, and the wheel side's linear model over a step (:class:`WheelSurrogate`, the interface
the wheel reports; equations in :mod:`spurdiff.differential.shafts`). Defaults: ``spurdiff/data/differential.toml``.
"""
from __future__ import annotations

import math
from dataclasses import field

from spurdiff.datafile import differential_default as _d
from spurdiff.errors import Bound, check_fields
from spurdiff.errors import ParameterError, require_finite, require_nonnegative, require_positive
from spurdiff.attrpath import record

SHAFT_COUPLINGS = ("torque", "wheel")

@record
class ShaftParams:
    """One half-shaft: c torsional stiffness (N m/rad), d damping (N m s/rad), phi_rel_start twist
    at the start (rad)."""

    c: float = _d("leftShaft.c")      # defaults: spurdiff/data/differential.toml
    d: float = _d("leftShaft.d")
    phi_rel_start: float = _d("leftShaft.phi_rel_start")

    # the fields' ranges (spurdiff.errors: validate and the FMU's min/max)
    BOUNDS = {"c": Bound(0.0, 1e9, lo_open=True, allowed="between 0 and 1e9 N m/rad"),
              "d": Bound(0.0, 1e6, allowed="between 0 and 1e6 N m s/rad"),
              "phi_rel_start": Bound(-1.0, 1.0, allowed="between -1 and 1 rad")}

    def validate(self, name: str) -> None:
        check_fields(self, f"{name}.")


@record
class ShaftsParams:
    """Both half-shafts and the largest sub-step h_max (s) of the implicit shaft integration
    (5 ms: one sub-step at the vehicle scenes' step; measured: the steady results as with 0.25 ms)."""

    left: ShaftParams = field(default_factory=lambda: ShaftParams(**_d("leftShaft")))
    right: ShaftParams = field(default_factory=lambda: ShaftParams(**_d("rightShaft")))
    h_max: float = _d("shafts.h_max")

    BOUNDS = {"h_max": Bound(0.0, 0.1, lo_open=True, allowed="between 0 and 0.1 s")}

    def validate(self) -> None:
        self.left.validate("leftShaft")
        self.right.validate("rightShaft")
        check_fields(self, "shafts.")


@record
class WheelSurrogate:
    """The wheel side's linear model over the coming step, reported by the wheel at the
    communication point (WheelLoad's ``wheel.aFree`` ... outputs; equations in :mod:`spurdiff.differential.shafts`).
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


__all__ = ["ShaftParams", "ShaftsParams", "WheelSurrogate", "SHAFT_COUPLINGS"]
