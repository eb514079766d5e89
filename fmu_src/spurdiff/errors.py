"""Errors raised for invalid model input.

Every check that rejects input raises :class:`ParameterError`, which names the offending
parameter, the value it got and the range it allows, so that the FMU adapters can log one
clear line and the harness can print one line and exit non-zero.
"""
from __future__ import annotations


class ParameterError(ValueError):
    """An input or parameter outside its valid range.

    Attributes
    ----------
    name: the parameter's structured name, e.g. ``sunA.z`` or ``left.tau``.
    value: the value that was rejected.
    allowed: a human-readable description of the allowed range, e.g. ``>= 0`` or ``finite``.
    """

    def __init__(self, name: str, value, allowed: str, hint: str = ""):
        self.name = name
        self.value = value
        self.allowed = allowed
        self.hint = hint
        msg = f"{name} = {value!r} is invalid: allowed {allowed}"
        if hint:
            msg += f" ({hint})"
        super().__init__(msg)


class StepError(RuntimeError):
    """A communication step a model could not complete; the model state is left as it was at the
    start of the step (so an FMU can return fmi2Discard with the last successful time)."""


def require_finite(name: str, value: float) -> float:
    """Return ``value`` as float, or raise ParameterError if it is NaN or infinite."""
    v = float(value)
    if v != v or v in (float("inf"), float("-inf")):
        raise ParameterError(name, value, "a finite number")
    return v


def require_positive(name: str, value: float) -> float:
    """Return ``value`` as float if finite and > 0."""
    v = require_finite(name, value)
    if not v > 0.0:
        raise ParameterError(name, value, "> 0")
    return v


def require_nonnegative(name: str, value: float) -> float:
    """Return ``value`` as float if finite and >= 0."""
    v = require_finite(name, value)
    if not v >= 0.0:
        raise ParameterError(name, value, ">= 0")
    return v


def require_range(name: str, value: float, lo: float, hi: float, allowed: str | None = None,
                  lo_open: bool = False) -> float:
    """Return ``value`` as float if finite and lo <= value <= hi (lo < value with ``lo_open``);
    ``allowed`` replaces the default description of the range in the error."""
    v = require_finite(name, value)
    if not (lo < v if lo_open else lo <= v) or not v <= hi:
        raise ParameterError(name, value, allowed or (f"> {lo:g} and <= {hi:g}" if lo_open
                                                      else f"between {lo:g} and {hi:g}"))
    return v
