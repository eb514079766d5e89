"""The copying between an FMU's value table and its physics, derived from the variables' bindings.

Every :class:`spurdiff.fmi.variables.Var` with a ``bind`` names what it stands for: an input the model
attribute it sets, an output or calculated parameter the model attribute it reads, a parameter its
field in the parameter objects. From these, once per model class, :class:`Bindings` compiles

* ``push(model, values)``: every input whose attribute the model has (a torque-coupled
  differential has no wheel-side inputs; those of a configuration that does not use them are
  not pushed), one attribute store per input;
* ``pull(model, values)``: every output (each must be answered by the model), one attribute read
  per output, a dotted path's shared prefix read once (``mesh_forces.F_A1``, ``.F_B2``...),
  Integer outputs as ``int``; ``pull_total`` the same returning the sum of the Real outputs
  (what the FMU adapter tests for a non-finite result);

as straight-line Python functions (generated source, as :mod:`dataclasses` writes its
``__init__``: no loop, no lookup table on the per-step path; the bindings are checked to be dotted
identifiers before any source is written). The FMU adapter (:mod:`spurdiff.fmi.adapter`) and the
harness's direct runs (``harness/direct.py``) use the same compiled functions.

:func:`build_params` builds the parameter objects from the values by the same bindings (frozen
dataclasses such as :class:`spurdiff.gears.geometry.GearTable` are replaced, mutable ones set), and
:func:`renamed` turns a validation error naming a field into one naming the FMU variable.
"""
from __future__ import annotations

import dataclasses
import re
from typing import Any, Callable, Sequence

from spurdiff.attrpath import resolve
from spurdiff.errors import ParameterError
from spurdiff.fmi.variables import Var

_PATH = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*\Z")
_CAST = {"Real": float, "Integer": int, "Boolean": bool, "String": str}


def _checked(v: Var) -> str:
    if not isinstance(v.bind, str) or not _PATH.match(v.bind):
        raise ValueError(f"{v.name}: binding {v.bind!r} is not a dotted attribute path")
    return v.bind


def slot_names(variables: Sequence[Var], plan) -> tuple[str | None, ...]:
    """The variable name of each slot of a native step's ``plan`` (:class:`spurdiff.native_step.NativeStep`):
    its inputs, then its outputs, each the Real input or output bound to the slot's attribute, None
    where the FMU declares none (the FMU's bridge and the direct runs read and write the slots by these)."""
    names = {(v.causality, v.bind): v.name for v in variables
             if v.kind == "Real" and v.bind and v.causality in ("input", "output")}
    return (tuple(names.get(("input", k)) for k in plan.inputs)
            + tuple(names.get(("output", k)) for k in plan.outputs))


def _own(obj: Any, name: str) -> bool:
    """``obj`` answers ``name`` itself (an instance or class attribute), not through ``__getattr__``."""
    return name in getattr(obj, "__dict__", ()) or any(name in vars(c) for c in type(obj).__mro__)


def _has(obj: Any, path: str) -> bool:
    """``obj`` answers the dotted ``path``, its first part without ``__getattr__`` (a forwarded
    attribute costs a failed lookup and a call on every read)."""
    first, *rest = path.split(".")
    if not _own(obj, first):
        return False
    obj = getattr(obj, first)
    try:
        for part in rest[:-1]:
            obj = getattr(obj, part)
    except AttributeError:
        return False
    return not rest or hasattr(obj, rest[-1])


def _compile(name: str, lines: list[str], env: dict | None = None) -> Callable:
    src = f"def {name}(model, values):\n" + "".join(f"    {ln}\n" for ln in (lines or ["pass"]))
    scope: dict = dict(env or {})
    exec(compile(src, f"<spurdiff.fmi.binding {name}>", "exec"), scope)   # source from checked paths only
    return scope[name]


def _target(path: str, prefixes: dict[str, str], lines: list[str]) -> str:
    """The expression for ``model.<path>``, reading each shared prefix once into a local."""
    head, _, last = path.rpartition(".")
    if not head:
        return f"model.{last}"
    if head not in prefixes:
        prefixes[head] = f"_{len(prefixes)}"
        lines.append(f"{prefixes[head]} = model.{head}")
    return f"{prefixes[head]}.{last}"


def compile_push(inputs: Sequence[Var], model: Any) -> Callable[[Any, dict], None]:
    """``push(model, values)`` storing each input the model has (see the module docstring)."""
    lines: list[str] = []
    prefixes: dict[str, str] = {}
    for v in inputs:
        path = _checked(v)
        if _has(model, path):
            lines.append(f"{_target(path, prefixes, lines)} = values[{v.name!r}]")
    return _compile("push", lines)


def _pull_lines(outputs: Sequence[Var], model: Any, total: bool) -> list[str]:
    """The lines of a pull; with ``total`` the Real outputs are also named ``_r0, _r1...`` and the
    last line returns their sum (0 when none)."""
    lines: list[str] = []
    prefixes: dict[str, str] = {}
    reals: list[str] = []
    for v in outputs:
        path = _checked(v)
        if not _has(model, path):
            raise AttributeError(f"output {v.name}: {type(model).__name__} has no attribute {path!r}")
        expr = _target(path, prefixes, lines)
        if total and v.kind == "Real":
            reals.append(f"_r{len(reals)}")
            lines.append(f"values[{v.name!r}] = {reals[-1]} = {expr}")
        else:
            lines.append(f"values[{v.name!r}] = " + (f"int({expr})" if v.kind == "Integer" else expr))
    if total:
        lines.append("return " + (" + ".join(reals) if reals else "0"))
    return lines


def compile_pull(outputs: Sequence[Var], model: Any) -> Callable[[Any, dict], None]:
    """``pull(model, values)`` reading every output; AttributeError naming the first output the
    model does not answer."""
    return _compile("pull", _pull_lines(outputs, model, total=False))


def compile_pull_total(outputs: Sequence[Var], model: Any) -> Callable[[Any, dict], Any]:
    """``pull`` (:func:`compile_pull`) that also returns the sum of the Real outputs it stored
    (0 when none), left to right: what an FMU adapter tests for a non-finite result (a NaN or an
    infinity makes the sum so) without reading the values back."""
    return _compile("pull_total", _pull_lines(outputs, model, total=True))


class Bindings:
    """The compiled push and pull of one variable list, per model class."""

    def __init__(self, variables: Sequence[Var]):
        self.variables = tuple(variables)
        self.inputs = [v for v in self.variables if v.causality == "input" and v.bind]
        self.outputs = [v for v in self.variables if v.causality == "output" and v.bind]
        self.calculated = [v for v in self.variables if v.causality == "calculatedParameter" and v.bind]
        self.parameters = [v for v in self.variables if v.causality == "parameter" and v.bind]
        for v in self.inputs + self.outputs + self.calculated + self.parameters:
            _checked(v)
        self.io_of: dict[type, tuple[Callable, Callable]] = {}   # model class -> (push, pull)
        self._push_of: dict[type, Callable] = {}
        self._pull_of: dict[type, Callable] = {}
        self._pull_total_of: dict[type, Callable] = {}
        self.real_outputs = [v.name for v in self.outputs if v.kind == "Real"]   # what pull_total sums

    def io(self, model: Any) -> tuple[Callable[[Any, dict], None], Callable[[Any, dict], None]]:
        """(push, pull) for an initialized ``model`` (compiled at the first model of its class)."""
        io = self.io_of.get(model.__class__)
        if io is None:
            io = self.io_of[model.__class__] = (self._push(model), self._pull(model))
        return io

    @staticmethod
    def _compiled(cache: dict, compile_fn: Callable, variables: Sequence[Var], model: Any) -> Callable:
        """``compile_fn(variables, model)`` for ``model``'s class, compiled at its first model (kept in ``cache``)."""
        f = cache.get(model.__class__)
        if f is None:
            f = cache[model.__class__] = compile_fn(variables, model)
        return f

    def _push(self, model: Any) -> Callable[[Any, dict], None]:
        return self._compiled(self._push_of, compile_push, self.inputs, model)

    def _pull(self, model: Any) -> Callable[[Any, dict], None]:
        return self._compiled(self._pull_of, compile_pull, self.outputs, model)

    def pull_total(self, model: Any) -> Callable[[Any, dict], Any]:
        """:func:`compile_pull_total` for ``model``'s class (compiled at its first model)."""
        return self._compiled(self._pull_total_of, compile_pull_total, self.outputs, model)

    def push(self, model: Any, values: dict) -> None:
        """The inputs into ``model`` (also before it is initialized)."""
        self._push(model)(model, values)

    def pull(self, model: Any, values: dict) -> None:
        """The outputs of an initialized ``model`` into ``values``."""
        self._pull(model)(model, values)

    def pull_calculated(self, model: Any, values: dict) -> None:
        """The bound calculated parameters from ``model`` (once, after it is built)."""
        for v in self.calculated:
            values[v.name] = _CAST[v.kind](resolve(model, v.bind))


_BINDINGS: dict[int, tuple[Sequence[Var], Bindings]] = {}   # id -> (the list, kept alive; its Bindings)


def bindings(variables: Sequence[Var]) -> Bindings:
    """The one :class:`Bindings` of a declared variable list (shared by every instance)."""
    entry = _BINDINGS.get(id(variables))
    if entry is None or entry[0] is not variables:
        entry = _BINDINGS[id(variables)] = (variables, Bindings(variables))
    return entry[1]


def _cast(v: Var, x: Any, current: Any) -> Any:
    if v.kind == "Boolean" and isinstance(current, int) and not isinstance(current, bool):
        return int(bool(x))   # a 0/1 switch in the parameter object
    return _CAST[v.kind](x)


def _replaced(obj: Any, parts: list[str], value: Any) -> Any:
    """``obj`` with the field at ``parts`` set to ``value``: a frozen dataclass is replaced, any
    other object set in place."""
    head = parts[0]
    new = value if len(parts) == 1 else _replaced(getattr(obj, head), parts[1:], value)
    if dataclasses.is_dataclass(obj) and obj.__dataclass_params__.frozen:
        return dataclasses.replace(obj, **{head: new})
    setattr(obj, head, new)
    return obj


def build_params(variables: Sequence[Var], values: dict, root: Any) -> Any:
    """``root`` (the parameter objects, their defaults) with every bound parameter set from
    ``values``, cast to the variable's type (a Boolean into a 0/1 field stays an int)."""
    for v in bindings(variables).parameters:
        parts = v.bind.split(".")
        root = _replaced(root, parts, _cast(v, values[v.name], resolve(root, v.bind)))
    return root


def renamed(error: ParameterError, variables: Sequence[Var], prefix: str) -> ParameterError:
    """``error`` naming the FMU variable bound to field ``prefix.<error.name>`` (unchanged if none)."""
    names = {v.bind[len(prefix) + 1:]: v.name for v in bindings(variables).parameters
             if v.bind.startswith(prefix + ".")}
    return ParameterError(names.get(error.name, error.name), error.value, error.allowed, error.hint)


__all__ = ["Bindings", "bindings", "build_params", "compile_pull", "compile_pull_total", "compile_push", "renamed",
           "resolve"]
