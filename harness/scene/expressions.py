"""Expressions in scene and sweep files: parsed to a tree, checked against an allowlist, evaluated
by walking the tree (never ``eval``).

An expression is arithmetic over references in braces, e.g. ``"{wheelR.wheel.w} / {wheelL.wheel.w}"``
(scene quantities: recorded variables ``{inst.var}``; sweep metrics: earlier columns ``{name}``
and parameters ``{inst.param}``). Allowed:

* numbers (at most :data:`MAX_NUMBER` in magnitude) and references in braces;
* ``+ - * / **``, unary ``-`` and ``+``, comparisons ``< <= > >= == !=`` (true is 1.0, false 0.0);
* the functions of :data:`FUNCTIONS`, called by name with positional arguments.

Nothing else: no attributes, subscripts, comprehensions, lambdas, strings, keywords or other
names. Sizes are bounded: :data:`MAX_LENGTH` characters, :data:`MAX_TERMS` terms (numbers and
references), :data:`MAX_NODES` nodes of the parsed tree (terms, operators, calls), a literal
exponent at most :data:`MAX_EXPONENT` in magnitude and no exponent that is itself a power
(``m ** 9 ** 9 ** 9``). Every value is a float64 (or an array of them, for recorded series), so no
operation is exact big-integer arithmetic: the cost of an evaluation is linear in the tree size
times the series length.

A refused expression raises :class:`ExpressionError` with one line naming where it came from
(the file and the key), the expression and what is not allowed.
"""
from __future__ import annotations

import ast
import functools
import math
import operator
import re
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Mapping

import numpy as np

from harness.scene.schema import SceneError

MAX_LENGTH = 500          # characters
MAX_TERMS = 200           # terms: numbers and references
MAX_NODES = 600           # nodes of the parsed tree: terms, operators, calls (200 summed terms are 599)
MAX_EXPONENT = 64.0       # magnitude of a literal exponent
MAX_NUMBER = 1e300        # magnitude of a literal number
REF = re.compile(r"\{([^{}]+)\}")
_PLACEHOLDER = "__ref"


def _reduce(f: Callable) -> Callable:
    return lambda *args: functools.reduce(f, args)


# name -> (function, least, most arguments)
FUNCTIONS: dict[str, tuple[Callable, int, int]] = {
    "abs": (np.abs, 1, 1),
    "sqrt": (np.sqrt, 1, 1),
    "exp": (np.exp, 1, 1),
    "log": (np.log, 1, 1),
    "log10": (np.log10, 1, 1),
    "sign": (np.sign, 1, 1),
    "min": (_reduce(np.minimum), 2, 8),
    "max": (_reduce(np.maximum), 2, 8),
    "minimum": (np.minimum, 2, 2),
    "maximum": (np.maximum, 2, 2),
}
_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
           ast.Pow: operator.pow}
_UNARY = {ast.USub: operator.neg, ast.UAdd: operator.pos}
_COMPARE = {ast.Lt: operator.lt, ast.LtE: operator.le, ast.Gt: operator.gt, ast.GtE: operator.ge,
            ast.Eq: operator.eq, ast.NotEq: operator.ne}
_STRUCTURE = (ast.Expression, ast.BinOp, ast.UnaryOp, ast.Compare, ast.Constant, ast.Name, ast.Call, ast.Load)
ALLOWED = (f"numbers, references in braces, + - * / **, comparisons, "
           f"{', '.join(f + '()' for f in FUNCTIONS)}")


class ExpressionError(SceneError):
    """An expression that is not allowed (bad syntax, a forbidden construct, too large)."""


def _show(text: str, n: int = 80) -> str:
    s = repr(text)
    return s if len(s) <= n else s[: n - 4] + "...'"


@dataclass(frozen=True)
class Expression:
    """A checked expression: its text, the references it reads (in order) and its tree."""

    text: str
    refs: tuple[str, ...]
    tree: ast.Expression

    def __call__(self, values: Mapping[str, Any] | Callable[[str], Any]):
        """The value for ``values`` (a mapping or a function from reference to value):
        a float for scalar inputs, a float array for series."""
        get = values if callable(values) else values.__getitem__
        args = [np.asarray(get(r), dtype=float) for r in self.refs]
        with np.errstate(all="ignore"):
            out = _eval(self.tree.body, args)
        return out


def _eval(node: ast.AST, args: list):
    if isinstance(node, ast.Constant):
        return np.float64(node.value)
    if isinstance(node, ast.Name):
        return args[int(node.id[len(_PLACEHOLDER):])]
    if isinstance(node, ast.BinOp):
        return _BINARY[type(node.op)](_eval(node.left, args), _eval(node.right, args))
    if isinstance(node, ast.UnaryOp):
        return _UNARY[type(node.op)](_eval(node.operand, args))
    if isinstance(node, ast.Compare):
        left = _eval(node.left, args)
        out = None
        for op, right in zip(node.ops, node.comparators):
            r = _eval(right, args)
            c = _COMPARE[type(op)](left, r)
            out = c if out is None else np.logical_and(out, c)
            left = r
        return np.asarray(out, dtype=float)
    if isinstance(node, ast.Call):
        return FUNCTIONS[node.func.id][0](*(_eval(a, args) for a in node.args))
    raise ExpressionError(f"{type(node).__name__} not allowed")  # unreachable after the check


def _literal(node: ast.AST) -> float | None:
    """The value of a number literal, also with a unary sign; None for anything else."""
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        v = _literal(node.operand)
        return None if v is None else (-v if isinstance(node.op, ast.USub) else v)
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
        return float(node.value)
    return None


def _what(node: ast.AST) -> str:
    names = {ast.Attribute: "attribute access", ast.Subscript: "subscript", ast.Lambda: "lambda",
             ast.ListComp: "comprehension", ast.SetComp: "comprehension", ast.DictComp: "comprehension",
             ast.GeneratorExp: "comprehension", ast.BoolOp: "and/or", ast.IfExp: "if/else",
             ast.NamedExpr: "assignment", ast.Starred: "*arguments", ast.JoinedStr: "string",
             ast.List: "list", ast.Tuple: "tuple", ast.Dict: "dict", ast.Set: "set"}
    if isinstance(node, ast.Attribute):
        return f"attribute access (.{node.attr})"
    return names.get(type(node), type(node).__name__)


def _check(text: str, tree: ast.Expression, fail: Callable[[str], ExpressionError]) -> None:
    nodes = list(ast.walk(tree))
    callee = {id(n.func) for n in nodes if isinstance(n, ast.Call)}
    terms = sum(isinstance(n, ast.Constant) or (isinstance(n, ast.Name) and id(n) not in callee) for n in nodes)
    if terms > MAX_TERMS:
        raise fail(f"{terms} terms (numbers and references); allowed at most {MAX_TERMS}")
    if len(nodes) > MAX_NODES:
        raise fail(f"{len(nodes)} nodes of the parsed tree (terms, operators, calls); allowed at most {MAX_NODES}")
    for node in nodes:
        if isinstance(node, (ast.operator, ast.unaryop, ast.cmpop)):
            if type(node) not in {**_BINARY, **_UNARY, **_COMPARE}:
                raise fail(f"operator {type(node).__name__} not allowed")
            continue
        if not isinstance(node, _STRUCTURE):
            raise fail(f"{_what(node)} not allowed")
        if isinstance(node, ast.Constant):
            v = node.value
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise fail(f"constant {_show(str(v), 40)} not allowed; only numbers")
            try:
                x = float(v)
            except OverflowError:
                x = math.inf
            if not abs(x) <= MAX_NUMBER:
                raise fail(f"number out of range; allowed at most {MAX_NUMBER:g} in magnitude")
        elif isinstance(node, ast.Name):
            if id(node) in callee:
                if node.id not in FUNCTIONS:
                    raise fail(f"function {node.id!r} not allowed")
            elif not node.id.startswith(_PLACEHOLDER):
                raise fail(f"name {node.id!r} not allowed; refer to values in braces, e.g. {{inst.var}}")
        elif isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name):
                raise fail(f"calling {_what(node.func)} not allowed")
            if node.keywords:
                raise fail(f"keyword arguments to {node.func.id}() not allowed")
            if node.func.id in FUNCTIONS:
                _, lo, hi = FUNCTIONS[node.func.id]
                if not lo <= len(node.args) <= hi:
                    n = f"{lo}" if lo == hi else f"{lo} to {hi}"
                    raise fail(f"{node.func.id}() takes {n} argument{'s' if hi > 1 else ''}, got {len(node.args)}")
        elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
            if any(isinstance(n, ast.BinOp) and isinstance(n.op, ast.Pow) for n in ast.walk(node.right)):
                raise fail("an exponent that is itself a power (a ** b ** c) is not allowed")
            e = _literal(node.right)
            if e is not None and not abs(e) <= MAX_EXPONENT:
                raise fail(f"exponent {e:g} out of range; allowed at most {MAX_EXPONENT:g} in magnitude")


@functools.lru_cache(maxsize=1024)
def _compile(text: str) -> Expression | str:
    """The checked expression, or the reason it is refused (cached: scenes evaluate theirs often)."""
    class _Refused(Exception):
        pass

    def fail(reason: str) -> Exception:
        return _Refused(reason)

    try:
        if len(text) > MAX_LENGTH:
            raise fail(f"{len(text)} characters; allowed at most {MAX_LENGTH}")
        refs = list(dict.fromkeys(r.strip() for r in REF.findall(text)))
        outside = REF.sub(" ", text)
        if _PLACEHOLDER in outside:
            raise fail(f"name {_PLACEHOLDER!r} is reserved")
        index = {r: i for i, r in enumerate(refs)}
        code = REF.sub(lambda m: f" {_PLACEHOLDER}{index[m.group(1).strip()]} ", text)
        try:
            tree = ast.parse(code.strip(), mode="eval")
        except (SyntaxError, ValueError):
            raise fail("not a valid arithmetic expression") from None
        except (RecursionError, MemoryError):
            raise fail("nested too deeply") from None
        _check(text, tree, fail)
        return Expression(text, tuple(refs), tree)
    except _Refused as e:
        return str(e)


def compile_expression(text: Any, where: str = "expression", names: Iterable[str] | None = None) -> Expression:
    """Check ``text``; ``names``, when given, are the references allowed in braces.

    Raises :class:`ExpressionError` (one line: ``where``, the text, the reason, what is allowed)."""
    if not isinstance(text, str):
        raise ExpressionError(f"{where} = {text!r}: allowed a string (an expression over {{references}})")
    got = _compile(text)
    if isinstance(got, str):
        raise ExpressionError(f"{where} = {_show(text)}: {got}; allowed: {ALLOWED}")
    if names is not None:
        names = list(names)
        missing = [r for r in got.refs if r not in names]
        if missing:
            shown = ", ".join(names[:20]) + (" ..." if len(names) > 20 else "")
            raise ExpressionError(f"{where} = {_show(text)}: unknown reference {missing[0]!r}; "
                                  f"allowed: {shown or 'none'}")
    return got


def is_expression(quantity: Any) -> bool:
    """A quantity with references in braces (else it names one variable)."""
    return isinstance(quantity, str) and "{" in quantity
