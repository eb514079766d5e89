"""Lifecycle checks of an FMI 2.0 co-simulation FMU, each run in a fresh process.

Every check loads the FMU's binary in a new Python process (``subprocess`` running
:func:`worker_main`), so an FMU that segfaults, calls ``exit`` or hangs cannot take the checker
down: a crash or a timeout is a FAIL naming the FMI call that was running (the worker writes the
call it is about to make to a trace file before making it).

The FMU is driven with fmpy's low-level API (:class:`fmpy.fmi2.FMU2Slave`): start values of
every non-constant parameter and input from the model description are set after
``fmi2Instantiate``; ``fmi2SetupExperiment`` gets the DefaultExperiment start time (else 0 s, no
tolerance, no stop time); the communication step is the DefaultExperiment ``stepSize`` (else
1e-3 s); before every ``fmi2DoStep`` the inputs are set again (to their start values unless a
check says otherwise), and after it every Real, Integer, Enumeration and Boolean output is read.

Checks (ids and rules; see docs/compliance.md):

``lifecycle.basic``
    instantiate, setupExperiment, enter/exit initialization, ``steps`` doSteps, terminate,
    freeInstance all return fmi2OK or fmi2Warning. When it fails, the other lifecycle checks are
    SKIPped (they would all fail for the same reason).
``lifecycle.reset``
    after ``fmi2Reset`` the same start values, initialization and steps give the same outputs.
``lifecycle.two-instances``
    two instances alive at once, the second with different inputs (or, without inputs, one
    different parameter), stepped alternately, give exactly the outputs each gives alone.
    SKIP when canBeInstantiatedOnlyOncePerProcess or when no variation changes any output.
``lifecycle.get-set-state``
    (canGetAndSetFMUstate) after ``fmi2SetFMUstate`` back to a saved state, the next steps
    repeat the outputs of the first continuation.
``lifecycle.serialize-state``
    (canSerializeFMUstate) a state serialized to bytes, deserialized and set into a fresh
    instance continues exactly as the original did.
``lifecycle.variable-step``
    (canHandleVariableCommunicationStepSize) steps of 1, 0.5, 2, 0.25, 1.5, 3, 0.75, 1 times the
    step size are accepted and do not turn finite Real outputs into NaN/Inf.
``lifecycle.step-before-init``
    ``fmi2DoStep`` after setupExperiment but before initialization is refused.
``lifecycle.parameter-after-init``
    setting a parameter with variability "fixed" after initialization is refused.
``lifecycle.zero-step-size`` / ``lifecycle.negative-step-size``
    ``fmi2DoStep`` with a communication step of 0 / of minus the step size is refused.
``lifecycle.nan-inputs``
    NaN written to every Real input is either refused (setReal or doStep returns
    fmi2Discard/Error/Fatal) or shows as NaN/Inf in a Real output within three steps; finite
    outputs that silently ignore the NaN are a FAIL.

"Refused" means a status above fmi2Warning: fmi2Discard, fmi2Error or fmi2Fatal (fmpy raises
:class:`fmpy.fmi1.FMICallException` for those). After a refusal the worker makes no further call
on the instance (after fmi2Fatal none is allowed) and exits. Outputs are "the same" when
``numpy.isclose(a, b, rtol=1e-9, atol=1e-12, equal_nan=True)`` holds for every sample: only
rounding-level differences are tolerated.
"""
from __future__ import annotations

import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

from .report import FAIL, PASS, SKIP, CheckResult

LIFECYCLE_CHECKS: tuple[str, ...] = (
    "lifecycle.basic",
    "lifecycle.reset",
    "lifecycle.two-instances",
    "lifecycle.get-set-state",
    "lifecycle.serialize-state",
    "lifecycle.variable-step",
    "lifecycle.step-before-init",
    "lifecycle.parameter-after-init",
    "lifecycle.zero-step-size",
    "lifecycle.negative-step-size",
    "lifecycle.nan-inputs",
)

DEFAULT_STEP_SIZE = 1e-3          # s, when the FMU has no DefaultExperiment stepSize
SAME_RTOL, SAME_ATOL = 1e-9, 1e-12  # "same outputs": rounding-level differences only
VARIABLE_STEP_FACTORS = (1.0, 0.5, 2.0, 0.25, 1.5, 3.0, 0.75, 1.0)
NAN_STEPS = 3
STATUS_LABELS = ("fmi2OK", "fmi2Warning", "fmi2Discard", "fmi2Error", "fmi2Fatal", "fmi2Pending")
REFUSED = (2, 3, 4)  # discard, error, fatal

_PACKAGE_ROOT = Path(__file__).resolve().parents[2]  # the directory holding the ``harness`` package


@dataclass
class LifecycleOptions:
    """How the lifecycle checks are run.

    ``steps``: doSteps per run (a few: these checks test the interface, not the model);
    ``timeout``: wall-clock limit per check process, s; ``jobs``: check processes at once.
    """

    steps: int = 10
    timeout: float = 60.0
    jobs: int = max(1, os.cpu_count() or 1)


# ============================================================================ parent side

def status_label(status: int | None) -> str:
    if status is None:
        return "no status"
    return STATUS_LABELS[status] if 0 <= status < len(STATUS_LABELS) else f"illegal status {status}"


def _last_line(path: Path) -> str:
    try:
        lines = [ln for ln in path.read_text(errors="replace").splitlines() if ln.strip()]
    except OSError:
        return ""
    return lines[-1] if lines else ""


def _tail(text: bytes, n: int = 2) -> str:
    lines = [ln.strip() for ln in text.decode(errors="replace").splitlines() if ln.strip()]
    return " / ".join(lines[-n:])


def run_isolated(task: str, payload: dict, timeout: float) -> tuple[str, str]:
    """Run ``task`` (a lifecycle check id, or "reference") in a fresh Python process.

    Returns (status, reason). A signal (segfault), a non-zero exit without a result, or the
    timeout gives FAIL with the FMI call that was running.
    """
    work = Path(tempfile.mkdtemp(prefix="spurdiff-check-"))
    trace, result = work / "trace.txt", work / "result.json"
    cmd = [sys.executable, "-c",
           "import sys; sys.path.insert(0, sys.argv[1]); "
           "from harness.check.lifecycle import worker_main; worker_main(sys.argv[2:])",
           str(_PACKAGE_ROOT), task, json.dumps(payload), str(trace), str(result)]
    try:
        proc = subprocess.Popen(cmd, cwd=work, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, start_new_session=True)
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            try:
                os.killpg(proc.pid, signal.SIGKILL)  # the worker's own process group (POSIX)
            except (AttributeError, ProcessLookupError, PermissionError):
                proc.kill()
            proc.communicate()
            where = _last_line(trace)
            return FAIL, f"timed out after {timeout:g} s" + (f" in {where}" if where else "")
        rc = proc.returncode
        data = None
        if result.exists():
            try:
                data = json.loads(result.read_text())
            except ValueError:
                data = None
        if rc < 0:
            try:
                sig = signal.Signals(-rc).name
            except ValueError:
                sig = f"signal {-rc}"
            where = _last_line(trace)
            if data is not None:
                return FAIL, f"{data['status']} ({data['reason']}), but the process then crashed ({sig}) at exit"
            return FAIL, f"crashed ({sig})" + (f" in {where}" if where else "")
        if data is None:
            where = _last_line(trace)
            tail = _tail(err) or _tail(out)
            return FAIL, (f"process exited with status {rc} without a result" + (f" in {where}" if where else "")
                          + (f"; output: {tail}" if tail else ""))
        return data["status"], data["reason"]
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _extract(fmu_path: Path) -> Path:
    from fmpy import extract
    unzipdir = Path(tempfile.mkdtemp(prefix="spurdiff-fmu-"))
    extract(str(fmu_path), unzipdir=str(unzipdir))
    return unzipdir


def run_lifecycle_checks_many(fmus: Sequence[tuple[str | Path, str]], options: LifecycleOptions | None = None,
                              checks: Sequence[str] = LIFECYCLE_CHECKS) -> dict[str, list[CheckResult]]:
    """Lifecycle checks for several FMUs, ``options.jobs`` processes at a time.

    ``fmus`` holds (path, subject) pairs; the answer maps subject -> results in ``checks`` order.
    ``lifecycle.basic`` runs first for every FMU; the other checks of an FMU whose basic check
    failed are SKIPped.
    """
    options = options or LifecycleOptions()
    unzipped: dict[str, Path] = {}
    out: dict[str, dict[str, CheckResult]] = {subject: {} for _, subject in fmus}

    def run_one(subject: str, check_id: str) -> CheckResult:
        t0 = time.perf_counter()
        payload = {"unzipdir": str(unzipped[subject]), "steps": options.steps}
        status, reason = run_isolated(check_id, payload, options.timeout)
        return CheckResult(subject, check_id, status, reason, time.perf_counter() - t0)

    try:
        for path, subject in fmus:
            unzipped[subject] = _extract(Path(path))
        with ThreadPoolExecutor(max_workers=max(1, options.jobs)) as pool:
            first = "lifecycle.basic" if "lifecycle.basic" in checks else None
            if first:
                for subject, res in zip(out, pool.map(lambda s: run_one(s, first), list(out))):
                    out[subject][first] = res
            jobs = []
            for subject in out:
                for check_id in checks:
                    if check_id == first:
                        continue
                    if first and out[subject][first].failed:
                        out[subject][check_id] = CheckResult(subject, check_id, SKIP,
                                                             "needs lifecycle.basic, which failed")
                    else:
                        jobs.append((subject, check_id))
            for (subject, check_id), res in zip(jobs, pool.map(lambda j: run_one(*j), jobs)):
                out[subject][check_id] = res
    finally:
        for d in unzipped.values():
            shutil.rmtree(d, ignore_errors=True)
    return {subject: [res[c] for c in checks] for subject, res in out.items()}


def run_lifecycle_checks(fmu_path: str | Path, subject: str | None = None,
                         options: LifecycleOptions | None = None) -> list[CheckResult]:
    """All lifecycle checks for one FMU (see the module docstring)."""
    subject = subject if subject is not None else str(fmu_path)
    return run_lifecycle_checks_many([(fmu_path, subject)], options)[subject]


# ============================================================================ worker side

class CallFailed(Exception):
    """An FMI call returned a status above fmi2Warning (or fmi2Instantiate returned NULL)."""

    def __init__(self, call: str, instance: str, status: int | None, message: str = ""):
        self.call, self.instance, self.status, self.message = call, instance, status, message
        text = f"{call} [instance {instance}] returned {status_label(status) if status is not None else 'NULL'}"
        super().__init__(text + (f': FMU says "{message}"' if message else ""))


class Tracer:
    """Writes the FMI call about to be made to a file (unbuffered), for crash reports."""

    def __init__(self, path: str):
        self.fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)

    def __call__(self, text: str) -> None:
        os.write(self.fd, (text + "\n").encode("utf-8", "replace"))


def _parse_start(v) -> Any:
    s = v.start
    if s is None:
        return None
    if v.type == "Real":
        return float(s)
    if v.type in ("Integer", "Enumeration"):
        return int(s)
    if v.type == "Boolean":
        return s in (True, "true", "1", 1)
    return str(s)


def perturbed(v, value: Any) -> Any | None:
    """A value different from ``value`` within the variable's min/max (None if there is none)."""
    if v.type == "Boolean":
        return not value
    if v.type == "String":
        return str(value) + "_changed"
    lo = float(v.min) if v.min is not None else -math.inf
    hi = float(v.max) if v.max is not None else math.inf
    if v.type == "Real":
        d = 0.1 * abs(value) if value != 0 else 0.1
        cands = [value + d, value - d]
        if math.isfinite(hi):
            cands.append(0.5 * (value + hi))
        if math.isfinite(lo):
            cands.append(0.5 * (value + lo))
    elif v.type in ("Integer", "Enumeration"):
        cands = [value + 1, value - 1]
    else:
        return None
    for c in cands:
        if lo <= c <= hi and c != value:
            return c
    return None


class Session:
    """One worker's view of the FMU: variables, experiment, and a factory for instances."""

    SETTABLE_TYPES = ("Real", "Integer", "Enumeration", "Boolean", "String")
    OUTPUT_TYPES = ("Real", "Integer", "Enumeration", "Boolean")

    def __init__(self, payload: dict, trace: Callable[[str], None]):
        from fmpy import read_model_description
        self.unzipdir = payload["unzipdir"]
        self.steps = max(2, int(payload.get("steps", 10)))
        self.trace = trace
        self.md = read_model_description(self.unzipdir, validate=False)
        self.cs = self.md.coSimulation
        de = self.md.defaultExperiment
        self.t0 = float(de.startTime) if de is not None and de.startTime is not None else 0.0
        step = float(de.stepSize) if de is not None and de.stepSize is not None else 0.0
        self.h = step if step > 0 else DEFAULT_STEP_SIZE
        mv = self.md.modelVariables
        self.start_vars = [v for v in mv if v.causality in ("parameter", "input") and v.variability != "constant"
                           and v.type in self.SETTABLE_TYPES and v.start is not None]
        self.start_values = {v.name: _parse_start(v) for v in self.start_vars}
        self.inputs = [v for v in mv if v.causality == "input" and v.type in self.SETTABLE_TYPES]
        self.real_inputs = [v for v in self.inputs if v.type == "Real"]
        self.outputs = [v for v in mv if v.causality == "output" and v.type in self.OUTPUT_TYPES]
        self.by_name = {v.name: v for v in mv}

    def instance(self, name: str) -> "Instance":
        return Instance(self, name)


class Instance:
    """One FMU instance driven through fmpy's FMU2Slave, every call traced and checked."""

    def __init__(self, session: Session, name: str):
        from fmpy.fmi2 import FMU2Slave
        self.s, self.name = session, name
        self.messages: list[tuple[int, str]] = []
        self.s.trace(f"loading the binary [instance {name}]")
        self.fmu = FMU2Slave(guid=session.md.guid, unzipDirectory=session.unzipdir,
                             modelIdentifier=session.cs.modelIdentifier, instanceName=name)

    # -- plumbing
    def _logger(self, component, instance_name, status, category, message):
        try:
            self.messages.append((int(status), message.decode("utf-8", "replace") if message else ""))
        except Exception:  # never let a logging problem escape into the FMU
            pass

    def last_message(self) -> str:
        bad = [m for st, m in self.messages if st >= 1]
        text = (bad or [m for _, m in self.messages] or [""])[-1]
        return " ".join(text.split())[:300]

    def call(self, label: str, fn: Callable, *args):
        """Trace, call, and turn fmpy's FMICallException into :class:`CallFailed`."""
        from fmpy.fmi1 import FMICallException
        self.s.trace(f"{label} [instance {self.name}]")
        try:
            return fn(*args)
        except FMICallException as e:
            raise CallFailed(label, self.name, e.status, self.last_message()) from None

    # -- lifecycle
    def instantiate(self) -> None:
        from ctypes import byref
        from fmpy import calloc, free
        from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                               fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
        cb = fmi2CallbackFunctions()
        self._logger_ref = fmi2CallbackLoggerTYPE(self._logger)  # keep a reference: no GC
        cb.logger = self._logger_ref
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        try:
            from fmpy.logging import addLoggerProxy  # formats printf-style messages in C
            addLoggerProxy(byref(cb))
        except Exception:
            pass
        self._callbacks = cb
        self.s.trace(f"fmi2Instantiate [instance {self.name}]")
        try:
            self.fmu.instantiate(visible=False, callbacks=cb, loggingOn=True)
        except Exception:
            raise CallFailed("fmi2Instantiate", self.name, None, self.last_message()) from None

    def set_values(self, values: dict[str, Any], label: str = "") -> None:
        """Set variables by name, batched per type (one fmi2SetXXX call per type)."""
        groups: dict[str, tuple[list[int], list[Any]]] = {}
        for name, value in values.items():
            v = self.s.by_name[name]
            kind = "Integer" if v.type == "Enumeration" else v.type
            vrs, vals = groups.setdefault(kind, ([], []))
            vrs.append(v.valueReference)
            vals.append(value)
        for kind, (vrs, vals) in groups.items():
            names = ", ".join(n for n in values if (self.s.by_name[n].type == kind or
                                                    (kind == "Integer" and self.s.by_name[n].type == "Enumeration")))
            setter = {"Real": self.fmu.setReal, "Integer": self.fmu.setInteger,
                      "Boolean": self.fmu.setBoolean, "String": self.fmu.setString}[kind]
            self.call(f"fmi2Set{kind}({names}){label}", setter, vrs, vals)

    def set_status(self, name: str, value: Any) -> int:
        """Set one variable through the raw FMI function and return its status (no exception)."""
        from ctypes import c_char_p
        from fmpy.fmi2 import fmi2Boolean, fmi2Integer, fmi2Real, fmi2ValueReference
        v = self.s.by_name[name]
        vr = (fmi2ValueReference * 1)(v.valueReference)
        if v.type == "Real":
            fn, arr = self.fmu.fmi2SetReal, (fmi2Real * 1)(value)
        elif v.type in ("Integer", "Enumeration"):
            fn, arr = self.fmu.fmi2SetInteger, (fmi2Integer * 1)(value)
        elif v.type == "Boolean":
            fn, arr = self.fmu.fmi2SetBoolean, (fmi2Boolean * 1)(1 if value else 0)
        else:
            fn, arr = self.fmu.fmi2SetString, (c_char_p * 1)(str(value).encode())
        kind = "Integer" if v.type == "Enumeration" else v.type
        return self.raw_status(f"fmi2Set{kind}({name} = {value!r})", fn, self.fmu.component, vr, 1, arr)

    def raw_status(self, label: str, fn: Callable, *args) -> int:
        from fmpy.fmi1 import FMICallException
        self.s.trace(f"{label} [instance {self.name}]")
        try:
            return int(fn(*args))
        except FMICallException as e:
            return int(e.status)

    def step_status(self, t: float, h: float) -> int:
        """fmi2DoStep returning its status instead of raising."""
        return self.raw_status(f"fmi2DoStep(t={t:.9g}, h={h:.9g})", self.fmu.fmi2DoStep,
                               self.fmu.component, t, h, 1)

    def setup(self) -> None:
        self.call(f"fmi2SetupExperiment(startTime={self.s.t0:g})", self.fmu.setupExperiment, None, self.s.t0, None)

    def initialize(self, overrides: dict[str, Any] | None = None, instantiate: bool = True) -> None:
        """[instantiate,] start values (with overrides), setupExperiment, enter/exit initialization."""
        if instantiate:
            self.instantiate()
        values = dict(self.s.start_values)
        values.update(overrides or {})
        if values:
            self.set_values(values, " start values")
        self.setup()
        self.call("fmi2EnterInitializationMode", self.fmu.enterInitializationMode)
        self.call("fmi2ExitInitializationMode", self.fmu.exitInitializationMode)

    def outputs(self) -> list[float]:
        """Every Real/Integer/Enumeration/Boolean output, as floats, in model-description order."""
        by_kind: dict[str, list] = {}
        for i, v in enumerate(self.s.outputs):
            kind = "Integer" if v.type == "Enumeration" else v.type
            by_kind.setdefault(kind, []).append((i, v.valueReference))
        row = [math.nan] * len(self.s.outputs)
        getters = {"Real": self.fmu.getReal, "Integer": self.fmu.getInteger, "Boolean": self.fmu.getBoolean}
        for kind, items in by_kind.items():
            vals = self.call(f"fmi2Get{kind}(outputs)", getters[kind], [vr for _, vr in items])
            for (i, _), x in zip(items, vals):
                row[i] = float(x)
        return row

    def do_step(self, t: float, h: float) -> None:
        self.call(f"fmi2DoStep(t={t:.9g}, h={h:.9g})", self.fmu.doStep, t, h)

    def run(self, t: float, steps: Sequence[float] | int, inputs: dict[str, Any] | None = None):
        """Outputs now, then for each step: set inputs, doStep, read outputs. Returns (rows, t_end)."""
        if isinstance(steps, int):
            n, h = steps, self.s.h
            sizes = None
        else:
            sizes = list(steps)
            n = len(sizes)
        inputs = inputs if inputs is not None else {v.name: self.s.start_values[v.name]
                                                    for v in self.s.inputs if v.name in self.s.start_values}
        rows = [self.outputs()]
        t_start = t
        for i in range(n):
            if inputs:
                self.set_values(inputs)
            if sizes is None:
                t_now, t_next = t_start + i * h, t_start + (i + 1) * h
            else:
                t_now, t_next = t, t + sizes[i]
            self.do_step(t_now, t_next - t_now)
            t = t_next
            rows.append(self.outputs())
        return rows, t

    def terminate(self) -> None:
        self.call("fmi2Terminate", self.fmu.terminate)

    def free(self) -> None:
        self.s.trace(f"fmi2FreeInstance [instance {self.name}]")
        self.fmu.freeInstance()


def first_difference(s: Session, a: list[list[float]], b: list[list[float]],
                     start: str = "after initialization") -> str | None:
    """None when the two output trajectories are the same (see SAME_RTOL/SAME_ATOL), else where
    they first differ; ``start`` names the moment of sample 0."""
    import numpy as np
    A, B = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if A.shape != B.shape:
        return f"{A.shape[0]} samples vs {B.shape[0]}"
    ok = np.isclose(A, B, rtol=SAME_RTOL, atol=SAME_ATOL, equal_nan=True)
    if ok.all():
        return None
    i, j = map(int, np.argwhere(~ok)[0])
    where = start if i == 0 else f"after step {i}"
    return f"{s.outputs[j].name} {where}: {float(A[i, j])!r} vs {float(B[i, j])!r}"


def _refusal(status: int, inst: Instance, what: str) -> tuple[str, str]:
    msg = inst.last_message()
    said = f' ("{msg}")' if msg else ""
    if status in REFUSED:
        note = " (fmi2Fatal leaves the instance unusable; fmi2Error would do)" if status == 4 else ""
        return PASS, f"{what} refused with {status_label(status)}{said}{note}"
    return FAIL, f"{what} returned {status_label(status)}{said}: it must be refused (fmi2Error)"


# ---------------------------------------------------------------- the checks (worker side)

def check_basic(s: Session) -> tuple[str, str]:
    a = s.instance("basic")
    a.initialize()
    rows, _ = a.run(s.t0, s.steps)
    a.terminate()
    a.free()
    return PASS, (f"instantiate, setupExperiment, initialization, {s.steps} doSteps of {s.h:g} s, terminate, "
                  f"freeInstance all accepted; {len(s.outputs)} outputs read")


def check_reset(s: Session) -> tuple[str, str]:
    if not s.outputs:
        return SKIP, "no outputs to compare"
    a = s.instance("reset")
    a.initialize()
    first, _ = a.run(s.t0, s.steps)
    a.call("fmi2Reset", a.fmu.reset)
    a.initialize(instantiate=False)
    second, _ = a.run(s.t0, s.steps)
    a.terminate()
    a.free()
    diff = first_difference(s, second, first)
    if diff:
        return FAIL, f"after fmi2Reset the same run gives different outputs: {diff} (after reset vs first run)"
    return PASS, f"after fmi2Reset the same {s.steps} steps give the same outputs"


def _variations(s: Session) -> list[tuple[str, dict[str, Any]]]:
    """Candidate (description, overrides): all inputs changed together, then single parameters."""
    out = []
    ins = {}
    for v in s.inputs:
        if v.name in s.start_values:
            p = perturbed(v, s.start_values[v.name])
            if p is not None:
                ins[v.name] = p
    if ins:
        out.append(("inputs " + ", ".join(ins), ins))
    for v in s.start_vars:
        if v.causality == "parameter" and v.type != "String":
            p = perturbed(v, s.start_values[v.name])
            if p is not None:
                out.append((f"parameter {v.name}", {v.name: p}))
        if len(out) >= 9:
            break
    return out


def _solo(s: Session, name: str, overrides: dict[str, Any]) -> list[list[float]]:
    inst = s.instance(name)
    inst.initialize(overrides)
    inputs = {v.name: s.start_values[v.name] for v in s.inputs if v.name in s.start_values}
    inputs.update({k: x for k, x in overrides.items() if s.by_name[k].causality == "input"})
    rows, _ = inst.run(s.t0, s.steps, inputs)
    inst.terminate()
    inst.free()
    return rows


def check_two_instances(s: Session) -> tuple[str, str]:
    if s.cs.canBeInstantiatedOnlyOncePerProcess:
        return SKIP, "canBeInstantiatedOnlyOncePerProcess is true"
    if not s.outputs:
        return SKIP, "no outputs to compare"
    ref_a = _solo(s, "A1", {})
    chosen = None
    for k, (what, overrides) in enumerate(_variations(s)):
        try:
            ref_b = _solo(s, f"B1_{k}", overrides)
        except CallFailed as e:
            if e.status == 4:  # the process must not touch this FMU again
                return SKIP, f"changing {what} made the FMU fail ({e}); no other variation tried"
            continue
        if first_difference(s, ref_b, ref_a):
            chosen = (what, overrides, ref_b)
            break
    if chosen is None:
        return SKIP, "no input or parameter variation changed the outputs: independence not observable"
    what, overrides, ref_b = chosen
    a, b = s.instance("A2"), s.instance("B2")
    a.instantiate()
    b.instantiate()
    for inst, ov in ((a, {}), (b, overrides)):
        values = dict(s.start_values)
        values.update(ov)
        inst.set_values(values, " start values")
    for inst in (a, b):
        inst.setup()
    for inst in (a, b):
        inst.call("fmi2EnterInitializationMode", inst.fmu.enterInitializationMode)
    for inst in (a, b):
        inst.call("fmi2ExitInitializationMode", inst.fmu.exitInitializationMode)
    in_a = {v.name: s.start_values[v.name] for v in s.inputs if v.name in s.start_values}
    in_b = dict(in_a)
    in_b.update({k: x for k, x in overrides.items() if s.by_name[k].causality == "input"})
    rows_a, rows_b = [a.outputs()], [b.outputs()]
    for i in range(s.steps):
        t, h = s.t0 + i * s.h, s.h
        for inst, ins, rows in ((a, in_a, rows_a), (b, in_b, rows_b)):
            if ins:
                inst.set_values(ins)
            inst.do_step(t, (s.t0 + (i + 1) * s.h) - t)
            rows.append(inst.outputs())
    for inst in (a, b):
        inst.terminate()
    for inst in (a, b):
        inst.free()
    da = first_difference(s, rows_a, ref_a)
    db = first_difference(s, rows_b, ref_b)
    if da or db:
        parts = []
        if da:
            parts.append(f"the first instance (start values) changed when a second one ran beside it: {da} (beside vs alone)")
        if db:
            parts.append(f"the second instance ({what} changed) differs from running alone: {db} (beside vs alone)")
        return FAIL, "; ".join(parts)
    return PASS, f"two instances at once (the second with {what} changed) each give their solo outputs"


def check_get_set_state(s: Session) -> tuple[str, str]:
    if not s.cs.canGetAndSetFMUstate:
        return SKIP, "canGetAndSetFMUstate is not declared"
    if not s.outputs:
        return SKIP, "no outputs to compare"
    k = max(1, s.steps // 2)
    m = max(1, s.steps - k)
    a = s.instance("state")
    a.initialize()
    _, t_k = a.run(s.t0, k)
    state = a.call("fmi2GetFMUstate", a.fmu.getFMUstate)
    first, _ = a.run(t_k, m)
    a.call("fmi2SetFMUstate", a.fmu.setFMUstate, state)
    second, _ = a.run(t_k, m)
    a.call("fmi2FreeFMUstate", a.fmu.freeFMUstate, state)
    a.terminate()
    a.free()
    diff = first_difference(s, second, first, "right after the state call")
    if diff:
        return FAIL, (f"after fmi2SetFMUstate to the state saved at t = {t_k:g} s the continuation differs: "
                      f"{diff} (after restore vs first continuation)")
    return PASS, f"fmi2SetFMUstate to the state at t = {t_k:g} s repeats the next {m} steps exactly"


def check_serialize_state(s: Session) -> tuple[str, str]:
    if not s.cs.canSerializeFMUstate:
        return SKIP, "canSerializeFMUstate is not declared"
    if not s.cs.canGetAndSetFMUstate:
        return FAIL, "canSerializeFMUstate is declared without canGetAndSetFMUstate (FMI 2.0 requires both)"
    if not s.outputs:
        return SKIP, "no outputs to compare"
    k = max(1, s.steps // 2)
    m = max(1, s.steps - k)
    a = s.instance("serialize")
    a.initialize()
    _, t_k = a.run(s.t0, k)
    state = a.call("fmi2GetFMUstate", a.fmu.getFMUstate)
    blob = a.call("fmi2SerializeFMUstate", a.fmu.serializeFMUstate, state)
    a.call("fmi2FreeFMUstate", a.fmu.freeFMUstate, state)
    first, _ = a.run(t_k, m)
    a.terminate()
    a.free()
    b = s.instance("deserialize")
    b.initialize()
    restored = b.call("fmi2DeSerializeFMUstate", b.fmu.deSerializeFMUstate, blob)
    b.call("fmi2SetFMUstate", b.fmu.setFMUstate, restored)
    second, _ = b.run(t_k, m)
    b.call("fmi2FreeFMUstate", b.fmu.freeFMUstate, restored)
    b.terminate()
    b.free()
    diff = first_difference(s, second, first, "right after the state call")
    if diff:
        return FAIL, (f"a state serialized at t = {t_k:g} s ({len(blob)} bytes) and restored into a fresh "
                      f"instance continues differently: {diff} (restored vs original)")
    return PASS, (f"a state serialized at t = {t_k:g} s ({len(blob)} bytes) and restored into a fresh instance "
                  f"repeats the next {m} steps exactly")


def check_variable_step(s: Session) -> tuple[str, str]:
    if not s.cs.canHandleVariableCommunicationStepSize:
        return SKIP, "canHandleVariableCommunicationStepSize is not declared"
    sizes = [f * s.h for f in VARIABLE_STEP_FACTORS]
    a = s.instance("varstep")
    a.initialize()
    rows, _ = a.run(s.t0, sizes)
    a.terminate()
    a.free()
    real = [j for j, v in enumerate(s.outputs) if v.type == "Real"]
    finite0 = [j for j in real if math.isfinite(rows[0][j])]
    for i, row in enumerate(rows[1:], 1):
        bad = [s.outputs[j].name for j in finite0 if not math.isfinite(row[j])]
        if bad:
            return FAIL, f"after step {i} (h = {sizes[i - 1]:g} s) outputs became non-finite: {', '.join(bad)}"
    return PASS, (f"{len(sizes)} steps of {', '.join(f'{f:g}' for f in VARIABLE_STEP_FACTORS)} x {s.h:g} s "
                  f"accepted, outputs stayed finite")


def check_step_before_init(s: Session) -> tuple[str, str]:
    a = s.instance("early")
    a.instantiate()
    if s.start_values:
        a.set_values(s.start_values, " start values")
    a.setup()
    st = a.step_status(s.t0, s.h)
    return _refusal(st, a, "fmi2DoStep before initialization")


def check_parameter_after_init(s: Session) -> tuple[str, str]:
    fixed = [v for v in s.start_vars if v.causality == "parameter" and v.variability == "fixed"]
    target = None
    for v in fixed:
        p = perturbed(v, s.start_values[v.name])
        if p is not None:
            target = (v, p)
            break
    if target is None:
        return SKIP, "no parameter with variability \"fixed\" to set"
    v, p = target
    a = s.instance("late")
    a.initialize()
    st = a.set_status(v.name, p)
    return _refusal(st, a, f"setting fixed parameter {v.name} after initialization")


def _bad_step(s: Session, h: float, what: str) -> tuple[str, str]:
    a = s.instance("badstep")
    a.initialize()
    st = a.step_status(s.t0, h)
    return _refusal(st, a, f"fmi2DoStep with {what} (h = {h:g} s)")


def check_zero_step_size(s: Session) -> tuple[str, str]:
    return _bad_step(s, 0.0, "a zero step size")


def check_negative_step_size(s: Session) -> tuple[str, str]:
    return _bad_step(s, -s.h, "a negative step size")


def check_nan_inputs(s: Session) -> tuple[str, str]:
    if not s.real_inputs:
        return SKIP, "no Real inputs"
    names = ", ".join(v.name for v in s.real_inputs)
    a = s.instance("nan")
    a.initialize()
    for v in s.real_inputs:
        st = a.set_status(v.name, math.nan)
        if st in REFUSED:
            return _refusal(st, a, f"NaN written to input {v.name}")
    real = [j for j, v in enumerate(s.outputs) if v.type == "Real"]
    for i in range(NAN_STEPS):
        t = s.t0 + i * s.h
        if i > 0:
            for v in s.real_inputs:
                st = a.set_status(v.name, math.nan)
                if st in REFUSED:
                    return _refusal(st, a, f"NaN written to input {v.name}")
        st = a.step_status(t, s.h)
        if st in REFUSED:
            return _refusal(st, a, f"fmi2DoStep with NaN on inputs {names}")
        row = a.outputs()
        bad = [s.outputs[j].name for j in real if not math.isfinite(row[j])]
        if bad:
            return PASS, f"NaN on inputs {names} shows in outputs after step {i + 1}: {', '.join(bad)}"
    if not real:
        return SKIP, f"NaN on inputs {names} was accepted, and there are no Real outputs to observe"
    return FAIL, (f"NaN written to inputs {names} was accepted and {NAN_STEPS} doSteps returned fmi2OK with "
                  f"all Real outputs finite: the NaN was silently ignored")


WORKER_TASKS: dict[str, Callable[[Session], tuple[str, str]]] = {
    "lifecycle.basic": check_basic,
    "lifecycle.reset": check_reset,
    "lifecycle.two-instances": check_two_instances,
    "lifecycle.get-set-state": check_get_set_state,
    "lifecycle.serialize-state": check_serialize_state,
    "lifecycle.variable-step": check_variable_step,
    "lifecycle.step-before-init": check_step_before_init,
    "lifecycle.parameter-after-init": check_parameter_after_init,
    "lifecycle.zero-step-size": check_zero_step_size,
    "lifecycle.negative-step-size": check_negative_step_size,
    "lifecycle.nan-inputs": check_nan_inputs,
}


def worker_main(argv: Sequence[str]) -> None:
    """Entry point of a check process: ``task payload-json trace-file result-file``.

    Writes {"status", "reason"} as JSON to the result file, then leaves with ``os._exit`` (no
    interpreter teardown touching the FMU again, e.g. after fmi2Fatal).
    """
    task, payload_json, trace_path, result_path = argv
    try:
        import resource
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))  # a crashing FMU leaves no core file
    except Exception:
        pass
    tracer = Tracer(trace_path)
    payload = json.loads(payload_json)
    try:
        if task == "reference":
            from .reference import simulate_reference_task
            status, reason = simulate_reference_task(payload, tracer)
        else:
            status, reason = WORKER_TASKS[task](Session(payload, tracer))
    except CallFailed as e:
        status, reason = FAIL, str(e)
    except Exception as e:
        status, reason = FAIL, f"{type(e).__name__}: {e}"
    with open(result_path, "w", encoding="utf-8") as f:
        json.dump({"status": status, "reason": reason}, f)
        f.flush()
        os.fsync(f.fileno())
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)
