"""Worker side for FMI 3.0 FMUs: one FMU instance through fmpy's FMI 3.0 API (:class:`fmpy.fmi3.FMU3Slave`,
:class:`fmpy.fmi3.FMU3Model`), every call traced, with the methods of the FMI 2.0 :class:`.fmi2.Instance` (a
rule that means the same in both versions is one function).

How an instance is driven (as in :mod:`.fmi2`): instantiated with logging on, an instanceEnvironment of its
own (the logger checks it comes back), event mode and early return not used unless a rule asks; the start
value of every non-constant parameter is set in Instantiated, of every input in Initialization Mode;
``fmi3EnterInitializationMode`` gets the DefaultExperiment start time (else 0 s) and, where a rule asks, the
stop time; the communication step is the DefaultExperiment ``stepSize`` (else 1e-3 s); before every
``fmi3DoStep`` the inputs are set again, after it every numeric and Boolean output is read (arrays whole, by
their Dimension sizes).
"""
from __future__ import annotations

from ctypes import c_void_p
from typing import Any, Callable, Sequence

from harness.fmi.instance import CallFailed

from .common import (DEFAULT_STEP_SIZE, DEFAULT_TOLERANCE, ENV_BASE, LOGGER_VIOLATIONS, SharedCalls,  # noqa: F401
                     finite, first_difference)

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


class Call3Failed(CallFailed):
    """An FMI 3.0 call returned a status above fmi3Warning (or an instantiation returned NULL); a
    :class:`~harness.fmi.instance.CallFailed`, so a rule of both versions catches one exception."""

    def __init__(self, call: str, instance: str, status: int | None, message: str = ""):
        self.call, self.instance, self.status, self.message = call, instance, status, message
        Exception.__init__(self, f"{call} [instance {instance}] returned {status3(status)}"
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

    fmi, REAL = "fmi3", "Float64"
    status_label = staticmethod(status3)

    def __init__(self, payload: dict, trace: Callable[[str], None], kind: str = "cs3"):
        from fmpy import read_model_description
        self.payload, self.unzipdir, self.trace, self.kind = payload, payload["unzipdir"], trace, kind
        self.steps = max(2, int(payload.get("steps", 10)))
        self.md = read_model_description(self.unzipdir, validate=False)
        self.cs, self.me = self.md.coSimulation, self.md.modelExchange
        import xml.etree.ElementTree as ET   # fmpy does not read FMI 3.0's providesDirectionalDerivatives (plural)
        root = ET.parse(f"{self.unzipdir}/modelDescription.xml").getroot()
        for iface, tag in ((self.cs, "CoSimulation"), (self.me, "ModelExchange")):
            el = root.find(tag)
            if iface is not None and el is not None:
                iface.providesDirectionalDerivative = el.get("providesDirectionalDerivatives") in ("true", "1")
        self.iface = self.cs if kind == "cs3" else self.me
        de = self.md.defaultExperiment
        self.t0 = float(de.startTime) if de is not None and de.startTime is not None else 0.0
        step = float(de.stepSize) if de is not None and de.stepSize is not None else 0.0
        self.h = step if step > 0 else DEFAULT_STEP_SIZE
        self.t_stop = float(de.stopTime) if de is not None and de.stopTime is not None else self.t0 + 1.0
        tol = float(de.tolerance) if de is not None and de.tolerance is not None else 0.0
        self.tolerance = tol if tol > 0 else DEFAULT_TOLERANCE
        self.variables = list(self.md.modelVariables)
        self.by_vr = {v.valueReference: v for v in self.variables}
        self.by_name = {v.name: v for v in self.variables}
        self.start_vars = [v for v in self.variables if v.causality in ("parameter", "input")
                           and v.variability != "constant" and v.type in NUMERIC + ("String",)
                           and v.start is not None and not getattr(v, "clocks", None)]
        self.start_values = {v.name: self.value_of(v) for v in self.start_vars}
        # inputs are set in Initialization Mode (as in FMI 2.0), the other start values in Instantiated
        self.early_values = {v.name: x for v, x in zip(self.start_vars, self.start_values.values())
                             if v.causality != "input"}
        self.inputs = [v for v in self.start_vars if v.causality == "input"]
        self.real_inputs = [v for v in self.inputs if v.type == "Float64" and self.size(v) == 1]
        self.outputs = [v for v in self.variables if v.causality == "output" and v.type in NUMERIC
                        and not getattr(v, "clocks", None)]
        self.columns = [f"{v.name}[{k}]" if self.size(v) > 1 else v.name
                        for v in self.outputs for k in range(self.size(v))]
        self.real_columns = [j for j, v in enumerate(self.outputs) if v.type == "Float64" and self.size(v) == 1]
        if len(self.columns) != len(self.outputs):   # arrays among the outputs: column of each scalar Float64
            cols, j = [], 0
            for v in self.outputs:
                if v.type == "Float64" and self.size(v) == 1:
                    cols.append(j)
                j += self.size(v)
            self.real_columns = cols
        self.log_categories = [c.name if hasattr(c, "name") else str(c) for c in (self.md.logCategories or [])]
        self._n = 0

    def is_real(self, v) -> bool:
        return v.type == "Float64" and self.size(v) == 1

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

    def value_of(self, v) -> Any:
        """The start value of a scalar, the list of an array's."""
        vals = self.values_of(v)
        return vals[0] if len(vals) == 1 and self.size(v) == 1 else vals

    def input_values(self) -> dict[str, Any]:
        return {v.name: self.start_values[v.name] for v in self.inputs}

    def instance(self, name: str, token: str | None = None, guid: str | None = None) -> "Instance3":
        self._n += 1
        return Instance3(self, name, ENV_BASE + 16 * self._n, token if token is not None else guid)


class Instance3(SharedCalls):
    """One FMU instance of the session (co-simulation or model exchange as the session says)."""

    def __init__(self, s: Session3, name: str, env: int, token: str | None = None):
        from fmpy.fmi3 import FMU3Model, FMU3Slave
        self.s, self.name, self.env, self.messages = s, name, env, []
        self.updates: list[tuple[int, float]] = []    # (instanceEnvironment, intermediateUpdateTime) per call
        self._stop: float | None = None
        s.trace(f"loading the binary [instance {name}]")
        cls = FMU3Slave if s.kind == "cs3" else FMU3Model
        self.fmu = cls(guid=token if token is not None else s.md.guid, unzipDirectory=s.unzipdir,
                       modelIdentifier=s.iface.modelIdentifier, instanceName=name)
        self.slave = self.fmu

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
            env = int(env or 0)
            if env != self.env:
                LOGGER_VIOLATIONS.append(f"instanceEnvironment {env:#x} instead of {self.env:#x} given to "
                                         f"fmi3Instantiate (instance {self.name}, message {text[:80]!r})")
            self.messages.append((int(status), text))
        except Exception:
            pass

    def _update(self, env, t, set_requested, get_allowed, step_finished, can_return_early, early_requested,
                early_time) -> None:
        try:
            self.updates.append((int(env or 0), float(t)))
        except Exception:
            pass

    def instantiate(self, raise_on_null: bool = True, early_return: bool = False, event_mode: bool = False) -> bool:
        """fmi3Instantiate{CoSimulation, ModelExchange} with logging on and this instance's instanceEnvironment
        (co-simulation: an intermediate update callback recording its calls)."""
        import os
        from fmpy.fmi3 import fmi3IntermediateUpdateCallback, fmi3LogMessageCallback, fmi3ValueReference
        cs = self.s.kind == "cs3"
        self.s.trace(f"fmi3Instantiate{'CoSimulation' if cs else 'ModelExchange'}"
                     f"{'(earlyReturnAllowed)' if early_return else ''}{'(eventModeUsed)' if event_mode else ''} "
                     f"[instance {self.name}]")
        self._callbacks = (fmi3LogMessageCallback(self._log), fmi3IntermediateUpdateCallback(self._update))
        self.fmu.logMessage = self._callbacks[0]
        res = (os.path.join(self.s.unzipdir, "resources") + os.path.sep).encode()
        common = (self.name.encode(), self.fmu.guid.encode(), res, False, True)
        if cs:
            comp = self.fmu.fmi3InstantiateCoSimulation(*common, event_mode, early_return, (fmi3ValueReference * 0)(),
                                                        0, c_void_p(self.env), *self._callbacks)
        else:
            comp = self.fmu.fmi3InstantiateModelExchange(*common, c_void_p(self.env), self._callbacks[0])
        if not comp:
            if raise_on_null:
                raise Call3Failed("fmi3Instantiate", self.name, None, self.last_message())
            return False
        self.fmu.component = comp
        return True

    def set_values(self, values: dict[str, Any], label: str = "") -> None:
        """Set variables by name (an array's value: the list of its elements), one fmi3Set{Type} per variable."""
        for name, value in values.items():
            v = self.s.by_name[name]
            t = api_type(v)
            self.call(f"fmi3Set{t}({v.name}){label}", getattr(self.fmu, f"set{t}"), [v.valueReference],
                      value if isinstance(value, list) else [value])

    def set_status(self, name: str, value: Any) -> int:
        v = self.s.by_name[name]
        t = api_type(v)
        return self.status(f"fmi3Set{t}({v.name} = {value!r})", getattr(self.fmu, f"set{t}"), [v.valueReference],
                           value if isinstance(value, list) else [value])

    def setup(self, stop_time: float | None = None) -> None:
        """Remembers the stop time for fmi3EnterInitializationMode (FMI 3.0 has no fmi3SetupExperiment)."""
        self._stop = stop_time

    def enter_init(self) -> None:
        stop = self._stop
        label = f"fmi3EnterInitializationMode(startTime={self.s.t0:g}" + (
            f", stopTime={stop:g})" if stop is not None else ")")
        self.call(label, self.fmu.enterInitializationMode, None, self.s.t0, stop)

    def read(self, variables: Sequence, label: str) -> list[float]:
        """The values of ``variables`` (arrays flattened), as floats, in the given order."""
        row: list[float] = []
        for v in variables:
            t = api_type(v)
            vals = self.call(f"fmi3Get{t}({label})", getattr(self.fmu, f"get{t}"), [v.valueReference], self.s.size(v))
            row += [float(x) for x in vals]
        return row

    def step_status(self, t: float, h: float) -> int:
        return self.status(f"fmi3DoStep(t={t:.9g}, h={h:.9g})", self.fmu.doStep, t, h, True)

    def step_result(self, t: float, h: float) -> tuple[int, bool]:
        """fmi3DoStep: (its status, terminateSimulation)."""
        from fmpy.fmi1 import FMICallException
        self.s.trace(f"fmi3DoStep(t={t:.9g}, h={h:.9g}) [instance {self.name}]")
        try:
            return 0, bool(self.fmu.doStep(t, h, True)[1])
        except FMICallException as e:
            return int(e.status), False

    def do_step(self, t: float, h: float) -> None:
        out = self.call(f"fmi3DoStep(t={t:.9g}, h={h:.9g})", self.fmu.doStep, t, h, True)
        if out and out[1]:   # terminateSimulation
            raise Call3Failed(f"fmi3DoStep(t={t:.9g}, h={h:.9g}) asked to terminate", self.name, 0,
                              self.last_message())

    def run(self, t: float, steps: Sequence[float] | int, inputs: dict[str, Any] | None = None):
        """Outputs now, then for each step: set inputs, doStep, read outputs. Returns (rows, t_end)."""
        sizes = [self.s.h] * steps if isinstance(steps, int) else list(steps)
        inputs = inputs if inputs is not None else self.s.input_values()
        rows = [self.outputs()]
        t_start, whole = t, isinstance(steps, int)
        for i, h in enumerate(sizes):
            if inputs:
                self.set_values(inputs)
            t_now, t_next = (t_start + i * h, t_start + (i + 1) * h) if whole else (t, t + h)
            self.do_step(t_now, t_next - t_now)
            t = t_next
            rows.append(self.outputs())
        return rows, t

    def terminate(self) -> None:
        self.call("fmi3Terminate", self.fmu.terminate)

    def free(self) -> None:
        self.s.trace(f"fmi3FreeInstance [instance {self.name}]")
        self.fmu.fmi3FreeInstance(self.fmu.component)

    # ------------------------------------------------------------------ the calls the rules share with FMI 2.0
    def fn(self, name: str):
        """The FMU's function for the FMI 2.0 name ``name`` (e.g. "GetFMUstate" is fmi3GetFMUState)."""
        return getattr(self.fmu, "fmi3" + name.replace("FMUstate", "FMUState").replace("DeSerialize", "Deserialize"))

    def set_debug_logging(self, on: bool, categories: list[str]) -> int:
        from fmpy.fmi3 import fmi3String
        arr = (fmi3String * max(1, len(categories)))(*[c.encode() for c in categories])
        label = f"fmi3SetDebugLogging({'on' if on else 'off'}, {len(categories)} categories)"
        return self.status(label, self.fmu.fmi3SetDebugLogging, self.fmu.component, 1 if on else 0,
                           len(categories), arr)


def first_difference3(s: Session3, a: list[list[float]], b: list[list[float]], start: str = "after initialization"):
    """None when the two output trajectories are the same (rounding only), else where they first differ."""
    return first_difference(s, a, b, start)


__all__ = ["Session3", "Instance3", "Call3Failed", "status3", "REFUSED3", "WRONG_TOKEN", "first_difference3",
           "finite"]
