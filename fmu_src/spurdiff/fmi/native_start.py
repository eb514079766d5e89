"""The native start: what the FMU's binary needs to run an instance without starting Python while its
host keeps the FMU's defaults (``fmu_src/native/fmi/native_start.c`` reads it).

An FMU whose model steps natively at its defaults (:mod:`spurdiff.native_step`; the differential's
default interface) carries ``resources/native_start.bin``, written at build time by :func:`snapshot`
from this package's own adapter run as the bridge runs it: every variable's value as a host reads it
after fmi2Instantiate, in Initialization Mode and after it; the messages each call logs; the native
step's function, its context's arrays and the array ``v`` after fmi2ExitInitializationMode; which
value references read and write which slot of ``v``, each input's accepted range.

The binary then answers fmi2Instantiate without Python and keeps every call it took before the first
step on a tape. As long as the host only does what the snapshot answers (sets a variable to the value
it already has, sets the inputs and steps, reads any variable, terminates), the instance runs the
compiled step, bit for bit what the Python instance computes (the same function on the same arrays).
Anything else (a parameter set to another value, a refused input, a step a watch would log, an FMU
state, ...) starts Python as before, replays the tape through the bridge, checking that every replayed
call answers as it did, hands the model the native step's arrays, time and step count as they are
then (the bridge's ``fmi2_native_export`` then ``fmi2_native_import``, as for a model in its own
process: :func:`live`, :func:`restore`), checks that the outputs equal the native ones, then passes
the call on.

The file is data, little-endian, made of: u32 numbers, f64 numbers, strings (u32 length, UTF-8 bytes),
ending with the FNV-1a 64-bit digest of all the bytes before it (:func:`digest`): a file changed in any
byte (a value as much as a count) is refused as damaged, never run.
Nothing of the build machine is in it (the kernels are named relative to the resources folder, the
snapshot is refused when a value or message would carry the instance name or the resources path).
"""
from __future__ import annotations

import ctypes
import math
import os
import struct
import sys

MAGIC = b"SPNS"
LIVE_MAGIC = b"SPNL"     # a hand-over of a stepping instance (live)
FORMAT = 3
FILE = "native_start.bin"
MAX_VR = 1 << 20       # native_start.c: NS_MAX_VR (a table indexed by value reference)
KINDS = ("Real", "Integer", "Boolean", "String")
# the variable flags
SETTABLE, INPUT, CONSTANT = 1, 2, 4
# the context fields
NULL, DOUBLES, FUNCTION = 0, 1, 2
# the phases of the recorded messages: fmi2Instantiate, fmi2SetupExperiment, fmi2EnterInitializationMode,
# the model's build (at the first read in Initialization Mode, else in fmi2ExitInitializationMode)
PHASES = ("instantiate", "setup", "enter", "build")

_PROBE_NAME = "spurdiff-native-start-probe-3f9c"
_PROBE_RESOURCES = "/nonexistent/spurdiff-native-start-probe-3f9c/resources"


class NoSnapshot(Exception):
    """This FMU cannot start natively (the reason)."""


class _Writer:
    def __init__(self):
        self.parts: list[bytes] = []

    def u32(self, x: int) -> None:
        self.parts.append(struct.pack("<I", x))

    def i64(self, x: int) -> None:
        self.parts.append(struct.pack("<q", x))

    def f64s(self, xs) -> None:
        xs = [float(x) for x in xs]
        self.parts.append(struct.pack(f"<{len(xs)}d", *xs))

    def text(self, s: str) -> None:
        b = s.encode("utf-8")
        if b"\0" in b:
            raise NoSnapshot("a string with a NUL character")
        self.u32(len(b))
        self.parts.append(b)

    def bytes(self) -> bytes:
        return b"".join(self.parts)


def digest(data: bytes) -> int:
    """FNV-1a, 64 bits (native_start.c: fnv1a)."""
    h = 0xCBF29CE484222325
    for b in data:
        h = ((h ^ b) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return h


def _drain(slave) -> list[tuple[int, str, str]]:
    out = [(int(m.status), str(m.category), str(m.msg)) for m in slave.log_queue]
    slave.log_queue.clear()
    return out


def _values(slave, kind: str, vrs: tuple) -> list:
    return list(getattr(slave, f"fmi2_get_{kind.lower()}")(vrs)) if vrs else []


def _library(module) -> tuple[str, list[tuple[str, int]]]:
    """A kernel's binding module: its shipped library relative to the resources folder (no suffix:
    the binary adds .so or .dll) and its checks (function, value)."""
    # the package's folder, whatever name it was imported by (the bridge imports it by a private alias)
    parts = module.__name__.split(".")
    top = os.path.basename(os.path.dirname(sys.modules[parts[0]].__file__))
    rel = "/".join([top] + parts[1:-1] + [module.LIB_NAME.rsplit(".", 1)[0]])
    checks = [(n, int(w)) for c in module._BINDING.checks for n, w in zip(c.names, c.want)]
    return rel, checks


def snapshot(klass, sets=()) -> bytes:
    """The native start of the FMU class ``klass`` (a :func:`spurdiff.fmi.adapter.fmu_class`) at its
    defaults, or with the values ``sets`` set after fmi2Instantiate (kind, value reference, value; the
    start cache, :func:`decode_sets`), or NoSnapshot saying why it has none."""
    def make():
        x = klass(instance_name=_PROBE_NAME, resources=_PROBE_RESOURCES, visible=False, logging_on=True)
        first = _drain(x)
        for kind, vr, value in sets:
            if getattr(x, f"fmi2_set_{kind.lower()}")((vr,), (value,)) != 0 or _drain(x):
                raise NoSnapshot(f"setting the {kind} variable {vr} to {value!r} did not answer fmi2OK silently")
        return x, first

    a, first = make()
    msgs = {p: [] for p in PHASES}
    msgs["instantiate"] = first
    vrs = {k: tuple(sorted(a._get[k])) for k in KINDS}
    phase0 = {k: _values(a, k, vrs[k]) for k in KINDS}
    statuses = [a.fmi2_setup_experiment(False, 0.0, 0.0, False, 0.0)]
    msgs["setup"] = _drain(a)
    statuses.append(a.fmi2_enter_initialization_mode())
    msgs["enter"] = _drain(a)
    statuses.append(a.fmi2_exit_initialization_mode())
    msgs["build"] = _drain(a)
    phase2 = {k: _values(a, k, vrs[k]) for k in KINDS}
    if _drain(a):
        raise NoSnapshot("reading the variables after initialization logs")
    # the same start with a read in Initialization Mode: the build's messages move to that read
    b, _ = make()
    b.fmi2_setup_experiment(False, 0.0, 0.0, False, 0.0)
    b.fmi2_enter_initialization_mode()
    _drain(b)
    phase1 = {k: _values(b, k, vrs[k]) for k in KINDS}
    if _drain(b) != msgs["build"]:
        raise NoSnapshot("the model's build logs differently when read in Initialization Mode")
    if b.fmi2_exit_initialization_mode() != statuses[2] or _drain(b):
        raise NoSnapshot("fmi2ExitInitializationMode logs after a read in Initialization Mode")
    if any(statuses):
        raise NoSnapshot(f"the start's statuses are {statuses}, not fmi2OK")

    # the inputs' start values checked as fmi2DoStep checks them (its first step then runs natively)
    for name, lo, hi in a._inputs:
        if not lo <= a.values[name] <= hi:
            raise NoSnapshot(f"the input {name}'s start value is outside [{lo}, {hi}]")
    a._inputs_ok = True
    answer = a.fmi2_native_enter()
    if not isinstance(answer, tuple):
        raise NoSnapshot("the model has no native step at its defaults")
    w = _Writer()
    w.parts.append(MAGIC)
    w.u32(FORMAT)
    _write_model(w, a, answer, vrs, lambda kind, i: [phase0[kind][i], phase1[kind][i], phase2[kind][i]], msgs)
    body = w.bytes()
    return body + struct.pack("<Q", digest(body))


def decode_sets(data: bytes) -> list:
    """The values set as the loader sends them for the start cache (``fmu_src/native/fmi/native_start.c``:
    pack_overrides): [(kind, value reference, value)], each u32 kind, u32 value reference, then a double
    (Real, Integer, Boolean) or a String's u32 length and UTF-8 bytes; ValueError for anything else."""
    out, at = [], 0
    while at < len(data):
        if at + 8 > len(data):
            raise ValueError("the values set end inside a record")
        k, vr = struct.unpack_from("=II", data, at)
        at += 8
        if k >= len(KINDS):
            raise ValueError(f"the values set name the kind {k}")
        kind = KINDS[k]
        if kind == "String":
            (n,) = struct.unpack_from("=I", data, at)
            if at + 4 + n > len(data):
                raise ValueError("the values set end inside a string")
            value = data[at + 4:at + 4 + n].decode("utf-8")
            at += 4 + n
        else:
            if at + 8 > len(data):
                raise ValueError("the values set end inside a number")
            (x,) = struct.unpack_from("=d", data, at)
            at += 8
            value = x if kind == "Real" else bool(x) if kind == "Boolean" else int(x)
        out.append((kind, vr, value))
    return out


def live(slave) -> bytes | bool | None:
    """The hand-over of a stepping instance ``slave`` to the host's process (the loader's answer to a
    model in its own process, ``fmu_src/native/fmi/fmi2_loader.c``): the native start's layout with the
    magic ``SPNL``, the FMU's time, stop time and its tolerance after the format, no digest at the end,
    the arrays as they are now (``v`` and every array of the context) and each constant variable's value
    (the three values alike; messages none). The state is then in the arrays (``fmi2_native_enter``),
    until :func:`restore` takes it back. False: this instance cannot be handed over (no native step, or
    one the layout cannot describe); None: not now (as ``fmi2_native_enter``)."""
    vrs = {k: tuple(sorted(slave._get[k])) for k in KINDS}
    by_name = {v.name: v for v in type(slave).VARIABLES}
    const = {k: [vr for vr in vrs[k] if _constant(by_name[slave._get[k][vr]])] for k in KINDS}
    now = {k: dict(zip(const[k], _values(slave, k, tuple(const[k])))) for k in KINDS}
    answer = slave.fmi2_native_enter()
    if not isinstance(answer, tuple):
        return answer if answer is None else False
    blank = {"String": ""}

    def values(kind, i):
        x = now[kind].get(vrs[kind][i], blank.get(kind, 0.0))
        return [x, x, x]

    w = _Writer()
    w.parts.append(LIVE_MAGIC)
    w.u32(FORMAT)
    w.f64s(answer[:3])
    try:
        _write_model(w, slave, answer, vrs, values, {p: [] for p in PHASES})
    except NoSnapshot:
        return False
    # no digest (8 zero bytes): the bytes go from this process to the host's through their shared memory
    # at once, never through a file (a digest here took as long as the rest of the hand-over)
    return w.bytes() + bytes(8)


def restore(slave, data: bytes) -> None:
    """The arrays of a hand-over back from the host (``v`` then each array of the context, in the
    layout's order, as doubles in the host's byte order) into the plan :func:`live` described; the
    caller then takes the state into the model (``fmi2_native_leave``)."""
    _, plan = slave._native_key
    arrays = [plan.v] + [f[1] for f in plan.layout()[1] if f[0] == DOUBLES]
    need = 8 * sum(len(x) for x in arrays)
    if len(data) != need:
        raise ValueError(f"the hand-over brings back {len(data)} bytes; the plan's arrays take {need}")
    at = 0
    for x in arrays:
        n = 8 * len(x)
        ctypes.memmove(x, data[at:at + n], n)
        at += n


def _constant(var) -> bool:
    return var.causality in ("parameter", "calculatedParameter") or var.fmi_variability == "constant"


def _write_model(w: _Writer, a, answer: tuple, vrs: dict, values, msgs: dict) -> None:
    """The part after the header: the step function, its context, ``v``, the variables (each one's
    three values by ``values(kind, i)``) and the messages; NoSnapshot when the plan does not fit."""
    klass = type(a)
    model, plan = a._native_key
    layout = getattr(plan, "layout", None)
    if layout is None:
        raise NoSnapshot(f"{type(plan).__name__} does not describe its context")
    (fn_module, fn_name), fields, direct = layout()
    if direct and (len(fields) != 1 or fields[0][0] != DOUBLES):
        raise NoSnapshot("a context given as itself must be one array of doubles")
    _, _, _, native, _ = answer
    _, _, _, slots, n_in, params, ints, early = native

    libs: list = []

    def lib_index(module) -> int:
        if module not in libs:
            libs.append(module)
        return libs.index(module)

    fn_lib = lib_index(fn_module)
    for f in fields:
        if f[0] == FUNCTION:
            lib_index(f[1])

    w.u32(1 if early else 0)
    w.u32(len(libs))
    checks = []
    for i, m in enumerate(libs):
        rel, cs = _library(m)
        w.text(rel)
        checks += [(i, n, x) for n, x in cs]
    w.u32(len(checks))
    for i, n, x in checks:
        w.u32(i)
        w.text(n)
        w.i64(x)
    w.u32(fn_lib)
    w.text(fn_name)
    w.u32(1 if direct else 0)
    w.u32(len(fields))
    for f in fields:
        w.u32(f[0])
        if f[0] == DOUBLES:
            w.u32(len(f[1]))
            w.f64s(f[1])
        elif f[0] == FUNCTION:
            w.u32(lib_index(f[1]))
            w.text(f[2])
    w.u32(len(plan.v))
    w.f64s(plan.v)
    w.u32(n_in)

    slot_of = {name: j for j, name in enumerate(slots) if name is not None}
    int_slot = dict(zip(ints[0::2], ints[1::2]))
    by_name = {v.name: v for v in klass.VARIABLES}
    inputs = {n: (lo, hi) for n, lo, hi in a._inputs}
    rows = []
    for kind in KINDS:
        for i, vr in enumerate(vrs[kind]):
            name = a._get[kind][vr]
            var = by_name[name]
            flags = (SETTABLE if vr in a._set[kind] else 0) | (INPUT if var.causality == "input" else 0)
            if _constant(var):
                flags |= CONSTANT
            slot = -1
            if kind == "Real" and name in slot_of and (var.causality != "input" or slot_of[name] < n_in):
                slot = slot_of[name]
            elif kind == "Integer" and vr in int_slot:
                slot = int_slot[vr]
            if kind == "Real" and var.causality == "input" and not 0 <= slot < n_in:
                raise NoSnapshot(f"the input {name} has no slot in the native step's array")
            if kind == "Real" and flags & CONSTANT and name not in params:
                raise NoSnapshot(f"the parameter {name} is not among the native step's parameters")
            if vr >= MAX_VR:
                raise NoSnapshot(f"the value reference {vr} of {name} is not below {MAX_VR}")
            lo, hi = inputs.get(name, (-math.inf, math.inf))
            rows.append((KINDS.index(kind), vr, flags, slot, lo, hi, values(kind, i)))
    w.u32(len(rows))
    for k, vr, flags, slot, lo, hi, vals in rows:
        w.u32(k)
        w.u32(vr)
        w.u32(flags)
        w.u32(slot & 0xFFFFFFFF)
        w.f64s((lo, hi))
        for x in vals:
            if k == 3:
                _clean(str(x), "the value of a String variable")
                w.text(str(x))
            else:
                w.f64s((float(int(x)) if k else float(x),))
    all_msgs = [(i, m) for i, p in enumerate(PHASES) for m in msgs[p]]
    w.u32(len(all_msgs))
    for i, (status, category, text) in all_msgs:
        _clean(text, "a message")
        w.u32(i)
        w.u32(status)
        w.text(category)
        w.text(text)


def _clean(s: str, what: str) -> None:
    if _PROBE_NAME in s or _PROBE_RESOURCES in s:
        raise NoSnapshot(f"{what} names the instance or its resources folder: {s[:200]!r}")


__all__ = ["snapshot", "decode_sets", "live", "restore", "digest", "NoSnapshot", "FILE", "MAGIC", "LIVE_MAGIC", "FORMAT"]
