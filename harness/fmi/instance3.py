"""One FMI 3.0 co-simulation instance behind the FMI 2.0 :class:`~harness.fmi.instance.Instance` API,
so the master, the sweep pool and the tests run an FMI 3.0 FMU (``NAME-fmi3.fmu``) unchanged.

:func:`open_instance` returns an :class:`Instance3` for an FMI 3.0 FMU, else an ``Instance``. An
``Instance3`` holds an :class:`fmpy.fmi3.FMU3Slave` in :class:`Slave3`, which answers the FMI 2.0
calls the harness makes (``setupExperiment`` + ``enterInitializationMode`` become
``fmi3EnterInitializationMode``; ``getReal`` is ``fmi3GetFloat64``, ``getInteger`` ``fmi3GetInt32``...),
and :meth:`Instance3.c_function` hands out the FMI 3.0 C functions with the FMI 2.0 signature the
harness calls them with (``fmi2DoStep(c, t, h, nsp)`` is ``fmi3DoStep`` with its four output
arguments kept here; a getter or setter gets ``nValues = nValueReferences``). The variables'
types read as FMI 2.0's (Float64 is Real, Int32 Integer: :func:`harness.fmi.instance.fmi2_type_names`);
the independent variable ``time`` is left out of ``vars``.

The FMU is instantiated with ``eventModeUsed`` and ``earlyReturnAllowed`` false: the FMI 2.0
semantics, whose results an FMI 3.0 run must reproduce to the last bit. The FMI 3.0 master
(:mod:`harness.run.master3`) asks for early return (``early_return=True``: ``last_step`` then says
where a step ended) and reads output derivatives (:meth:`Instance3.output_derivatives`).
"""
from __future__ import annotations

from ctypes import byref, c_bool, c_double, c_size_t
from pathlib import Path
from typing import Callable

from harness.fmi.instance import CallFailed, Instance, _no_trace, fmu_cache

# the FMI 2.0 function the harness calls -> the FMI 3.0 one
FUNCTIONS3 = {"fmi2GetReal": "fmi3GetFloat64", "fmi2SetReal": "fmi3SetFloat64",
              "fmi2GetInteger": "fmi3GetInt32", "fmi2SetInteger": "fmi3SetInt32",
              "fmi2GetBoolean": "fmi3GetBoolean", "fmi2SetBoolean": "fmi3SetBoolean",
              "fmi2GetString": "fmi3GetString", "fmi2SetString": "fmi3SetString"}


def is_fmi3(md) -> bool:
    return str(getattr(md, "fmiVersion", "")).startswith("3")


def open_instance(name: str, fmu_file: Path | str, **kwargs) -> Instance:
    """An :class:`Instance3` for an FMI 3.0 FMU, an :class:`Instance` for an FMI 2.0 one."""
    unzipdir, md = fmu_cache().get(Path(fmu_file))
    cls = Instance3 if is_fmi3(md) else Instance
    return cls(name, unzipdir=unzipdir, md=md, **kwargs)


class Slave3:
    """An :class:`fmpy.fmi3.FMU3Slave` answering the FMI 2.0 calls of fmpy's ``FMU2Slave`` the
    harness makes; anything else is the FMU3Slave's own (``dll``, ``component``, ``doStep``...)."""

    def __init__(self, fmu3):
        self._fmu = fmu3
        self._experiment = (None, 0.0, None)   # tolerance, start, stop

    def __getattr__(self, name):
        return getattr(self._fmu, name)

    def setupExperiment(self, tolerance=None, startTime=0.0, stopTime=None):
        self._experiment = (tolerance, startTime, stopTime)

    def enterInitializationMode(self):
        tol, start, stop = self._experiment
        return self._fmu.enterInitializationMode(tolerance=tol, startTime=start, stopTime=stop)

    def getReal(self, vr):
        return self._fmu.getFloat64(vr)

    def setReal(self, vr, values):
        return self._fmu.setFloat64(vr, values)

    def getInteger(self, vr):
        return self._fmu.getInt32(vr)

    def setInteger(self, vr, values):
        return self._fmu.setInt32(vr, values)

    def doStep(self, currentCommunicationPoint, communicationStepSize, noSetFMUStatePriorToCurrentPoint=True):
        self._fmu.doStep(currentCommunicationPoint, communicationStepSize, noSetFMUStatePriorToCurrentPoint)


class Instance3(Instance):
    """An FMI 3.0 co-simulation instance with :class:`Instance`'s API (see the module docstring)."""

    def __init__(self, name: str, fmu_file: Path | str | None = None, *, unzipdir: str | None = None, md=None,
                 kind: str = "cs", guid: str | None = None, trace: Callable[[str], None] | None = None,
                 instantiate: bool = True, early_return: bool = False):
        from fmpy.fmi3 import FMU3Slave

        if kind != "cs":
            raise ValueError("an FMI 3.0 instance of the harness is co-simulation only")
        if fmu_file is not None:
            unzipdir, md = fmu_cache().get(Path(fmu_file))
        self.name, self.md, self.unzipdir, self.kind = name, md, unzipdir, kind
        self.vars = {v.name: v for v in md.modelVariables if v.causality != "independent"}
        self.messages: list[tuple[int, str]] = []
        self.trace = trace or _no_trace
        self.trace(f"loading the binary [instance {name}]")
        self.slave = Slave3(FMU3Slave(guid=guid if guid is not None else md.guid, unzipDirectory=unzipdir,
                                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name))
        self._callbacks = None
        self._c: dict[str, Callable] = {}
        self.last_step = (False, False, False, 0.0)   # eventHandlingNeeded, terminateSimulation, earlyReturn, lastSuccessfulTime
        if instantiate:
            self.instantiate(early_return=early_return)

    def instantiate(self, logger=None, environment: int | None = None, format_messages: bool = False,
                    raise_on_null: bool = True, early_return: bool = False) -> bool:
        """fmi3InstantiateCoSimulation with logging on (``logger``: an fmi3LogMessageCallback
        function; default: one that appends to ``messages``)."""
        sink = self.messages

        def log(env, status, category, message):
            text = message.decode("utf-8", "replace") if isinstance(message, bytes) else str(message)
            sink.append((int(status), text))

        self.trace(f"fmi3InstantiateCoSimulation [instance {self.name}]")
        try:
            self.slave._fmu.instantiate(visible=False, loggingOn=True, eventModeUsed=False,
                                        earlyReturnAllowed=early_return, logMessage=logger or log)
        except Exception:
            if raise_on_null:
                raise CallFailed("fmi3InstantiateCoSimulation", self.name, None, self.last_message()) from None
            return False
        self._callbacks = self.slave._fmu.logMessage
        return True

    def terminate(self) -> None:
        self.call("fmi3Terminate", self.slave.terminate)

    def c_function(self, name: str):
        """The FMI 3.0 C function behind the FMI 2.0 ``name`` the harness calls, with the FMI 2.0
        signature (returns the status, never raises)."""
        fn = self._c.get(name)
        if fn is None:
            fn = self._c[name] = self._make(name)
        return fn

    fast_function = c_function

    def _make(self, name: str) -> Callable:
        dll = self.slave._fmu.dll
        if name == "fmi2DoStep":
            c_step = dll.fmi3DoStep
            ev, term, early, last = c_bool(), c_bool(), c_bool(), c_double()
            outs = (byref(ev), byref(term), byref(early), byref(last))

            def do_step(component, t, h, nsp):
                status = c_step(component, t, h, bool(nsp), *outs)
                self.last_step = (ev.value, term.value, early.value, last.value)
                return status
            return do_step
        if name not in FUNCTIONS3:
            raise KeyError(f"{name} has no FMI 3.0 counterpart in harness.fmi.instance3")
        c_fn = getattr(dll, FUNCTIONS3[name])
        if name in ("fmi2GetBoolean", "fmi2SetBoolean"):   # fmi2Boolean is int, fmi3Boolean bool
            get = name == "fmi2GetBoolean"

            def booleans(component, vr, n, values):
                count = n.value if isinstance(n, c_size_t) else int(n)
                arr = (c_bool * count)(*([] if get else [bool(x) for x in values[:count]]))
                status = c_fn(component, vr, count, arr, count)
                if get:
                    for i in range(count):
                        values[i] = 1 if arr[i] else 0
                return status
            return booleans

        def values_call(component, vr, n, values):
            return c_fn(component, vr, n, values, n)
        return values_call

    @property
    def max_output_derivative_order(self) -> int:
        return int(self.md.coSimulation.maxOutputDerivativeOrder or 0)

    @property
    def might_return_early(self) -> bool:
        return bool(self.md.coSimulation.mightReturnEarlyFromDoStep)

    def output_derivatives(self, vrs: list[int], fail: Callable[[str], None] | None = None) -> Callable[[], list]:
        """A function returning the first derivatives of the Float64 outputs ``vrs`` now
        (fmi3GetOutputDerivatives with its arrays made once); a refusal calls ``fail(reason)``
        (default: raises :class:`CallFailed`)."""
        from ctypes import c_double, c_int32, c_uint32

        n = len(vrs)
        refs, orders, values = (c_uint32 * n)(*vrs), (c_int32 * n)(*([1] * n)), (c_double * n)()
        fn, comp = self.slave._fmu.dll.fmi3GetOutputDerivatives, self.component

        def read() -> list:
            status = fn(comp, refs, n, orders, values, n)
            if status > 1:
                if fail is not None:
                    fail(self.last_message())
                raise CallFailed("fmi3GetOutputDerivatives", self.name, status, self.last_message())
            return values[:]
        return read

    def step_status(self, t: float, h: float) -> int:
        return self.status(f"fmi3DoStep(t={t:.9g}, h={h:.9g})", self.c_function("fmi2DoStep"), self.component, t, h, 1)

    def do_step(self, t: float, h: float) -> None:
        self.call(f"fmi3DoStep(t={t:.9g}, h={h:.9g})", self.slave.doStep, t, h)
