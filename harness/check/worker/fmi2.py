"""Worker side: driving one FMU through fmpy's low-level FMI 2.0 API, every call traced.

Runs inside the fresh process of :mod:`.isolation`. :class:`Session` holds what the model
description says (variables, experiment, capabilities); :class:`Instance` is one FMU instance:
the harness's FMU wrapper (:class:`harness.fmi.instance.Instance`: calls, statuses, messages,
co-simulation or model exchange) driven the way the session says.

How an instance is driven: after ``fmi2Instantiate`` (logging on) the start value of every
non-constant parameter and input is set; ``fmi2SetupExperiment`` gets the DefaultExperiment start
time (else 0 s); the communication step is the DefaultExperiment ``stepSize`` (else 1e-3 s); before
every ``fmi2DoStep`` the inputs are set again, after it every Real, Integer, Enumeration and
Boolean output is read.

Every instance gets its own ``componentEnvironment`` (a distinct pointer value); one logger serves
the process and records messages per instance, and every message whose componentEnvironment or
instance name is not the one its instance was given (:data:`LOGGER_VIOLATIONS`).
"""
from __future__ import annotations

import math
import os
from typing import Any, Callable, Sequence

from harness.fmi.instance import REFUSED, CallFailed, Instance as FmuInstance, status_label  # noqa: F401

DEFAULT_STEP_SIZE = 1e-3          # s, when the FMU has no DefaultExperiment stepSize
DEFAULT_TOLERANCE = 1e-4          # relative, when the DefaultExperiment gives none (fmpy's and the cross-check default)
SAME_RTOL, SAME_ATOL = 1e-9, 1e-12  # "same outputs": rounding-level differences only
ENV_BASE = 0x5D1F0000  # componentEnvironment values handed out: ENV_BASE + 16 k
WRONG_GUID = "{00000000-0000-0000-0000-5b0ad5b0ad00}"  # cs.guid, me.guid

INSTANCES: dict[int, "Instance"] = {}          # componentEnvironment -> instance
LOGGER_VIOLATIONS: list[str] = []              # messages with a wrong environment or instance name
_LOGGER: list = []                             # the process's logger callback (kept alive)


class Tracer:
    """Writes the FMI call about to be made to a file (unbuffered), for crash reports."""

    def __init__(self, path: str):
        self.fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)

    def __call__(self, text: str) -> None:
        os.write(self.fd, (text + "\n").encode("utf-8", "replace"))


def _decode(b) -> str:
    if not b:
        return ""
    return b.decode("utf-8", "replace") if isinstance(b, bytes) else str(b)


def _log(env, instance_name, status, category, message) -> None:
    try:
        env = int(env or 0)
        name, text = _decode(instance_name), _decode(message)
        inst = INSTANCES.get(env)
        if inst is None:
            LOGGER_VIOLATIONS.append(f"componentEnvironment {env:#x} is not one given to fmi2Instantiate "
                                     f"(instance name {name!r}, message {text[:80]!r})")
            return
        if name != inst.name:
            LOGGER_VIOLATIONS.append(f"instance name {name!r} instead of {inst.name!r} "
                                     f"(message {text[:80]!r})")
        inst.messages.append((int(status), text))
    except Exception:  # never let a logging problem escape into the FMU
        pass


def logger_callback():
    from fmpy.fmi2 import fmi2CallbackLoggerTYPE
    if not _LOGGER:
        _LOGGER.append(fmi2CallbackLoggerTYPE(_log))
    return _LOGGER[0]


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
    """One worker's view of the FMU: variables, experiment, capabilities, and instances."""

    SETTABLE_TYPES = ("Real", "Integer", "Enumeration", "Boolean", "String")
    OUTPUT_TYPES = ("Real", "Integer", "Enumeration", "Boolean")

    def __init__(self, payload: dict, trace: Callable[[str], None], kind: str = "cs"):
        from fmpy import read_model_description
        self.payload = payload
        self.unzipdir = payload["unzipdir"]
        self.steps = max(2, int(payload.get("steps", 10)))
        self.trace = trace
        self.kind = kind
        self.md = read_model_description(self.unzipdir, validate=False)
        self.cs = self.md.coSimulation
        self.me = self.md.modelExchange
        self.iface = self.cs if kind == "cs" else self.me
        de = self.md.defaultExperiment
        self.t0 = float(de.startTime) if de is not None and de.startTime is not None else 0.0
        step = float(de.stepSize) if de is not None and de.stepSize is not None else 0.0
        self.h = step if step > 0 else DEFAULT_STEP_SIZE
        self.t_stop = (float(de.stopTime) if de is not None and de.stopTime is not None else self.t0 + 1.0)
        tol = float(de.tolerance) if de is not None and de.tolerance is not None else 0.0
        self.tolerance = tol if tol > 0 else DEFAULT_TOLERANCE   # the FMU's own (DefaultExperiment), else 1e-4
        mv = self.md.modelVariables
        self.variables = mv
        self.start_vars = [v for v in mv if v.causality in ("parameter", "input") and v.variability != "constant"
                           and v.type in self.SETTABLE_TYPES and v.start is not None]
        self.start_values = {v.name: _parse_start(v) for v in self.start_vars}
        self.inputs = [v for v in mv if v.causality == "input" and v.type in self.SETTABLE_TYPES]
        self.real_inputs = [v for v in self.inputs if v.type == "Real"]
        self.outputs = [v for v in mv if v.causality == "output" and v.type in self.OUTPUT_TYPES]
        self.by_name = {v.name: v for v in mv}
        self.log_categories = [c.name if hasattr(c, "name") else str(c) for c in (self.md.logCategories or [])]
        self._n = 0

    def input_values(self) -> dict[str, Any]:
        return {v.name: self.start_values[v.name] for v in self.inputs if v.name in self.start_values}

    def instance(self, name: str, guid: str | None = None) -> "Instance":
        self._n += 1
        return Instance(self, name, ENV_BASE + 16 * self._n, guid)


class Instance(FmuInstance):
    """One FMU instance of the session: co-simulation or model exchange as the session says, every
    call traced, messages through the process's logger (:func:`logger_callback`)."""

    def __init__(self, session: Session, name: str, env: int, guid: str | None = None):
        self.s, self.env = session, env
        super().__init__(name, unzipdir=session.unzipdir, md=session.md, kind=session.kind, guid=guid,
                         trace=session.trace, instantiate=False)

    def instantiate(self, raise_on_null: bool = True) -> bool:
        INSTANCES[self.env] = self
        return super().instantiate(logger=logger_callback(), environment=self.env, format_messages=True,
                                   raise_on_null=raise_on_null)

    def setup(self, stop_time: float | None = None) -> None:
        label = f"fmi2SetupExperiment(startTime={self.s.t0:g}" + (f", stopTime={stop_time:g})" if stop_time is not None else ")")
        self.call(label, self.slave.setupExperiment, None, self.s.t0, stop_time)

    def initialize(self, overrides: dict[str, Any] | None = None, instantiate: bool = True,
                   stop_time: float | None = None) -> None:
        """[instantiate,] start values (with overrides), setupExperiment, enter/exit initialization."""
        if instantiate:
            self.instantiate()
        values = dict(self.s.start_values)
        values.update(overrides or {})
        if values:
            self.set_values(values, " start values")
        self.setup(stop_time)
        self.call("fmi2EnterInitializationMode", self.slave.enterInitializationMode)
        self.call("fmi2ExitInitializationMode", self.slave.exitInitializationMode)

    def outputs(self) -> list[float]:
        """Every Real/Integer/Enumeration/Boolean output, as floats, in model-description order."""
        return self.read(self.s.outputs, "outputs")

    def run(self, t: float, steps: Sequence[float] | int, inputs: dict[str, Any] | None = None):
        """Outputs now, then for each step: set inputs, doStep, read outputs. Returns (rows, t_end)."""
        if isinstance(steps, int):
            n, sizes = steps, None
        else:
            sizes = list(steps)
            n = len(sizes)
        inputs = inputs if inputs is not None else self.s.input_values()
        rows = [self.outputs()]
        t_start = t
        for i in range(n):
            if inputs:
                self.set_values(inputs)
            if sizes is None:
                t_now, t_next = t_start + i * self.s.h, t_start + (i + 1) * self.s.h
            else:
                t_now, t_next = t, t + sizes[i]
            self.do_step(t_now, t_next - t_now)
            t = t_next
            rows.append(self.outputs())
        return rows, t


def accepts_wrong_guid(s: Session) -> tuple[bool, str]:
    """Whether fmi2Instantiate with :data:`WRONG_GUID` gave an instance (freed again), and the FMU's
    last message."""
    a = s.instance("wrongGuid", guid=WRONG_GUID)
    if a.instantiate(raise_on_null=False):
        a.free()
        return True, a.last_message()
    return False, a.last_message()


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


def refusal(status: int, inst: Instance, what: str) -> tuple[str, str]:
    """PASS when ``status`` refuses (discard/error/fatal), FAIL when it accepts."""
    from ..report import FAIL, PASS
    msg = inst.last_message()
    said = f' ("{msg}")' if msg else ""
    if status in REFUSED:
        note = " (fmi2Fatal leaves the instance unusable; fmi2Error would do)" if status == 4 else ""
        return PASS, f"{what} refused with {status_label(status)}{said}{note}"
    return FAIL, f"{what} returned {status_label(status)}{said}: it should be refused (fmi2Error)"
