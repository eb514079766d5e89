"""Worker side for FMI 3.0 FMUs: one FMU instance through fmpy's FMI 3.0 API (:class:`fmpy.fmi3.FMU3Slave`,
:class:`fmpy.fmi3.FMU3Model`), every call traced.

How an instance is driven (the FMI 3.0 counterpart of :mod:`.driver`): instantiated with logging on,
event mode and early return not used; the start value of every non-constant parameter and input with
initial exact or approx is set in Instantiated; ``fmi3EnterInitializationMode`` gets the
DefaultExperiment start time (else 0 s) and, where a rule asks, the stop time; the communication step is
the DefaultExperiment ``stepSize`` (else 1e-3 s); before every ``fmi3DoStep`` the inputs are set again,
after it every numeric and Boolean output is read (arrays whole, by their Dimension sizes).
"""
from __future__ import annotations

import math
from typing import Callable, Sequence

from .fmi2 import DEFAULT_STEP_SIZE, DEFAULT_TOLERANCE, SAME_ATOL, SAME_RTOL

STATUS3 = ("fmi3OK", "fmi3Warning", "fmi3Discard", "fmi3Error", "fmi3Fatal")
REFUSED3 = (2, 3, 4)
NUMERIC = ("Float32", "Float64", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64", "Boolean",
           "Enumeration")


def api_type(v) -> str:
    """The {VariableType} of the fmi3Get/Set functions for ``v``: 2.2.7.2 "To set or inquire variables of type
    Enumeration, fmi3SetInt64 and fmi3GetInt64 must be used." """
    return "Int64" if v.type == "Enumeration" else v.type
WRONG_TOKEN = "{00000000-0000-0000-0000-5b0ad5b0ad00}"


def status3(status: int | None) -> str:
    if status is None:
        return "NULL"
    return STATUS3[status] if 0 <= status < len(STATUS3) else f"illegal status {status}"


class Call3Failed(Exception):
    """An FMI 3.0 call returned a status above fmi3Warning (or an instantiation returned NULL)."""

    def __init__(self, call: str, instance: str, status: int | None, message: str = ""):
        self.call, self.instance, self.status, self.message = call, instance, status, message
        super().__init__(f"{call} [instance {instance}] returned {status3(status)}"
                         + (f': FMU says "{message}"' if message else ""))


def _parse(v, text: str) -> list:
    if v.type in ("Float32", "Float64"):
        return [float(w) for w in text.split()]
    if v.type == "Boolean":
        return [w in ("true", "1") for w in text.split()]
    if v.type == "String":
        return [text]
    return [int(w) for w in text.split()]


class Session3:
    """One worker's view of an FMI 3.0 FMU: variables with their sizes, experiment, capabilities."""

    def __init__(self, payload: dict, trace: Callable[[str], None], kind: str = "cs3"):
        from fmpy import read_model_description
        self.payload, self.unzipdir, self.trace, self.kind = payload, payload["unzipdir"], trace, kind
        self.steps = max(2, int(payload.get("steps", 10)))
        self.md = read_model_description(self.unzipdir, validate=False)
        self.iface = self.md.coSimulation if kind == "cs3" else self.md.modelExchange
        de = self.md.defaultExperiment
        self.t0 = float(de.startTime) if de is not None and de.startTime is not None else 0.0
        step = float(de.stepSize) if de is not None and de.stepSize is not None else 0.0
        self.h = step if step > 0 else DEFAULT_STEP_SIZE
        self.t_stop = float(de.stopTime) if de is not None and de.stopTime is not None else self.t0 + 1.0
        tol = float(de.tolerance) if de is not None and de.tolerance is not None else 0.0
        self.tolerance = tol if tol > 0 else DEFAULT_TOLERANCE
        self.variables = list(self.md.modelVariables)
        self.by_vr = {v.valueReference: v for v in self.variables}
        self.start_vars = [v for v in self.variables if v.causality in ("parameter", "input")
                           and v.variability != "constant" and v.type in NUMERIC + ("String",)
                           and v.start is not None and not getattr(v, "clocks", None)]
        self.inputs = [v for v in self.start_vars if v.causality == "input"]
        self.outputs = [v for v in self.variables if v.causality == "output" and v.type in NUMERIC
                        and not getattr(v, "clocks", None)]
        self._n = 0

    def size(self, v) -> int:
        n = 1
        for d in getattr(v, "dimensions", None) or []:
            if d.start is not None:
                n *= int(d.start)
            else:
                ref = d.variable if getattr(d, "variable", None) is not None else self.by_vr.get(d.valueReference)
                n *= int(ref.start)
        return n

    def values_of(self, v) -> list:
        """The start value(s) of ``v``, as many as its size (one value repeated for an array)."""
        vals = _parse(v, str(v.start))
        n = self.size(v)
        return vals * n if len(vals) == 1 and n > 1 else vals

    def instance(self, name: str, token: str | None = None) -> "Instance3":
        self._n += 1
        return Instance3(self, name, token)


class Instance3:
    """One FMU instance of the session (co-simulation or model exchange as the session says)."""

    def __init__(self, s: Session3, name: str, token: str | None = None):
        from fmpy.fmi3 import FMU3Model, FMU3Slave
        self.s, self.name, self.messages = s, name, []
        s.trace(f"loading the binary [instance {name}]")
        cls = FMU3Slave if s.kind == "cs3" else FMU3Model
        self.fmu = cls(guid=token if token is not None else s.md.guid, unzipDirectory=s.unzipdir,
                       modelIdentifier=s.iface.modelIdentifier, instanceName=name)

    # ------------------------------------------------------------------ calls
    def last_message(self) -> str:
        bad = [m for st, m in self.messages if st >= 1]
        text = (bad or [m for _, m in self.messages] or [""])[-1]
        return " ".join(text.split())[:300]

    def call(self, label: str, fn: Callable, *args):
        from fmpy.fmi1 import FMICallException
        self.s.trace(f"{label} [instance {self.name}]")
        try:
            return fn(*args)
        except FMICallException as e:
            raise Call3Failed(label, self.name, e.status, self.last_message()) from None

    def status(self, label: str, fn: Callable, *args) -> int:
        from fmpy.fmi1 import FMICallException
        self.s.trace(f"{label} [instance {self.name}]")
        try:
            r = fn(*args)
            return int(r) if isinstance(r, int) else 0
        except FMICallException as e:
            return int(e.status)

    def _log(self, env, status, category, message) -> None:
        try:
            text = message.decode("utf-8", "replace") if isinstance(message, bytes) else str(message)
            self.messages.append((int(status), text))
        except Exception:
            pass

    def instantiate(self, raise_on_null: bool = True, early_return: bool = False) -> bool:
        self.s.trace(f"fmi3Instantiate{'CoSimulation' if self.s.kind == 'cs3' else 'ModelExchange'}"
                     f"{'(earlyReturnAllowed)' if early_return else ''} [instance {self.name}]")
        try:
            if self.s.kind == "cs3":
                self.fmu.instantiate(visible=False, loggingOn=True, eventModeUsed=False,
                                     earlyReturnAllowed=early_return, logMessage=self._log)
            else:
                self.fmu.instantiate(visible=False, loggingOn=True, logMessage=self._log)
        except Exception:
            if raise_on_null:
                raise Call3Failed("fmi3Instantiate", self.name, None, self.last_message()) from None
            return False
        return True

    def set_values(self, variables: Sequence, label: str = "") -> None:
        """Set the start values of ``variables``, one fmi3Set{Type} call per variable."""
        for v in variables:
            vals = self.s.values_of(v)
            t = api_type(v)
            self.call(f"fmi3Set{t}({v.name}){label}", getattr(self.fmu, f"set{t}"), [v.valueReference], vals)

    def set_status(self, v, values: list) -> int:
        t = api_type(v)
        return self.status(f"fmi3Set{t}({v.name} = {values!r})", getattr(self.fmu, f"set{t}"), [v.valueReference],
                           values)

    def enter_init(self, stop_time: float | None = None) -> None:
        label = f"fmi3EnterInitializationMode(startTime={self.s.t0:g}" + (
            f", stopTime={stop_time:g})" if stop_time is not None else ")")
        self.call(label, self.fmu.enterInitializationMode, None, self.s.t0, stop_time)

    def initialize(self, stop_time: float | None = None, instantiate: bool = True, early_return: bool = False) -> None:
        """[instantiate,] start values, enter and exit Initialization Mode."""
        if instantiate:
            self.instantiate(early_return=early_return)
        self.set_values(self.s.start_vars, " start values")
        self.enter_init(stop_time)
        self.call("fmi3ExitInitializationMode", self.fmu.exitInitializationMode)

    def read(self, variables: Sequence, label: str) -> list[float]:
        """The values of ``variables`` (arrays flattened), as floats, in the given order."""
        row: list[float] = []
        for v in variables:
            t = api_type(v)
            vals = self.call(f"fmi3Get{t}({label})", getattr(self.fmu, f"get{t}"), [v.valueReference], self.s.size(v))
            row += [float(x) for x in vals]
        return row

    def outputs(self) -> list[float]:
        return self.read(self.s.outputs, "outputs")

    def step_status(self, t: float, h: float) -> int:
        return self.status(f"fmi3DoStep(t={t:.9g}, h={h:.9g})", self.fmu.doStep, t, h, True)

    def do_step(self, t: float, h: float) -> None:
        out = self.call(f"fmi3DoStep(t={t:.9g}, h={h:.9g})", self.fmu.doStep, t, h, True)
        if out and out[1]:   # terminateSimulation
            raise Call3Failed(f"fmi3DoStep(t={t:.9g}, h={h:.9g}) asked to terminate", self.name, 0,
                              self.last_message())

    def run(self, t: float, steps: int) -> tuple[list[list[float]], float]:
        """Outputs now, then ``steps`` times: inputs, doStep, outputs. Returns (rows, t_end)."""
        rows = [self.outputs()]
        for i in range(steps):
            if self.s.inputs:
                self.set_values(self.s.inputs)
            t_now = self.s.t0 + i * self.s.h if t == self.s.t0 else t + i * self.s.h
            self.do_step(t_now, self.s.h)
            rows.append(self.outputs())
        return rows, t + steps * self.s.h

    def terminate(self) -> None:
        self.call("fmi3Terminate", self.fmu.terminate)

    def free(self) -> None:
        self.s.trace(f"fmi3FreeInstance [instance {self.name}]")
        self.fmu.fmi3FreeInstance(self.fmu.component)


def first_difference3(s: Session3, a: list[list[float]], b: list[list[float]], start: str = "after initialization"):
    """None when the two output trajectories are the same (rounding only), else where they first differ."""
    import numpy as np
    A, B = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if A.shape != B.shape:
        return f"{A.shape[0]} samples vs {B.shape[0]}"
    ok = np.isclose(A, B, rtol=SAME_RTOL, atol=SAME_ATOL, equal_nan=True)
    if ok.all():
        return None
    i, j = map(int, np.argwhere(~ok)[0])
    names = [f"{v.name}[{k}]" if s.size(v) > 1 else v.name for v in s.outputs for k in range(s.size(v))]
    where = start if i == 0 else f"after step {i}"
    return f"{names[j]} {where}: {float(A[i, j])!r} vs {float(B[i, j])!r}"


def finite(xs: Sequence[float]) -> bool:
    return all(math.isfinite(x) for x in xs)


__all__ = ["Session3", "Instance3", "Call3Failed", "status3", "REFUSED3", "WRONG_TOKEN", "first_difference3",
           "finite"]
