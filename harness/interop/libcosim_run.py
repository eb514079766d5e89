"""Run an SSP file with DNV's libcosim (through libcosimpy) and record chosen variables.

libcosim loads the SSP itself (components, parameter bindings, connections, and the step from
the ``osp:FixedStepAlgorithm`` annotation) and steps it with its fixed-step algorithm, which is
Jacobi: every FMU steps with the inputs transferred at the end of the previous step. This module
only adds what an SSP cannot hold, read from the ``org.spurdiff.scene`` annotation that
:mod:`harness.interop.ssp` writes: the variables to record and the input tables, which it applies with
libcosim's override manipulator before each step (zero-order hold at the communication points,
as our master does).

:func:`run_ssp` returns a :class:`harness.run.result.Result` (``result["inst.var"]`` arrays, ``.time``,
``.step``) as our master does. By default libcosim runs in a child process
(``python -m harness.cli.tools.libcosim_run``): pythonfmu FMUs share one interpreter per process, and a
crash inside libcosim or an FMU then cannot take the caller down.

After the run, every start value the SSP binds is read back through a libcosim observer and
compared with the SSP: libcosim only logs a warning when it cannot apply a binding, so a binding
that did not arrive is reported here as a failure.
"""
from __future__ import annotations

import ctypes
import os
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from harness.run.result import Result
from harness.scene.spec import Profile

SSD_FILE = "SystemStructure.ssd"
NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
    "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations",
    "sd": "urn:spurdiff:ssp-scene:1",
}
NANO = 1_000_000_000  # libcosim's time unit is the nanosecond


class LibcosimError(RuntimeError):
    """The SSP could not be loaded or set up in libcosim (one line naming the cause)."""


@dataclass
class SspFacts:
    """What the runner needs from an SSP file's SystemStructure.ssd."""

    name: str
    stop_time: float | None
    step: float | None                                  # osp:FixedStepAlgorithm baseStepSize
    record: list[str]                                   # from the org.spurdiff.scene annotation
    tables: dict[str, Profile]                          # "element.connector" -> table profile
    bindings: dict[str, dict[str, tuple[str, str]]]     # element -> {variable: (ssv type, text)}
    algorithm: str | None = None                        # the scene's own algorithm (information)


# ---------------------------------------------------------------------------- reading the SSP
def _parameter_set(pset) -> dict[str, tuple[str, str]]:
    out = {}
    for p in pset.findall("ssv:Parameters/ssv:Parameter", NS):
        value = p[0]
        out[p.get("name")] = (value.tag.split("}")[-1], value.get("value"))
    return out


def read_facts(ssp_path: Path | str) -> SspFacts:
    """Step, stop time, recording list, input tables and bound start values of an SSP file."""
    from lxml import etree as ET

    ssp_path = Path(ssp_path)
    try:
        with zipfile.ZipFile(ssp_path) as z:
            root = ET.fromstring(z.read(SSD_FILE))
            bindings: dict[str, dict[str, tuple[str, str]]] = {}
            for comp in root.iterfind("ssd:System/ssd:Elements/ssd:Component", NS):
                vals: dict[str, tuple[str, str]] = {}
                for pb in comp.iterfind("ssd:ParameterBindings/ssd:ParameterBinding", NS):
                    src = pb.get("source")
                    pset = (ET.fromstring(z.read(src)) if src
                            else pb.find("ssd:ParameterValues/ssv:ParameterSet", NS))
                    if pset is not None:
                        vals.update(_parameter_set(pset))
                bindings[comp.get("name")] = vals
    except FileNotFoundError:
        raise LibcosimError(f"{ssp_path}: no such SSP file") from None
    except (zipfile.BadZipFile, KeyError) as e:
        raise LibcosimError(f"{ssp_path}: not an SSP archive with {SSD_FILE} ({e})") from None
    exp = root.find("ssd:DefaultExperiment", NS)
    stop = float(exp.get("stopTime")) if exp is not None and exp.get("stopTime") else None
    fixed = root.find("ssd:DefaultExperiment/ssd:Annotations/ssc:Annotation/osp:Algorithm/osp:FixedStepAlgorithm", NS)
    step = float(fixed.get("baseStepSize")) if fixed is not None else None
    scene = root.find("ssd:System/ssd:Annotations/ssc:Annotation/sd:Scene", NS)
    record, tables, algorithm = [], {}, None
    if scene is not None:
        algorithm = scene.get("algorithm")
        record = [r.get("variable") for r in scene.iterfind("sd:Record", NS)]
        for tab in scene.iterfind("sd:InputTable", NS):
            pts = [(float(p.get("time")), float(p.get("value"))) for p in tab.iterfind("sd:Point", NS)]
            tables[f"{tab.get('element')}.{tab.get('connector')}"] = Profile(
                "table", times=tuple(t for t, _ in pts), values=tuple(v for _, v in pts))
    return SspFacts(root.get("name", ssp_path.stem), stop, step, record, tables, bindings, algorithm)


# ---------------------------------------------------------------------------- running here
def _nanoseconds(label: str, seconds: float) -> int:
    x = seconds * NANO
    ns = int(round(x))
    if ns <= 0 or abs(ns - x) > 1e-9 * x:
        raise LibcosimError(f"{label} = {seconds!r} s is not a positive whole number of nanoseconds (libcosim's time unit)")
    return ns


def _samples_function(kind: str):
    """libcosimc's sample getter, called directly: libcosimpy's wrapper drops samples whose step
    number is 0 when it trims its arrays, and the t = 0 sample has step number 0."""
    from libcosimpy._internal import libcosimc, wrap_function

    c_type = {"real": ctypes.c_double, "integer": ctypes.c_int}[kind]
    return c_type, wrap_function(
        lib=libcosimc(), funcname=f"cosim_observer_slave_get_{kind}_samples",
        argtypes=[ctypes.c_void_p, ctypes.c_int, ctypes.c_uint32, ctypes.c_int64, ctypes.c_size_t,
                  ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p],
        restype=ctypes.c_int64)


def _read_samples(observer, slave: int, ref: int, kind: str, n: int):
    c_type, get = _samples_function(kind)
    values, steps, times = (c_type * n)(), (ctypes.c_int64 * n)(), (ctypes.c_int64 * n)()
    count = get(ctypes.cast(observer.ptr(), ctypes.c_void_p), slave, ref, 0, n, values, steps, times)
    if count < 0:
        from libcosimpy._internal import get_last_error_message
        raise LibcosimError(f"libcosim observer: {get_last_error_message()}")
    return np.array(times[:count], dtype=np.int64), np.array(values[:count], dtype=float)


def _check_bindings(observer, facts: SspFacts, slaves: dict, variables: dict) -> list[str]:
    """Start values the SSP binds that libcosim did not deliver to the FMU, read back through
    a last-value ``observer``."""
    problems = []
    for element, vals in facts.bindings.items():
        idx = slaves[element]
        for name, (ptype, text) in vals.items():
            if f"{element}.{name}" in facts.tables:
                continue  # overridden by the table during the run
            v = variables[element].get(name)
            if v is None:
                problems.append(f"{element}.{name}: bound in the SSP but not a variable of the FMU")
                continue
            if ptype == "Real":
                got, want = observer.last_real_values(idx, [v.reference])[0], float(text)
            elif ptype == "Integer":
                got, want = observer.last_integer_values(idx, [v.reference])[0], int(text)
            elif ptype == "Boolean":
                got, want = bool(observer.last_boolean_values(idx, [v.reference])[0]), text == "true"
            else:
                got, want = observer.last_string_values(idx, [v.reference])[0].decode(), text
            if got != want:
                problems.append(f"{element}.{name}: the SSP binds {text!r}, the FMU has {got!r}")
    return problems


def run_here(ssp_path: Path | str, record: list[str] | None = None, step: float | None = None,
             duration: float | None = None) -> Result:
    """Run in this process (see :func:`run_ssp` for the arguments)."""
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy._internal import get_last_error_message

    ssp_path = Path(ssp_path).resolve()
    facts = read_facts(ssp_path)
    record = list(record if record is not None else facts.record)
    if not record:
        raise LibcosimError(f"{ssp_path.name}: nothing to record (pass variables, or export the SSP from a scene)")
    h = step if step is not None else facts.step
    if h is None:
        raise LibcosimError(f"{ssp_path.name}: no osp:FixedStepAlgorithm step in the SSP; pass a step")
    stop = duration if duration is not None else facts.stop_time
    if stop is None:
        raise LibcosimError(f"{ssp_path.name}: no DefaultExperiment stopTime in the SSP; pass a duration")
    h_ns, stop_ns = _nanoseconds("step", h), _nanoseconds("duration", stop)
    n_steps = int(round(stop_ns / h_ns))
    if n_steps * h_ns != stop_ns:
        raise LibcosimError(f"duration {stop} s is not a whole number of steps of {h} s")

    log_output_level(CosimLogLevel.WARNING)
    try:  # without a step, libcosim takes the algorithm and step from the SSP's annotation
        execution = (CosimExecution.from_ssp_file(str(ssp_path)) if step is None
                     else CosimExecution.from_ssp_file(str(ssp_path), step_size=h_ns))
    except AssertionError:
        raise LibcosimError(f"libcosim cannot load {ssp_path.name}: {get_last_error_message()}") from None
    slaves = {info.name.decode(): info.index for info in execution.slave_infos()}
    variables = {name: {v.name.decode(): v for v in execution.slave_variables(idx)} for name, idx in slaves.items()}

    def lookup(ref: str):
        inst, _, var = ref.partition(".")
        if inst not in slaves:
            raise LibcosimError(f"{ref!r}: no component {inst!r} in the SSP; have: {', '.join(sorted(slaves))}")
        if var not in variables[inst]:
            raise LibcosimError(f"{ref!r}: component {inst!r} has no variable {var!r}")
        return slaves[inst], variables[inst][var]

    series = CosimObserver.create_time_series(buffer_size=n_steps + 1)
    execution.add_observer(series)
    last = CosimObserver.create_last_value()
    execution.add_observer(last)
    kinds = {CosimVariableType.REAL.value: "real", CosimVariableType.INTEGER.value: "integer"}
    recorded = []
    for ref in record:
        idx, v = lookup(ref)
        if v.type not in kinds:
            raise LibcosimError(f"{ref!r}: libcosim records only Real and Integer variables over time")
        series.start_time_series(idx, v.reference, CosimVariableType(v.type))
        recorded.append((idx, v.reference, kinds[v.type]))
    tables = [(lookup(ref), prof) for ref, prof in facts.tables.items()]
    override = None
    if tables:
        override = CosimManipulator.create_override()
        execution.add_manipulator(override)

    failure = None
    done = 0
    if not tables:
        if not execution.step(n_steps):
            failure = get_last_error_message()
        done = n_steps
    else:
        for k in range(n_steps):
            t = k * h_ns / NANO
            for (idx, v), prof in tables:
                override.slave_real_values(idx, [v.reference], [prof(t)])
            if not execution.step(1):
                failure = get_last_error_message()
                break
            done = k + 1
    now = execution.status().current_time
    if failure is not None:
        failure = f"libcosim step failed at t = {now / NANO:.6g} s: {failure}"

    columns, times = [], None
    for (idx, ref, kind), name in zip(recorded, record):
        t_ns, vals = _read_samples(series, idx, ref, kind, n_steps + 1)
        if times is None:
            times = t_ns
        elif len(t_ns) != len(times) or np.any(t_ns != times):
            raise LibcosimError(f"{name!r}: libcosim returned samples at other times than for {record[0]!r}")
        columns.append(vals)
    data = np.column_stack([times / NANO] + columns) if times is not None and len(times) else np.zeros((0, 1 + len(record)))
    if failure is None and len(data) != done + 1:
        failure = f"libcosim recorded {len(data)} samples for {done} steps"
    if failure is None:
        problems = _check_bindings(last, facts, slaves, variables)
        if problems:
            failure = f"{len(problems)} start value(s) did not reach the FMUs: {problems[0]}"
    return Result(None, record, data, failure=failure, step=h)


# ---------------------------------------------------------------------------- child process
def run_ssp(ssp_path: Path | str, record: list[str] | None = None, step: float | None = None,
            duration: float | None = None, isolate: bool = True, timeout: float | None = None) -> Result:
    """Run an SSP file with libcosim's fixed-step (Jacobi) algorithm and record variables.

    ``record``: "component.variable" names (default: the scene's recording list in the SSP).
    ``step``/``duration``: override the SSP's step annotation and stop time (seconds).
    ``isolate``: run libcosim in a child process (default) rather than in this one.
    A failed step gives a result with ``failure`` set and the samples recorded so far; a file or
    setup problem raises :class:`LibcosimError`.
    """
    if not isolate:
        return run_here(ssp_path, record, step, duration)
    with tempfile.TemporaryDirectory(prefix="spurdiff_libcosim_") as tmp:
        out = Path(tmp) / "result.npz"
        cmd = [sys.executable, "-m", "harness.cli.tools.libcosim_run", str(Path(ssp_path).resolve()), "--out", str(out)]
        if record is not None:
            cmd += ["--record", *record] if record else []
        if step is not None:
            cmd += ["--step", repr(step)]
        if duration is not None:
            cmd += ["--duration", repr(duration)]
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                                  env={**os.environ, "PYTHONUNBUFFERED": "1"})
        except subprocess.TimeoutExpired:
            raise LibcosimError(f"libcosim run of {Path(ssp_path).name} took longer than {timeout} s") from None
        lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
        if proc.returncode not in (0, 1) or not out.exists():
            how = f"signal {-proc.returncode}" if proc.returncode < 0 else f"status {proc.returncode}"
            raise LibcosimError(f"libcosim run of {Path(ssp_path).name} ended with {how}: "
                                f"{lines[-1] if lines else 'no message'}")
        z = np.load(out, allow_pickle=False)
        failure = str(z["failure"]) or None
        return Result(None, [str(n) for n in z["names"]], z["data"], failure=failure, messages=lines, step=float(z["step"]))
