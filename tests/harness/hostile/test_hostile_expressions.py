"""Issue 14, item 1: scene and sweep expressions are data. The classic escape from an emptied
``__builtins__`` and other non-arithmetic are refused with one line naming the file and the key,
before anything runs; nothing outside the temporary folder changes."""
from __future__ import annotations

import math
import time

import numpy as np
import pytest

from hostile_harness_util import ESCAPE, cli, one_line_error, sandbox, scene, sweep  # noqa: F401

from harness.scene.expressions import ExpressionError, compile_expression


def payload(marker) -> str:
    return ESCAPE.format(marker=marker)


@pytest.mark.parametrize("where, body", [
    ("checks 'x'.var", '[[checks]]\nname = "x"\nstat = "max"\nvar = "{{diff.left.tauMesh}} + {p}.__len__()"\nbelow = 1e99'),
    ("checks 'x'.expect_var", '[[checks]]\nname = "x"\nstat = "max"\nvar = "diff.left.tauMesh"\n'
                              'expect_var = "{{diff.left.tauMesh}} * ({p} + 1)"\natol = 1e99'),
    ("table 'x'.var", '[[table]]\nlabel = "x"\nvar = "{{diff.left.tauMesh}} + ({p})"'),
    ("table 'x'.theory", '[[table]]\nlabel = "x"\nvar = "diff.left.tauMesh"\ntheory = "{{diff.left.tauMesh}} * ({p})"'),
])
def test_escape_payload_in_a_scene_is_refused_naming_file_and_key(sandbox, capsys, where, body):
    p = scene(sandbox.dir, body.format(p=payload(sandbox.marker).replace('"', '\\"')), name="escape")
    r = cli(capsys, "run", p, "--duration", "0.05", "--no-plots", "--out", sandbox.dir / "out")
    line = one_line_error(r, "escape.toml", where, "not allowed")
    assert "attribute access" in line or "comprehension" in line
    assert not (sandbox.dir / "out").exists()


@pytest.mark.parametrize("metric", [
    'var = "{{diff.lockingTorque}} + ({p})"\nstat = "mean"',
    'expr = "{{diff.mu_pin}} + ({p})"',
])
def test_escape_payload_in_a_sweep_is_refused_naming_file_and_key(sandbox, capsys, metric):
    p = sweep(sandbox.dir, '[[metrics]]\nname = "m"\n' + metric.format(p=payload(sandbox.marker).replace('"', '\\"')))
    r = cli(capsys, "sweep", p, "--workers", "0", "--out", sandbox.dir / "out", "--quiet")
    one_line_error(r, "hsweep.toml", "metrics 'm'.", "not allowed")
    assert not (sandbox.dir / "out").exists()


def test_exponent_tower_in_a_sweep_is_refused_at_once(sandbox, capsys):
    p = sweep(sandbox.dir, '[[metrics]]\nname = "boom"\nexpr = "{diff.mu_pin} ** 9 ** 9 ** 9"')
    t0 = time.perf_counter()
    r = cli(capsys, "sweep", p, "--workers", "0", "--out", sandbox.dir / "out", "--quiet")
    one_line_error(r, "hsweep.toml", "metrics 'boom'.expr", "exponent")
    assert time.perf_counter() - t0 < 30   # refused when read, not computed (it hung before)


@pytest.mark.parametrize("text, words", [
    ("().__class__.__base__.__subclasses__()", ["attribute access (.__subclasses__)"]),
    ("{a}.real", ["attribute access (.real)"]),
    ("{a}[0]", ["subscript"]),
    ("[x for x in {a}]", ["comprehension"]),
    ("(lambda: 1)()", ["lambda"]),
    ("__import__('os')", ["function '__import__'"]),
    ("open", ["name 'open'"]),
    ("'text'", ["constant"]),
    ("{a} if {b} else 1", ["if/else"]),
    ("{a} and {b}", ["and/or"]),
    ("abs(x={a})", ["keyword"]),
    ("max({a}, *{b})", ["*arguments"]),
    ("{a} ** 65", ["exponent 65", "at most 64"]),
    ("{a} ** -1e9", ["exponent", "at most 64"]),
    ("2 ** {a} ** 2", ["exponent that is itself a power"]),
    ("1e999", ["number out of range"]),
    ("9" * 400, ["number out of range"]),
    ("{a} + " * 100 + "1", ["at most 500"]),
    ("-" * 300 + "{a}", ["603 nodes of the parsed tree", "at most 600"]),
    ("+".join(["1"] * 201), ["201 terms (numbers and references)", "at most 200"]),
    ("(" * 201 + "{a}" + ")" * 201, ["not a valid arithmetic expression"]),
    ("{a}; import os", ["not a valid arithmetic expression"]),
    ("__ref0 + {a}", ["reserved"]),
    ("sqrt({a}, {b})", ["sqrt() takes 1 argument"]),
    ("{a} // {b}", ["FloorDiv"]),
])
def test_expression_module_refuses_what_is_not_arithmetic(text, words):
    with pytest.raises(ExpressionError) as e:
        compile_expression(text, "f.toml: checks 'k'.var", names=["a", "b"])
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("f.toml: checks 'k'.var = ") and "allowed" in msg
    for w in words:
        assert w in msg, msg


def test_expression_module_evaluates_arithmetic_comparisons_and_functions():
    a, b = np.array([1.0, 4.0, 9.0]), np.array([-2.0, 2.0, 3.0])
    e = compile_expression("sqrt({a}) / abs({b}) + 2 ** 3 - ({a} > 3) * max({a}, 5, {b}) + -{b} ** 2",
                           "k", names=["a", "b"])
    assert e.refs == ("a", "b")
    want = np.sqrt(a) / abs(b) + 8 - (a > 3) * np.maximum(np.maximum(a, 5), b) - b ** 2
    assert np.array_equal(e({"a": a, "b": b}), want)
    assert float(compile_expression("{x} ** 2.5 < 10 <= 11", "k")({"x": 2})) == 1.0
    assert math.isinf(float(compile_expression("{m} ** 64", "k")({"m": 1e300})))   # float64: cheap, no big ints
    with pytest.raises(ExpressionError, match="unknown reference 'c'"):
        compile_expression("{a} + {c}", "k", names=["a", "b"])
    with pytest.raises(ExpressionError, match="allowed a string"):
        compile_expression(5, "k")
