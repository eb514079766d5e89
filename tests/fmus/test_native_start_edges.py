"""The native start against the Python start at its edges (fmu_src/native/fmi/native_start.c,
fmi2_loader.c): call-order violations, stop and start times, odd step sizes, non-finite inputs,
logging switched in every way, unknown value references, sets equal and unequal to the start values,
two instances at once, a long tape replayed, the model's own process (the FMI 3.0 binary:
test_native_start_fmi3.py; a damaged resources/native_start.bin: test_native_start_damaged.py). Every case runs the same calls with SPURDIFF_FMU_START=auto and =python
and compares what the host sees: each status, each value bit for bit, every message."""
from __future__ import annotations

import math
import struct
from ctypes import c_char_p, c_double, c_int, c_size_t, c_uint, c_void_p

import pytest
from test_native_start import CHANGES, KINDS

from harness.fmi.instance import Instance, fmu_cache

NAMES = list(CHANGES)
CTYPE = {"Real": c_double, "Integer": c_int, "Boolean": c_int, "String": c_char_p}


def _bits(kind, x):
    if kind == "Real":
        return struct.pack("<d", x).hex()
    if kind == "String":
        return x.decode("utf-8", "replace") if x is not None else None
    return int(x)


class Md:
    """The variables of an FMU picked by role (any of the three FMUs)."""

    def __init__(self, path):
        self.path = path
        self.unzipdir, self.md = fmu_cache().get(path)
        self.vars = list(self.md.modelVariables)
        self.by = {v.name: v for v in self.vars}
        self.inputs = [v for v in self.vars if v.causality == "input" and v.type == "Real"]
        self.outputs = [v.valueReference for v in self.vars if v.causality == "output" and v.type == "Real"]

    def vr(self, name):
        return self.by[name].valueReference

    def params(self, kind):
        return [v for v in self.vars if v.causality == "parameter" and v.type == kind and v.start is not None]

    def start(self, v):
        if v.type == "Real":
            return float(v.start)
        if v.type == "Integer":
            return int(v.start)
        if v.type == "Boolean":
            return v.start in ("true", "1", True)
        return v.start


def _call(inst, name, *args):
    return int(inst.c_function(name)(inst.component, *args))


def _get(inst, kind, vrs):
    n = len(vrs)
    vals = (CTYPE[kind] * max(n, 1))()
    s = _call(inst, f"fmi2Get{kind}", (c_uint * max(n, 1))(*vrs), c_size_t(n), vals)
    return (s, [_bits(kind, x) for x in vals[:n]] if s <= 1 else None)


def _set(inst, kind, vrs, values):
    n = len(vrs)
    if kind == "String":
        arr = (c_char_p * max(n, 1))(*[v.encode() for v in values])
    else:
        arr = (CTYPE[kind] * max(n, 1))(*[(int(v) if kind != "Real" else v) for v in values])
    return _call(inst, f"fmi2Set{kind}", (c_uint * max(n, 1))(*vrs), c_size_t(n), arr)


def _all(inst, m):
    return [_get(inst, k, [v.valueReference for v in m.vars if v.type == k]) for k in KINDS]


def _do(inst, m, act):
    op, *a = act
    if op == "setup":      # (start, stop or None[, tolerance or None])
        t0, t1, *tol = a
        tol = tol[0] if tol else None
        return _call(inst, "fmi2SetupExperiment", 1 if tol is not None else 0, c_double(tol or 0.0), c_double(t0),
                     1 if t1 is not None else 0, c_double(t1 if t1 is not None else 0.0))
    if op in ("enter", "exit", "terminate", "reset"):
        fn = {"enter": "fmi2EnterInitializationMode", "exit": "fmi2ExitInitializationMode",
              "terminate": "fmi2Terminate", "reset": "fmi2Reset"}[op]
        return _call(inst, fn)
    if op == "step":       # (t, h[, noSetFMUStatePriorToCurrentPoint]): its status and the outputs after it
        s = _call(inst, "fmi2DoStep", c_double(a[0]), c_double(a[1]), a[2] if len(a) > 2 else 1)
        return s, _get(inst, "Real", m.outputs)
    if op == "steps":      # (t0, n, h): the statuses, the outputs every 100 steps and at the end
        t, n, h = a
        fn, comp = inst.c_function("fmi2DoStep"), inst.component
        out = []
        for i in range(n):
            s = int(fn(comp, c_double(t), c_double(h), 1))
            t += h
            if s != 0 or i % 100 == 99 or i == n - 1:
                out.append((i, s, _get(inst, "Real", m.outputs)))
        return out
    if op == "status":     # (function, kind): its status and the value
        from ctypes import byref
        fn, k = a
        x = {"fmi2GetStatus": c_int, "fmi2GetRealStatus": c_double, "fmi2GetIntegerStatus": c_int,
             "fmi2GetBooleanStatus": c_int, "fmi2GetStringStatus": c_char_p}[fn]()
        st = _call(inst, fn, c_int(k), byref(x))
        return st, _bits("Real", x.value) if isinstance(x, c_double) else x.value
    if op == "other":      # the functions the native start leaves to the Python, with harmless arguments
        fn = a[0]
        if fn == "fmi2CancelStep":
            return _call(inst, fn)
        if fn == "fmi2GetDirectionalDerivative":
            u, z = (c_uint * 1)(m.inputs[0].valueReference), (c_uint * 1)(m.outputs[0])
            du, dz = (c_double * 1)(1.0), (c_double * 1)()
            return _call(inst, fn, u, c_size_t(1), z, c_size_t(1), du, dz), _bits("Real", dz[0])
        vr, order, v = (c_uint * 1)(m.inputs[0].valueReference), (c_int * 1)(1), (c_double * 1)(0.0)
        return _call(inst, fn, vr, c_size_t(1), order, v)
    if op in ("nullget", "nullset"):   # (kind): n = 0 with NULL arrays
        return _call(inst, f"fmi2{op[4:].capitalize()}{a[0]}", None, c_size_t(0), None)
    if op == "get":
        return _get(inst, *a)
    if op == "set":
        return _set(inst, *a)
    if op == "all":
        return _all(inst, m)
    if op == "log":        # (on, categories)
        on, cats = a
        arr = (c_char_p * max(len(cats), 1))(*[c.encode() for c in cats])
        return _call(inst, "fmi2SetDebugLogging", 1 if on else 0, c_size_t(len(cats)), arr)
    if op == "state":
        st = c_void_p()
        from ctypes import byref
        s1 = _call(inst, "fmi2GetFMUstate", byref(st))
        s2 = _call(inst, "fmi2SetFMUstate", st) if s1 == 0 else None
        s3 = _call(inst, "fmi2FreeFMUstate", byref(st)) if s1 == 0 else None
        return s1, s2, s3
    raise ValueError(op)


def _instance(m, mode, monkeypatch, logging=True, name="ns", unzipdir=None, md=None, env=0x5150):
    monkeypatch.setenv("SPURDIFF_FMU_START", mode)
    inst = Instance(name, None, unzipdir=unzipdir or m.unzipdir, md=md or m.md, instantiate=False)
    if not logging:
        orig = inst.slave.instantiate
        inst.slave.instantiate = lambda **kw: orig(**{**kw, "loggingOn": False})
    inst.instantiate(logger=_logger(inst.messages), environment=env)
    return inst


def _logger(sink):
    """A C logger keeping everything the host is given: instance name, status, category, text."""
    from fmpy.fmi2 import fmi2CallbackLoggerTYPE

    def text(b):
        return b.decode("utf-8", "replace") if isinstance(b, bytes) else str(b)

    def log(env, name, status, category, message):
        sink.append((int(status), text(message), text(name), text(category), env))
    log.c = fmi2CallbackLoggerTYPE(log)
    return log.c


def trace(m, mode, program, monkeypatch, logging=True, **kw):
    """Each action's result on a new instance started in ``mode``, then its messages."""
    inst = _instance(m, mode, monkeypatch, logging, **kw)
    try:
        out = [(act[0], _do(inst, m, act)) for act in program]
    finally:
        inst.close()
    return out + [("messages", list(inst.messages))]


def same(m, program, monkeypatch, logging=True, **kw):
    native = trace(m, "auto", program, monkeypatch, logging, **kw)
    python = trace(m, "python", program, monkeypatch, logging, **kw)
    assert native == python
    assert any(r == 0 or (isinstance(r, tuple) and r[0] == 0) for _, r in native[:-1]), "some call succeeds"
    return native


@pytest.fixture(params=NAMES)
def m(request, fmu_files):
    return Md(fmu_files[request.param])


INIT = [("setup", 0.0, None), ("enter",), ("exit",)]
H = 1e-3


def _steps(t0, n, h=H):
    return [("steps", t0, n, h)]


# ------------------------------------------------------------------------------ call order
ORDER = {
    "step-before-init": [("step", 0.0, H)] + INIT + _steps(0.0, 5),
    "exit-before-enter": [("setup", 0.0, None), ("exit",), ("enter",), ("exit",)] + _steps(0.0, 5),
    "enter-twice": [("setup", 0.0, None), ("enter",), ("enter",), ("exit",)] + _steps(0.0, 5),
    "setup-after-enter": [("setup", 0.0, None), ("enter",), ("setup", 1.0, None), ("exit",)] + _steps(0.0, 5),
    "setup-twice": [("setup", 0.0, 5.0), ("setup", 0.0, None), ("enter",), ("exit",)] + _steps(0.0, 5),
    "setup-after-exit": INIT + [("setup", 0.0, None)] + _steps(0.0, 5),
    "exit-twice": INIT + [("exit",)] + _steps(0.0, 5),
    "terminate-before-init": [("terminate",)] + INIT + _steps(0.0, 3),
    "terminate-in-init": [("setup", 0.0, None), ("enter",), ("terminate",), ("exit",)] + _steps(0.0, 3),
    "terminate-twice": INIT + _steps(0.0, 5) + [("terminate",), ("terminate",), ("all",)],
    "after-terminate": INIT + _steps(0.0, 5) + [("terminate",), ("all",), ("step", 5 * H, H)],
    "reset-after-terminate": INIT + _steps(0.0, 5) + [("terminate",), ("reset",)] + INIT + _steps(0.0, 5),
    "reset-before-init": [("reset",)] + INIT + _steps(0.0, 5),
    "reset-in-init": [("setup", 0.0, None), ("enter",), ("reset",)] + INIT + _steps(0.0, 5),
    "state-before-init": [("state",)] + INIT + _steps(0.0, 3),
    "state-in-init": [("setup", 0.0, None), ("enter",), ("state",), ("all",), ("exit",)] + _steps(0.0, 3),
    "state-after-terminate": INIT + _steps(0.0, 3) + [("terminate",), ("state",), ("all",)],
    "no-setup": [("enter",), ("exit",)] + _steps(0.0, 5),
}


@pytest.mark.parametrize("case", list(ORDER))
def test_call_order_violations(m, monkeypatch, case):
    same(m, ORDER[case], monkeypatch)


def test_set_after_terminate(m, monkeypatch):
    u = m.inputs[0]
    p = m.params("Real")[0]
    prog = INIT + _steps(0.0, 3) + [("terminate",), ("set", "Real", [u.valueReference], [m.start(u)]),
                                     ("set", "Real", [p.valueReference], [m.start(p)]), ("all",)]
    same(m, prog, monkeypatch)


# ------------------------------------------------------------------------------ times
TIMES = {
    "stop-exactly-reached": [("setup", 0.0, 0.01), ("enter",), ("exit",)] + _steps(0.0, 10)
    + [("step", 0.01, H)],
    "stop-step-lands-on-it": [("setup", 0.0, 0.01), ("enter",), ("exit",), ("step", 0.0, 0.009),
                              ("step", 0.009, 0.001), ("step", 0.01, 1e-12)],
    "stop-step-past-it": [("setup", 0.0, 0.01), ("enter",), ("exit",), ("step", 0.0, 0.0105)],
    "stop-equals-start": [("setup", 0.5, 0.5), ("enter",), ("exit",), ("step", 0.5, H)],
    "stop-before-start": [("setup", 1.0, 0.5), ("enter",), ("exit",), ("step", 1.0, H)],
    "start-2.5": [("setup", 2.5, None), ("enter",), ("exit",)] + _steps(2.5, 20),
    "start-negative": [("setup", -1.0, 1.0), ("enter",), ("exit",)] + _steps(-1.0, 20),
    "start-huge": [("setup", 1e9, None), ("enter",), ("exit",)] + _steps(1e9, 5),
    "start-nan": [("setup", math.nan, None), ("enter",), ("exit",), ("step", 0.0, H)],
    "start-inf": [("setup", math.inf, None), ("enter",), ("exit",), ("step", 0.0, H)],
    "stop-nan": [("setup", 0.0, math.nan), ("enter",), ("exit",), ("step", 0.0, H)],
    "stop-inf": [("setup", 0.0, math.inf), ("enter",), ("exit",), ("step", 0.0, H)],
    "stop-within-tolerance": [("setup", 0.0, 0.01), ("enter",), ("exit",), ("step", 0.0, 0.009),
                              ("step", 0.009, 0.001 + 5e-10), ("step", 0.01 + 5e-10, H)],
    "stop-just-past-tolerance": [("setup", 0.0, 0.01), ("enter",), ("exit",), ("step", 0.0, 0.009),
                                 ("step", 0.009, 0.001 + 3e-9)],
    "start-2.5-read-in-init": [("setup", 2.5, 3.0), ("enter",), ("all",), ("exit",), ("all",)] + _steps(2.5, 5)
    + [("all",)],
    "start-2.5-read-after-setup": [("setup", 2.5, 3.0), ("all",), ("enter",), ("exit",)] + _steps(2.5, 3),
    "stop-read-in-init": [("setup", 0.0, 0.02), ("enter",), ("all",), ("exit",), ("all",)] + _steps(0.0, 5)
    + [("all",)],
    "step-wrong-time": INIT + [("step", 0.5, H), ("step", 0.0, H), ("step", 0.0, H), ("step", 5e-4, H)],
    "step-start-ignored": [("setup", 2.5, None), ("enter",), ("exit",), ("step", 0.0, H), ("step", 2.5, H)],
    "step-time-within-tolerance": INIT + [("step", 1e-10, H), ("step", H + 1e-9, H)],
    "step-time-at-tolerance": INIT + [("step", 0.0, H), ("step", H + 1e-9 * 1 + 1e-6 * H, H)],
}


@pytest.mark.parametrize("case", list(TIMES))
def test_times(m, monkeypatch, case):
    same(m, TIMES[case], monkeypatch)


@pytest.mark.parametrize("tol", [1e-3, 1e-9, 0.0, -1.0, math.nan, math.inf, 1.0])
def test_setup_with_a_tolerance(m, monkeypatch, tol):
    """A tolerance the host defines: the model may use it (its build, its steps) or refuse it."""
    same(m, [("setup", 0.0, None, tol), ("enter",), ("all",), ("exit",), ("all",)] + _steps(0.0, 20) + [("all",)],
         monkeypatch)


@pytest.mark.parametrize("h", [0.0, -H, math.nan, math.inf, -math.inf, 1e-300, 5e-324, 10.0],
                         ids=["zero", "negative", "nan", "inf", "-inf", "tiny", "denormal", "large"])
def test_step_sizes(m, monkeypatch, h):
    same(m, INIT + _steps(0.0, 3) + [("step", 3 * H, h), ("step", 3 * H, H)], monkeypatch)


# ------------------------------------------------------------------------------ inputs
@pytest.mark.parametrize("x", [math.nan, math.inf, -math.inf, -0.0, 1e308],
                         ids=["nan", "inf", "-inf", "-zero", "huge"])
@pytest.mark.parametrize("when", ["instantiated", "initializing", "stepping"])
def test_non_finite_inputs(m, monkeypatch, x, when):
    u = m.inputs[0].valueReference
    s = ("set", "Real", [u], [x])
    prog = {"instantiated": [s] + INIT + _steps(0.0, 3),
            "initializing": INIT[:2] + [s, ("all",), ("exit",)] + _steps(0.0, 3),
            "stepping": INIT + _steps(0.0, 3) + [s, ("step", 3 * H, H), ("get", "Real", [u]),
                                                 ("set", "Real", [u], [m.start(m.inputs[0])]), ("step", 4 * H, H)]}
    same(m, prog[when] + [("all",)], monkeypatch)


def test_every_input_set_to_its_start_before_init_then_read(m, monkeypatch):
    """Sets equal to the start values (native) then reads in Initialization Mode: the build's messages
    at the first read, again after another set (the model is rebuilt), none at exitInitializationMode."""
    vrs = [v.valueReference for v in m.inputs]
    starts = [m.start(v) for v in m.inputs]
    prog = [("set", "Real", vrs, starts), ("setup", 0.0, None), ("set", "Real", vrs, starts), ("enter",),
            ("set", "Real", vrs, starts), ("all",), ("all",), ("set", "Real", vrs[:1], starts[:1]), ("all",),
            ("exit",)] + _steps(0.0, 5)
    native = same(m, prog, monkeypatch)
    assert native[-1][1], "the messages are compared"


def test_input_set_while_stepping_in_a_changing_order(m, monkeypatch):
    """More input vectors than the native start caches (4), in changing orders, with reads between."""
    us = m.inputs
    prog = list(INIT)
    t = 0.0
    for k in range(12):
        pick = [us[(k + j) % len(us)] for j in range(1 + k % len(us))]
        prog += [("set", "Real", [v.valueReference for v in pick], [m.start(v) for v in pick]),
                 ("step", t, H), ("get", "Real", list(reversed(m.outputs))[: 1 + k])]
        t += H
    same(m, prog, monkeypatch)


def test_input_sets_of_odd_shapes_while_stepping(m, monkeypatch):
    """A reference twice in one set (the last value holds), a set of none, a read of the input before the
    step, an out-of-range value read back before the step refuses it, a step that allows FMU states."""
    u, w = m.inputs[0], m.inputs[-1]
    x0 = m.start(u)
    prog = INIT + _steps(0.0, 2) + [
        ("set", "Real", [u.valueReference, u.valueReference], [x0 + 1.0, x0]), ("get", "Real", [u.valueReference]),
        ("set", "Real", [], []), ("step", 2 * H, H, 0), ("set", "Real", [w.valueReference], [-1e30]),
        ("get", "Real", [w.valueReference, u.valueReference]), ("step", 3 * H, H), ("step", 3 * H, H),
        ("set", "Real", [w.valueReference], [m.start(w)]), ("step", 3 * H, H), ("all",)]
    same(m, prog, monkeypatch)


@pytest.mark.parametrize("seed", range(4))
def test_random_inputs_within_their_ranges(m, monkeypatch, seed):
    """Every input set each step to a value drawn across its range (tiny to its bounds, either sign):
    the native step, a step the compiled function declines, a refused input, all as the Python."""
    import random

    rnd = random.Random(seed)
    prog, t = list(INIT), 0.0
    for k in range(25):
        vrs, vals = [], []
        for v in m.inputs:
            lo = float(v.min) if v.min is not None else -1e6
            hi = float(v.max) if v.max is not None else 1e6
            x = rnd.choice([lo, hi, 0.0, rnd.uniform(lo, hi), rnd.uniform(lo, hi) * 10.0 ** -rnd.randint(0, 12),
                            m.start(v)])
            vrs.append(v.valueReference)
            vals.append(min(max(x, lo), hi))
        prog += [("set", "Real", vrs, vals), ("step", t, H)]
        t += H
    same(m, prog + [("all",)], monkeypatch)


# ------------------------------------------------------------------------------ logging
LOGS = {
    "off": [("log", False, [])],
    "off-on": [("log", False, []), ("log", True, [])],
    "on-with-categories": [("log", True, ["logAll"])],
    "off-with-categories": [("log", False, ["logAll"])],
    "unknown-category": [("log", True, ["noSuchCategory"])],
}


@pytest.mark.parametrize("logging", [True, False], ids=["logging-on", "logging-off"])
@pytest.mark.parametrize("case", list(LOGS))
@pytest.mark.parametrize("where", ["before-setup", "in-init", "stepping"])
def test_debug_logging(m, monkeypatch, case, logging, where):
    u = m.inputs[0]
    tail = _steps(0.0, 3) + [("set", "Real", [u.valueReference], [1e300]), ("step", 3 * H, H)]
    calls = LOGS[case]
    prog = {"before-setup": calls + INIT + tail,
            "in-init": INIT[:2] + calls + [("all",), ("exit",)] + tail,
            "stepping": INIT + calls + tail}[where]
    same(m, prog, monkeypatch, logging=logging)


def test_logging_off_at_instantiate_shows_fewer_messages(m, monkeypatch):
    """loggingOn = False: the start's fmi2OK messages are not shown (a check the comparison can fail)."""
    prog = INIT + _steps(0.0, 3)
    off = same(m, prog, monkeypatch, logging=False)[-1][1]
    on = trace(m, "auto", prog, monkeypatch)[-1][1]
    assert all(x[0] >= 1 for x in off)
    assert len(on) > len(off)


# ------------------------------------------------------------------------------ references and values
UNKNOWN = [99999, 2 ** 31 - 1, 2 ** 32 - 1]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("when", ["instantiated", "initializing", "stepping"])
def test_unknown_value_references(m, monkeypatch, kind, when):
    known = [v.valueReference for v in m.vars if v.type == kind][:1]
    other = [v.valueReference for v in m.vars if v.type != kind and v.valueReference not in
             {w.valueReference for w in m.vars if w.type == kind}][:1]
    acts = []
    for vr in UNKNOWN + other:
        acts += [("get", kind, [vr]), ("get", kind, known + [vr])]
    start = {"Real": 0.0, "Integer": 0, "Boolean": False, "String": ""}[kind]
    acts += [("set", kind, [UNKNOWN[0]], [start]), ("get", kind, [])]
    prog = {"instantiated": acts + INIT, "initializing": INIT[:2] + acts + [("exit",)],
            "stepping": INIT + _steps(0.0, 2) + acts}[when]
    same(m, prog + _steps(0.0 if when != "stepping" else 2 * H, 2), monkeypatch)


@pytest.mark.parametrize("kind", ["String", "Boolean", "Integer", "Real"])
@pytest.mark.parametrize("value", ["equal", "unequal", "invalid"])
@pytest.mark.parametrize("when", ["instantiated", "initializing", "stepping"])
def test_parameter_sets(m, monkeypatch, kind, value, when):
    """A parameter set to its start value (native), another valid one, an invalid one (the Python),
    before, in and after Initialization Mode (in it after a read that built the model)."""
    ps = m.params(kind)
    if not ps:
        pytest.skip(f"no {kind} parameter with a start value")
    p = ps[0]
    x = m.start(p)
    if value == "unequal":
        x = {"String": lambda: p.start + "x", "Boolean": lambda: not x, "Integer": lambda: x + 1,
             "Real": lambda: x + 1.0}[kind]()
    elif value == "invalid":
        x = {"String": "noSuchChoice", "Boolean": 7, "Integer": -2 ** 31, "Real": math.nan}[kind]
    s = ("set", kind, [p.valueReference], [x])
    prog = {"instantiated": [s] + INIT, "initializing": INIT[:2] + [("all",), s, ("all",), ("exit",)],
            "stepping": INIT + _steps(0.0, 2) + [s]}[when]
    same(m, prog + [("all",)] + _steps(0.0 if when != "stepping" else 2 * H, 3), monkeypatch)


def test_a_boolean_set_to_another_true(m, monkeypatch):
    """fmi2Boolean 7 where the start is true: the same truth, another number (native: unchanged)."""
    ps = [p for p in m.params("Boolean") if m.start(p)]
    if not ps:
        pytest.skip("no Boolean parameter starting true")
    vrs = [p.valueReference for p in ps]
    same(m, [("set", "Boolean", vrs, [7] * len(vrs)), ("get", "Boolean", vrs)] + INIT[:2]
         + [("set", "Boolean", vrs, [-1] * len(vrs)), ("all",), ("exit",), ("all",)] + _steps(0.0, 3), monkeypatch)


@pytest.mark.parametrize("kind", KINDS)
def test_a_read_of_no_variable_in_initialization_mode(m, monkeypatch, kind):
    """A read of none builds the model as any read does (its messages then, not at the exit)."""
    p = m.params("String")[0]
    same(m, INIT[:2] + [("get", kind, []), ("set", "String", [p.valueReference], ["noSuchChoice"]), ("all",),
                        ("exit",)] + _steps(0.0, 2), monkeypatch)


@pytest.mark.parametrize("when", ["instantiated", "stepping"])
def test_a_long_message_after_a_promotion(m, monkeypatch, when):
    """A long message (the refused value quoted in it, with a '%s'): as the Python start gives it, after
    the promotion relays the model's messages."""
    p = m.params("String")[0]
    s = ("set", "String", [p.valueReference], ["%s" + "x" * 40000])
    prog = [s] + INIT if when == "instantiated" else INIT + _steps(0.0, 2) + [("state",), s]
    native = same(m, prog, monkeypatch)
    if when == "instantiated":   # whole messages either way (fmu_src/native/fmi/log_text.h), past 16 kB
        assert max(len(x[1]) for x in native[-1][1]) > 16000, "the message quotes the value (else this proves little)"


STATUS_CALLS = [("status", "fmi2GetStatus", 0), ("status", "fmi2GetRealStatus", 2), ("status", "fmi2GetIntegerStatus", 0),
                ("status", "fmi2GetBooleanStatus", 3), ("status", "fmi2GetStringStatus", 1),
                ("status", "fmi2GetRealStatus", 99), ("other", "fmi2CancelStep"),
                ("other", "fmi2GetDirectionalDerivative"), ("other", "fmi2SetRealInputDerivatives"),
                ("other", "fmi2GetRealOutputDerivatives")]


@pytest.mark.parametrize("call", STATUS_CALLS, ids=lambda c: f"{c[1]}-{c[2]}" if len(c) > 2 else c[1])
@pytest.mark.parametrize("when", ["instantiated", "initializing", "stepping", "terminated"])
def test_the_calls_left_to_the_python(m, monkeypatch, call, when):
    prog = {"instantiated": [call] + INIT + _steps(0.0, 2),
            "initializing": INIT[:2] + [call, ("exit",)] + _steps(0.0, 2),
            "stepping": INIT + _steps(0.0, 2) + [call] + _steps(2 * H, 2),
            "terminated": INIT + _steps(0.0, 2) + [("terminate",), call, ("all",)]}[when]
    same(m, prog, monkeypatch)


@pytest.mark.parametrize("kind", KINDS)
def test_sets_and_reads_of_no_variable(m, monkeypatch, kind):
    """n = 0 (arrays given, or NULL) in every mode; in Initialization Mode between reads (a set of none
    may or may not make the model build again: as the Python does)."""
    g, z = [("get", kind, []), ("nullget", kind)], [("set", kind, [], []), ("nullset", kind)]
    prog = g + z + INIT[:2] + [("all",)] + z + [("all",)] + g + [("exit",)] + g + z + _steps(0.0, 2) + g + z
    same(m, prog + [("terminate",)] + g + z, monkeypatch)


def test_strings_of_parameters_in_every_mode(m, monkeypatch):
    vrs = [v.valueReference for v in m.vars if v.type == "String"]
    g = ("get", "String", vrs)
    same(m, [g, ("setup", 0.0, None), g, ("enter",), g, ("exit",), g] + _steps(0.0, 3)
         + [g, ("terminate",), g], monkeypatch)


@pytest.mark.parametrize("fmu_type", [0, 2, -1], ids=["model-exchange", "unknown-2", "unknown-negative"])
def test_an_instance_of_another_type_is_refused_alike(m, monkeypatch, fmu_type):
    """fmi2Instantiate asked for another FMU type than co-simulation: NULL and the same message."""
    from ctypes import byref

    from fmpy import calloc, free
    from fmpy.fmi2 import fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE, fmi2CallbackFunctions
    from pathlib import Path

    def run(mode):
        monkeypatch.setenv("SPURDIFF_FMU_START", mode)
        inst = Instance("ns", None, unzipdir=m.unzipdir, md=m.md, instantiate=False)
        cb = fmi2CallbackFunctions()
        cb.logger = _logger(inst.messages)
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        f = inst.slave.dll.fmi2Instantiate
        uri = Path(m.unzipdir, "resources").as_uri().encode()
        c = f(b"ns", fmu_type, m.md.guid.encode(), uri, byref(cb), 0, 1)
        if c:
            inst.slave.dll.fmi2FreeInstance(c)
        return bool(c), list(inst.messages)
    native = run("auto")
    assert native == run("python")
    assert not native[0] and native[1]


# ------------------------------------------------------------------------------ two instances
def test_two_instances_one_promoted_one_native(m, monkeypatch):
    """A and B at once; A is promoted (an FMU state) between B's native steps; both as with the Python."""
    def run(mode):
        a = _instance(m, mode, monkeypatch, name="a", env=0xA1)
        b = _instance(m, mode, monkeypatch, name="b", env=0xB2)
        out = []
        try:
            for inst in (a, b):
                out += [_do(inst, m, act) for act in INIT]
            for k in range(10):
                out.append(_do(a, m, ("step", k * H, H)))
                out.append(_do(b, m, ("step", k * H, H)))
                if k == 4:
                    out.append(_do(a, m, ("state",)))
                    out.append(_do(a, m, ("set", "Real", [m.inputs[0].valueReference], [math.nan])))
                    out.append(_do(b, m, ("set", "Real", [m.inputs[0].valueReference], [math.nan])))
            out += [_do(a, m, ("all",)), _do(b, m, ("all",))]
        finally:
            a.close()
            b.close()
        return out, list(a.messages), list(b.messages)
    native = run("auto")
    assert native == run("python")
    assert {x[4] for x in native[1]} == {0xA1} and {x[4] for x in native[2]} == {0xB2}, "each its own environment"


@pytest.mark.parametrize("name", ["a%sb%%c%n", "x" * 2000, "\u00e9t\u00e9 ns"], ids=["percent", "long", "utf8"])
def test_odd_instance_names_through_a_promotion(m, monkeypatch, name):
    """The instance name as the host gave it in every message, native or relayed after a promotion."""
    u = m.inputs[0].valueReference
    same(m, INIT[:2] + [("all",)] + INIT[2:] + _steps(0.0, 3) + [("set", "Real", [u], [math.inf]),
                                                               ("step", 3 * H, H), ("state",)],
         monkeypatch, name=name)


# ------------------------------------------------------------------------------ a long tape
def test_a_long_tape_replayed_at_an_fmu_state_call(differential_fmu, monkeypatch):
    m = Md(differential_fmu)
    u = m.inputs[2].valueReference
    prog = INIT + [("set", "Real", [u], [m.start(m.inputs[2]) * 0.9])] + _steps(0.0, 20000, 1e-4) + [
        ("state",), ("step", 2.0, 1e-4), ("all",)]
    native = same(m, prog, monkeypatch)
    assert native[-4] == ("state", (0, 0, 0))


OWN_PROCESS = {
    "nan-input": lambda m: INIT + _steps(0.0, 30) + [("set", "Real", [m.inputs[0].valueReference], [math.nan]),
                                                     ("step", 30 * H, H), ("state",), ("all",)],
    "state": lambda m: INIT + _steps(0.0, 30) + [("state",), ("step", 30 * H, H), ("all",)],
    "refused-set-after-a-read": lambda m: INIT[:2] + [("all",), ("set", "String", [m.params("String")[0].valueReference],
                                                                 ["noSuchChoice"]), ("all",), ("exit",)]
    + _steps(0.0, 2),
    "step-past-stop": lambda m: [("setup", 0.0, 0.01), ("enter",), ("exit",)] + _steps(0.0, 10) + [("step", 0.01, H)],
    "after-terminate": lambda m: INIT + _steps(0.0, 5) + [("terminate",), ("terminate",), ("all",), ("reset",)]
    + INIT + _steps(0.0, 3),
}


@pytest.mark.parametrize("case", list(OWN_PROCESS))
def test_a_promotion_in_the_model_s_own_process(m, monkeypatch, case):
    monkeypatch.setenv("SPURDIFF_FMU_PROCESS", "out")
    same(m, OWN_PROCESS[case](m), monkeypatch)
