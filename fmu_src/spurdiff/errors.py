"""Errors raised for invalid model input.

Every check that rejects input raises :class:`ParameterError`, which names the offending
parameter, the value it got and the range it allows, so that the FMU adapters can log one
clear line and the harness can print one line and exit non-zero.
"""
from __future__ import annotations

import math
from typing import Any

from spurdiff.attrpath import record


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


# ---- the range a parameter field accepts (was spurdiff.errors)
# The range a parameter field accepts, declared once beside the field and used twice: by the
# parameter class's ``validate`` (:meth:`Bound.check`, the error naming the parameter and the range)
# and by the FMU's modelDescription (``min``/``max`` of the FMI variable bound to the field,
# :func:`bound_of`).
# 
# A parameter class declares ``BOUNDS = {field: Bound(lo, hi, ...)}``. FMI's min and max are closed;
# an open bound (``lo_open``: the value must be greater than ``lo``) is declared there as ``lo`` and
# refused at ``lo`` itself by the check. Bounds that depend on another parameter (``mu_pinDynamic <=
# mu_pin``) stay in ``validate`` beside the fixed outer range declared here.

@record(frozen=True)
class Bound:
    """lo <= value <= hi (either side None: unbounded there), finite; ``integer``: a whole number."""

    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    allowed: str | None = None     # how an error states the range (default from lo/hi)
    integer: bool = False
    hint: str | None = None        # why, added to the error

    def describe(self) -> str:
        if self.allowed:
            return self.allowed
        lo, hi = self.lo, self.hi
        kind = "an integer" if self.integer else None
        if lo is not None and hi is not None:
            if self.lo_open or self.hi_open:
                return (f"{'>' if self.lo_open else '>='} {lo:g} and {'<' if self.hi_open else '<='} {hi:g}")
            return f"{kind} from {lo:g} to {hi:g}" if kind else f"between {lo:g} and {hi:g}"
        if lo is not None:
            return f"{'>' if self.lo_open else '>='} {lo:g}"
        if hi is not None:
            return f"{'<' if self.hi_open else '<='} {hi:g}"
        return "a finite number"

    def contains(self, value: Any) -> bool:
        try:
            v = float(value)
        except (TypeError, ValueError):
            return False
        if not math.isfinite(v) or (self.integer and (isinstance(value, bool) or int(v) != v)):
            return False
        if self.lo is not None and not (v > self.lo if self.lo_open else v >= self.lo):
            return False
        if self.hi is not None and not (v < self.hi if self.hi_open else v <= self.hi):
            return False
        return True

    def check(self, name: str, value: Any) -> float:
        """``value`` as float; ParameterError naming ``name`` and the range if outside it."""
        if not self.contains(value):
            raise ParameterError(name, value, self.describe(), self.hint)
        return float(value)


def check_fields(obj: Any, prefix: str = "") -> None:
    """Check every field of ``obj`` its class declares a bound for (``prefix`` + field names the
    parameter in the error), in the declaration's order; a field that is None (an optional one not
    given, such as a gear's ``axialStart``) is not checked."""
    for field, b in type(obj).BOUNDS.items():
        value = getattr(obj, field)
        if value is not None:
            b.check(prefix + field, value)


def bound_of(root: Any, path: str) -> Bound | None:
    """The bound declared for the field at dotted ``path`` under ``root`` (by the class of the
    object holding it), None where none is declared."""
    head, _, last = path.rpartition(".")
    obj = root
    for part in head.split(".") if head else ():
        obj = getattr(obj, part)
    return getattr(type(obj), "BOUNDS", {}).get(last)


__all__ = ["Bound", "bound_of", "check_fields"]
