"""The TOML schema helpers of scene and sweep files (:mod:`harness.scene.spec`, :mod:`harness.sweep.spec`).

Both are data read with :mod:`tomllib`; every check here raises one line that names the key and
says what is allowed, as an ``error`` (:class:`SceneError` or a subclass, e.g. ``SweepError``).
:func:`parameter_value` converts a value by the FMI type of the variable it is set on; it is used
wherever a value from a file or the command line reaches an FMU.
"""
from __future__ import annotations

import math
import re
import tomllib
from pathlib import Path

from harness.common.messages import shown

INT32 = (-2**31, 2**31 - 1)
_TRUE = {"true", "on", "yes", "1"}
_FALSE = {"false", "off", "no", "0"}
_SAFE_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,99}$")
# the limits of a run's length (here, not in harness.scene.recording, which imports the scene: no cycle)
MAX_STEPS = 1_000_000   # communication steps of one run unless raised (spurdiff run --max-steps)
STEP_CAP = 1e30         # a count of steps beyond any run (inf and nan included): refused whatever the limit


class SceneError(ValueError):
    """A scene file that cannot be run (bad key, bad value, unknown FMU or variable)."""


def is_safe_name(name) -> bool:
    return isinstance(name, str) and bool(_SAFE_NAME.match(name)) and ".." not in name


def safe_name(where: str, name, error: type[SceneError] = SceneError) -> str:
    """``name`` if it can be a file or folder name inside a results folder (no separator, no '..',
    no leading dot, at most 100 characters); else an error naming ``where``."""
    if not is_safe_name(name):
        raise error(f"{where} = {shown(name)}: allowed letters, digits, '_', '-' and '.' (not first, no '..'), "
                    "at most 100 characters: it becomes a file name")
    return name


def _short(value, n: int = 60) -> str:
    """A value echoed in a message: cut, with its length stated (:func:`harness.common.messages.shown`)."""
    return shown(value, n)


def _float(value) -> float:
    """``float(value)`` of a number; an integer too large for a float is +-inf (refused as not finite)."""
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


def parameter_value(where: str, type_: str, value, finite: bool = True):
    """``value`` converted to the FMI type ``type_`` (Real, Integer, Enumeration, Boolean, String) of
    the variable it is set on; a value that does not fit raises a one-line SceneError.

    Booleans: true/false, or the words true/false, on/off, yes/no, 1/0 (any case). Integers: whole
    numbers in the int32 range (a boolean is not an integer). Reals: numbers, finite unless
    ``finite`` is false (an FMU's own refusal of inf and NaN is tested through the master)."""
    if type_ == "Boolean":
        if isinstance(value, bool):
            return value
        if isinstance(value, int) and value in (0, 1):
            return bool(value)
        if isinstance(value, str) and value.strip().lower() in _TRUE | _FALSE:
            return value.strip().lower() in _TRUE
        raise SceneError(f"{where} = {_short(value)}: allowed a boolean: true or false (also on/off, yes/no, 1/0)")
    if type_ in ("Integer", "Enumeration"):
        v = value
        if isinstance(v, float) and math.isfinite(v) and v.is_integer():
            v = int(v)
        if isinstance(v, bool) or not isinstance(v, int):
            raise SceneError(f"{where} = {_short(value)}: allowed an integer in {INT32[0]} .. {INT32[1]}")
        if not INT32[0] <= v <= INT32[1]:
            raise SceneError(f"{where} = {_short(value)}: out of the int32 range; allowed an integer in "
                             f"{INT32[0]} .. {INT32[1]}")
        return v
    if type_ == "Real":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise SceneError(f"{where} = {_short(value)}: allowed a number")
        x = _float(value)
        if finite and not math.isfinite(x):
            raise SceneError(f"{where} = {_short(value)}: allowed a finite number")
        return x
    if type_ == "String":
        if not isinstance(value, str):
            raise SceneError(f"{where} = {_short(value)}: allowed a string")
        return value
    raise SceneError(f"{where}: variable type {type_} cannot be set")


# ---------------------------------------------------------------------------- key checks
def unknown(where: str, keys, allowed, error: type[SceneError] = SceneError) -> None:
    """Refuse keys outside ``allowed``, naming them and listing the allowed ones."""
    bad = sorted(set(keys) - set(allowed))
    if bad:
        raise error(f"{where}: unknown key{'s' if len(bad) > 1 else ''} {', '.join(shown(b) for b in bad[:5])}"
                    f"{f' (and {len(bad) - 5} more)' if len(bad) > 5 else ''}; "
                    f"allowed: {', '.join(sorted(allowed))}")


def positive(where: str, value, error: type[SceneError] = SceneError) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise error(f"{where} = {shown(value)}: allowed a number > 0")
    v = _float(value)
    if not (v > 0.0 and math.isfinite(v)):
        raise error(f"{where} = {shown(value)}: allowed a finite number > 0")
    return v


def number(where: str, value, minimum: float | None = None, error: type[SceneError] = SceneError) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(_float(value)):
        raise error(f"{where} = {shown(value)}: allowed a finite number")
    if minimum is not None and value < minimum:
        raise error(f"{where} = {shown(value)}: allowed a number >= {minimum:g}")
    return float(value)


def count(where: str, value, error: type[SceneError] = SceneError) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise error(f"{where} = {shown(value)}: allowed an integer >= 1")
    return value


def text(where: str, value, error: type[SceneError] = SceneError) -> str:
    if not isinstance(value, str):
        raise error(f"{where} = {shown(value)}: allowed a string")
    return value


def table(where: str, value, error: type[SceneError] = SceneError) -> dict:
    if not isinstance(value, dict):
        raise error(f"{where} = {shown(value)}: allowed a table {{key = value, ...}}")
    return value


def tables(where: str, value, error: type[SceneError] = SceneError) -> list[dict]:
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise error(f"{where} = {shown(value)}: allowed an array of tables [[...]]")
    return value


def strings(where: str, value, error: type[SceneError] = SceneError) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise error(f"{where} = {shown(value)}: allowed a list of strings")
    return value


def scalar(where: str, value, error: type[SceneError] = SceneError):
    """A parameter value as a file gives it: a finite number, a string or a boolean."""
    if isinstance(value, (bool, int, str)) or (isinstance(value, float) and math.isfinite(value)):
        return value
    raise error(f"{where}: {shown(value)} is not allowed; allowed: a finite number, a string or a boolean")


def window(where: str, value, error: type[SceneError] = SceneError, start_at_zero: bool = False):
    """A time window [t0, t1] in s (t0 <= t1; with ``start_at_zero``: 0 <= t0 < t1); returned as given."""
    if not (isinstance(value, list) and len(value) == 2):
        raise error(f"{where} = {shown(value)}: allowed [t0, t1] in s")
    lo, hi = (number(where, v, error=error) for v in value)
    if start_at_zero and not 0 <= lo < hi:
        raise error(f"{where} = {shown(value)}: allowed 0 <= t0 < t1")
    if not lo <= hi:
        raise error(f"{where} = {shown(value)}: allowed [t0, t1] with t0 <= t1")
    return value


MAX_DEPTH = 32   # nesting of tables and arrays in a scene or sweep file


def depth(data) -> int:
    """Nesting depth of tables and arrays (a plain value is 0), without recursion."""
    deepest, todo = 0, [(data, 0)]
    while todo:
        value, d = todo.pop()
        if isinstance(value, dict):
            todo += [(v, d + 1) for v in value.values()]
        elif isinstance(value, list):
            todo += [(v, d + 1) for v in value]
        else:
            deepest = max(deepest, d)
            continue
        deepest = max(deepest, d + 1)
    return deepest


def read_toml(path: Path, error: type[SceneError] = SceneError) -> dict:
    """The TOML data of ``path``; a file that is not UTF-8 TOML, cannot be read, or nests tables
    and arrays deeper than :data:`MAX_DEPTH` is one line."""
    try:
        data = tomllib.loads(Path(path).read_bytes().decode("utf-8"))
    except UnicodeDecodeError as e:
        raise error(f"{path.name}: not UTF-8 text (byte {e.start}); allowed: a UTF-8 TOML file") from None
    except tomllib.TOMLDecodeError as e:
        raise error(f"{path.name}: not valid TOML: {e}") from None
    except RecursionError:
        raise error(f"{path.name}: tables or arrays nested too deep to read; allowed: at most {MAX_DEPTH} "
                    "levels") from None
    except ValueError as e:   # e.g. an integer of more than 4300 digits
        raise error(f"{path.name}: not valid TOML: {shown(str(e), 200)}") from None
    except OSError as e:
        raise error(f"{path.name}: cannot read: {e.strerror}") from None
    d = depth(data)
    if d > MAX_DEPTH:
        raise error(f"{path.name}: tables and arrays nested {d} levels deep; allowed: at most {MAX_DEPTH}")
    return data
