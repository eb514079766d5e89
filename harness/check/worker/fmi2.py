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

from .common import (DEFAULT_STEP_SIZE, DEFAULT_TOLERANCE, ENV_BASE, LOGGER_VIOLATIONS, SAME_ATOL,  # noqa: F401
                     SAME_RTOL, SharedCalls, Tracer, first_difference, perturbed)

WRONG_GUID = "{00000000-0000-0000-0000-5b0ad5b0ad00}"  # cs.guid, me.guid
INSTANCES: dict[int, "Instance"] = {}          # componentEnvironment -> instance
_LOGGER: list = []                             # the process's logger callback (kept alive)


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
        self.early_values = {v.name: self.start_values[v.name] for v in self.start_vars if v.causality != "input"}
        self.inputs = [v for v in mv if v.causality == "input" and v.type in self.SETTABLE_TYPES]
        self.real_inputs = [v for v in self.inputs if v.type == "Real"]
        self.outputs = [v for v in mv if v.causality == "output" and v.type in self.OUTPUT_TYPES]
        self.by_name = {v.name: v for v in mv}
        self.log_categories = [c.name if hasattr(c, "name") else str(c) for c in (self.md.logCategories or [])]
        self.columns = [v.name for v in self.outputs]
        self.real_columns = [j for j, v in enumerate(self.outputs) if v.type == "Real"]
        self._n = 0

    fmi, REAL = "fmi2", "Real"
    status_label = staticmethod(status_label)

    def is_real(self, v) -> bool:
        return v.type == "Real"

    def input_values(self) -> dict[str, Any]:
        return {v.name: self.start_values[v.name] for v in self.inputs if v.name in self.start_values}

    def instance(self, name: str, guid: str | None = None) -> "Instance":
        self._n += 1
        return Instance(self, name, ENV_BASE + 16 * self._n, guid)


class Instance(SharedCalls, FmuInstance):
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

    def enter_init(self) -> None:
        self.call("fmi2EnterInitializationMode", self.slave.enterInitializationMode)

    def fn(self, name: str):
        """The FMU's function fmi2<name> as fmpy wraps it (a refusal raises), e.g. fn("GetFMUstate")."""
        return getattr(self.slave, "fmi2" + name)

    def set_debug_logging(self, on: bool, categories: list[str]) -> int:
        from fmpy.fmi2 import fmi2String
        arr = (fmi2String * max(1, len(categories)))(*[c.encode() for c in categories]) if categories else None
        label = f"fmi2SetDebugLogging({'on' if on else 'off'}, {len(categories)} categories)"
        return self.status(label, self.slave.fmi2SetDebugLogging, self.slave.component, 1 if on else 0,
                           len(categories), arr)

    def step_result(self, t: float, h: float) -> tuple[int, bool]:
        """fmi2DoStep: (its status, False: FMI 2.0 says terminate through fmi2Terminated after a discard)."""
        return self.step_status(t, h), False

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


def refusal(status: int, inst, what: str) -> tuple[str, str]:
    """PASS when ``status`` refuses (discard/error/fatal), FAIL when it accepts."""
    from ..report import FAIL, PASS
    msg, f, label = inst.last_message(), inst.s.fmi, inst.s.status_label
    said = f' ("{msg}")' if msg else ""
    if status in REFUSED:
        note = f" ({f}Fatal leaves the instance unusable; {f}Error would do)" if status == 4 else ""
        return PASS, f"{what} refused with {label(status)}{said}{note}"
    return FAIL, f"{what} returned {label(status)}{said}: it should be refused ({f}Error)"
