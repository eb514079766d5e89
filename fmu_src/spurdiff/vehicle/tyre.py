"""Tyre force laws: the Magic Formula, its slope and inverse, and the transient-slip equation.

Magic Formula (Pacejka), normalised to the friction-limited peak ``D = mu Fz``::

    f(k)  = sin(C atan(phi)),   phi = B k - E (B k - atan(B k))          (1)
    F     = mu max(Fz, 0) f(k)                                          (2)

``k`` is the longitudinal slip ratio (or, for the lateral axle model in :mod:`spurdiff.vehicle.car`,
the slip angle in rad); ``B`` stiffness factor, ``C`` shape factor, ``E`` curvature factor
(dimensionless). The slope at zero slip is ``dF/dk = B C D`` (the slip stiffness).

Properties used by the models and checked by the tests, for ``B > 0``, ``0 < C <= 2``, ``E <= 1``:
``f`` is odd in ``k`` (exactly, in IEEE arithmetic: every operation in (1) is odd), ``|f| <= 1`` so
``|F| <= mu Fz``, ``f`` has the sign of ``k``, and ``F = 0`` when ``Fz <= 0`` (a wheel that lifts
carries no force) or ``mu = 0``.

Transient slip (relaxation length ``sigma``, m), as in Chrono's Fiala tyre and Pacejka's
"Tyre and Vehicle Dynamics" (3rd ed., 2012); see shared/docs/model-references.md::

    sigma dk/dt + |v_x| k = R w - v_x                                    (3)

``R w - v_x`` is minus the slip velocity of the contact point (m/s). In steady state ``k`` is the
SAE slip ratio ``(R w - v_x)/|v_x|``; (3) never divides by ``v_x``, so it is defined at standstill,
where the tyre behaves as a spring of stiffness ``B C D / sigma`` (N/m) holding a static force.
At standstill nothing bounds ``k`` in (3) while the wheel turns, so the models clamp it to
``|k| <= k_max``: the fitted Magic Formula data cover ``|k| <= 1``.

Default values live in ``spurdiff/data/passenger_car.toml`` (section ``[tyre]``) with sources.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from spurdiff.errors import Bound, check_fields
from spurdiff.errors import ParameterError, require_finite
from spurdiff.numerics import find_root

_HALF_PI = 0.5 * math.pi


def magic_formula(k: float, B: float, C: float, E: float) -> float:
    """Normalised Magic Formula ``f(k) = F / (mu Fz)``, equation (1), dimensionless."""
    x = B * k
    return math.sin(C * math.atan(x - E * (x - math.atan(x))))


def magic_formula_slope(k: float, B: float, C: float, E: float) -> float:
    """``df/dk`` of equation (1) (per unit slip)."""
    x = B * k
    phi = x - E * (x - math.atan(x))
    dphi = B * (1.0 - E + E / (1.0 + x * x))
    return math.cos(C * math.atan(phi)) * C / (1.0 + phi * phi) * dphi


def tyre_force(k: float, Fz: float, mu: float, B: float, C: float, E: float) -> float:
    """Tyre force ``F = mu max(Fz, 0) f(k)`` (N), equation (2). Zero without load or friction."""
    if Fz <= 0.0 or mu <= 0.0:
        return 0.0
    return mu * Fz * magic_formula(k, B, C, E)


def peak_slip(B: float, C: float, E: float) -> float:
    """Slip ``k > 0`` at which ``f`` peaks (``f = 1``); ``inf`` when ``C <= 1`` (no peak).

    At the peak ``C atan(phi) = pi/2``, i.e. ``phi(B k) = tan(pi / (2 C))``; ``phi`` is strictly
    increasing in ``k`` for ``E <= 1``, so the root is unique (Brent's method, ``find_root``).
    """
    if C <= 1.0:
        return math.inf
    target = math.tan(_HALF_PI / C)

    def g(x: float) -> float:
        return x - E * (x - math.atan(x)) - target

    hi = 1.0
    while g(hi) < 0.0:
        hi *= 2.0
    return find_root(g, 0.0, hi, xtol=1e-15, rtol=1e-15) / B


def slip_for_force_ratio(ratio: float, B: float, C: float, E: float) -> float:
    """Inverse of (1) on the stable branch: the slip ``k`` with ``f(k) = ratio``, ``|k| <=`` peak slip.

    ``ratio = F / (mu Fz)`` must satisfy ``|ratio| <= 1`` (``< sin(C pi/2)`` when ``C <= 1``).
    Not for use in time-step loops (it solves for ``k`` with ``find_root``).
    """
    ratio = require_finite("ratio", ratio)
    if ratio == 0.0:
        return 0.0
    top = 1.0 if C > 1.0 else math.sin(C * _HALF_PI)
    if abs(ratio) > top:
        raise ParameterError("ratio", ratio, f"|ratio| <= {top:g}", "beyond the tyre's friction limit")

    k_hi = peak_slip(B, C, E)
    if math.isinf(k_hi):
        k_hi = 1.0
        while magic_formula(k_hi, B, C, E) < abs(ratio):
            k_hi *= 2.0
    k = find_root(lambda s: magic_formula(s, B, C, E) - abs(ratio), 0.0, k_hi, xtol=1e-15, rtol=1e-15)
    return math.copysign(k, ratio)


# the Magic Formula factors' ranges (spurdiff.errors: validate_shape and the FMUs' min/max)
SHAPE_BOUNDS = {
    "B": Bound(0.0, lo_open=True),
    "C": Bound(0.0, 2.0, lo_open=True, allowed="0 < C <= 2", hint="C > 2 reverses the force at large slip"),
    "E": Bound(None, 1.0, allowed="E <= 1", hint="E > 1 makes the force non-monotonic near zero slip"),
}


def validate_shape(prefix: str, B: float, C: float, E: float) -> None:
    """Check Magic Formula factors; raise ParameterError naming ``prefix.B`` / ``.C`` / ``.E``."""
    for name, value in (("B", B), ("C", C), ("E", E)):
        SHAPE_BOUNDS[name].check(f"{prefix}.{name}", value)


@dataclass
class TyreParams:
    """Longitudinal tyre of one wheel (section ``[tyre]`` of the TOML data).

    B, C, E: Magic Formula factors (1). sigma: longitudinal relaxation length (m), eq. (3).
    f_rr: rolling-resistance coefficient (1); the moment is ``f_rr Fz R tanh(w / w_eps)`` (N m).
    w_eps: wheel speed (rad/s) below which rolling resistance fades to zero (smoothly, tanh).
    k_max: largest |transient slip| (1), see the module docstring.
    k_start: slip at the start (1); NaN = the steady value of (3) for the initial speeds.
    """

    B: float = 10.0
    C: float = 1.9
    E: float = 0.97
    sigma: float = 0.12
    f_rr: float = 0.015
    w_eps: float = 0.5
    k_max: float = 1.0
    k_start: float = math.nan

    # the fields' ranges (spurdiff.errors: validate and the FMU's min/max)
    BOUNDS = {**SHAPE_BOUNDS, "sigma": Bound(0.0, lo_open=True), "f_rr": Bound(0.0, 0.5),
              "w_eps": Bound(0.0, lo_open=True), "k_max": Bound(0.0, lo_open=True)}

    def validate(self, prefix: str = "tyre") -> None:
        check_fields(self, f"{prefix}.")
        if not math.isnan(self.k_start):
            require_finite(f"{prefix}.k_start", self.k_start)


__all__ = [
    "TyreParams", "magic_formula", "magic_formula_slope", "tyre_force", "peak_slip",
    "slip_for_force_ratio", "validate_shape",
]
