"""One FMU instance on fmpy's FMI 2.0 API, with its status handling: the only wrapper around
:class:`fmpy.fmi2.FMU2Slave` (co-simulation) and :class:`fmpy.fmi2.FMU2Model` (model exchange).
The master, the compliance checks, the sweep pool and the tests use it.

* Messages: every instance collects what its FMU logs as (status, text) in ``messages``, through a
  logger callback of its own (fmpy's logger proxy keeps one logger per process, so messages would
  reach the last instance created), or through a logger the caller gives (the compliance checks
  use one per process and tell instances apart by ``componentEnvironment``).
* Status: :meth:`Instance.call` turns a refused call (a status above fmi2Warning, fmpy's
  :class:`~fmpy.fmi1.FMICallException`) into :class:`CallFailed` naming the call, the instance and
  the FMU's last message; :meth:`Instance.status` calls a function and returns its status instead.
  :meth:`Instance.c_function` is the C function itself (ctypes, argument types set by fmpy);
  :meth:`Instance.fast_function` the same C function for loops that call it many times
  (:class:`Port`, the master's fmi2DoStep), with its arguments converted once by the caller.
* Tracing: ``trace`` (a callable taking one line) sees every call before it is made, so a crash
  report can name the call the FMU died in.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Callable, Sequence

from harness.common import scratch
from harness.fmi import fmpy_logging

STATUS_LABELS = ("fmi2OK", "fmi2Warning", "fmi2Discard", "fmi2Error", "fmi2Fatal", "fmi2Pending")
REFUSED = (2, 3, 4)  # discard, error, fatal
SETTERS = {"Real": "setReal", "Integer": "setInteger", "Boolean": "setBoolean", "String": "setString"}
GETTERS = {"Real": "getReal", "Integer": "getInteger", "Boolean": "getBoolean"}


def status_label(status: int | None) -> str:
    if status is None:
        return "no status"
    return STATUS_LABELS[status] if 0 <= status < len(STATUS_LABELS) else f"illegal status {status}"


def value_kind(type_: str) -> str:
    """The FMI function family of a variable type (an Enumeration is set and read as an Integer)."""
    return "Integer" if type_ == "Enumeration" else type_


class CallFailed(Exception):
    """An FMI call returned a status above fmi2Warning (or fmi2Instantiate returned NULL)."""

    def __init__(self, call: str, instance: str, status: int | None, message: str = ""):
        self.call, self.instance, self.status, self.message = call, instance, status, message
        text = f"{call} [instance {instance}] returned {status_label(status) if status is not None else 'NULL'}"
        super().__init__(text + (f': FMU says "{message}"' if message else ""))


# FMI 3.0 variable types under the FMI 2.0 names the harness uses (harness.fmi.instance3)
TYPES_AS_FMI2 = {"Float64": "Real", "Int32": "Integer"}


def fmi2_type_names(md):
    """``md`` with an FMI 3.0 FMU's Float64 and Int32 variables typed Real and Integer (in place)."""
    if str(getattr(md, "fmiVersion", "")).startswith("3"):
        for v in md.modelVariables:
            v.type = TYPES_AS_FMI2.get(v.type, v.type)
    return md


class FmuCache:
    """Extracts each FMU file once per process and keeps its model description, in a scratch folder
    of this process (``spurdiff_fmus_*`` in the temporary directory, :mod:`harness.common.scratch`);
    making one removes those of processes that ended without removing theirs (killed)."""

    PREFIX = "spurdiff_fmus_"

    def __init__(self, root: Path | str | None = None):
        self._dirs: dict[Path, tuple[str, Any]] = {}
        self._scratch = scratch.process_folder(self.PREFIX, root)
        self._tmp = self._scratch.path

    def get(self, path: Path):
        from fmpy import extract, read_model_description

        path = Path(path).resolve()
        key = (path, path.stat().st_mtime_ns)
        if key not in self._dirs:
            target = self._tmp / f"{path.stem}_{len(self._dirs)}"
            d = extract(str(path), unzipdir=str(target))
            self._dirs[key] = (d, fmi2_type_names(read_model_description(d)))
        return self._dirs[key]

    def cleanup(self) -> None:
        self._scratch.remove()


_CACHE: FmuCache | None = None


def fmu_cache() -> FmuCache:
    """The process-wide cache of extracted FMUs (removed at interpreter exit)."""
    global _CACHE
    if _CACHE is None:
        import atexit
        _CACHE = FmuCache()
        atexit.register(_CACHE.cleanup)
    return _CACHE


def make_logger(sink: list):
    """A C logger callback collecting (status, message) into ``sink``."""
    from fmpy.fmi2 import fmi2CallbackLoggerTYPE

    def logger(componentEnvironment, instanceName, status, category, message):
        text = message.decode("utf-8", "replace") if isinstance(message, bytes) else str(message)
        sink.append((int(status), text.replace("%%", "%")))  # pythonfmu escapes '%' (printf format)
    return fmi2CallbackLoggerTYPE(logger)


def _no_trace(text: str) -> None:
    pass


class Instance:
    """One FMU instance: the fmpy object (``slave``), its variables and the messages it logged.

    ``Instance(name, fmu_file)`` extracts the FMU once per process (:func:`fmu_cache`) and
    instantiates at once with a logger of its own; ``unzipdir`` and ``md`` instead name an FMU
    already extracted, ``kind = "me"`` loads its model-exchange interface, ``guid`` overrides the
    model description's, and ``instantiate = False`` leaves :meth:`instantiate` to the caller."""

    def __init__(self, name: str, fmu_file: Path | str | None = None, *, unzipdir: str | None = None, md=None,
                 kind: str = "cs", guid: str | None = None, trace: Callable[[str], None] | None = None,
                 instantiate: bool = True):
        from fmpy.fmi2 import FMU2Model, FMU2Slave

        if fmu_file is not None:
            unzipdir, md = fmu_cache().get(Path(fmu_file))
        self.name, self.md, self.unzipdir, self.kind = name, md, unzipdir, kind
        self.vars = {v.name: v for v in md.modelVariables}
        self.messages: list[tuple[int, str]] = []
        self.trace = trace or _no_trace
        iface = md.coSimulation if kind == "cs" else md.modelExchange
        self.trace(f"loading the binary [instance {name}]")
        cls = FMU2Slave if kind == "cs" else FMU2Model
        self.slave = cls(guid=guid if guid is not None else md.guid, unzipDirectory=unzipdir,
                         modelIdentifier=iface.modelIdentifier, instanceName=name)
        self._callbacks = None
        if instantiate:
            self.instantiate()

    # ------------------------------------------------------------------ lifecycle
    def instantiate(self, logger=None, environment: int | None = None, format_messages: bool = False,
                    raise_on_null: bool = True) -> bool:
        """fmi2Instantiate with logging on. ``logger``: a C logger callback (default: one that
        appends to ``messages``); ``environment``: the componentEnvironment pointer value;
        ``format_messages``: let fmpy format printf-style messages in C before the logger sees
        them. False when the FMU returned NULL and ``raise_on_null`` is False."""
        from ctypes import c_void_p

        from fmpy import calloc, free
        from fmpy.fmi2 import fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE, fmi2CallbackFunctions

        cb = fmi2CallbackFunctions()
        cb.logger = logger if logger is not None else make_logger(self.messages)
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        if environment is not None:
            cb.componentEnvironment = c_void_p(environment)
        self._proxied = format_messages and fmpy_logging.use_proxy(cb)
        self._callbacks = cb  # keep the C callbacks alive as long as the instance
        self.trace(f"fmi2Instantiate [instance {self.name}]")
        try:
            self.slave.instantiate(visible=False, callbacks=cb, loggingOn=True)
        except Exception:
            if raise_on_null:
                raise CallFailed("fmi2Instantiate", self.name, None, self.last_message()) from None
            return False
        return True

    def terminate(self) -> None:
        self.call("fmi2Terminate", self.slave.terminate)

    def free(self) -> None:
        self.trace(f"fmi2FreeInstance [instance {self.name}]")
        self.slave.freeInstance()
        self._unproxy()

    def _unproxy(self) -> None:
        if getattr(self, "_proxied", False):
            fmpy_logging.restore_default()     # fmpy's one process-wide proxy target
            self._proxied = False

    def close(self) -> None:
        """Terminate (if the state allows) and free, ignoring refusals: the end of any run."""
        for call in (self.slave.terminate, self.slave.freeInstance):
            try:
                call()
            except Exception:
                pass
        self._unproxy()

    # ------------------------------------------------------------------ calls and statuses
    def call(self, label: str, fn: Callable, *args):
        """Trace, call, and turn fmpy's FMICallException into :class:`CallFailed`."""
        from fmpy.fmi1 import FMICallException

        self.trace(f"{label} [instance {self.name}]")
        try:
            return fn(*args)
        except FMICallException as e:
            raise CallFailed(label, self.name, e.status, self.last_message()) from None

    def status(self, label: str, fn: Callable, *args) -> int:
        """Trace and call an fmi2XXX function; its status (no exception)."""
        from fmpy.fmi1 import FMICallException

        self.trace(f"{label} [instance {self.name}]")
        try:
            return int(fn(*args))
        except FMICallException as e:
            return int(e.status)

    def c_function(self, name: str):
        """The FMU's C function ``name`` (e.g. "fmi2DoStep") as fmpy declared it: returns the
        status and never raises; the first argument is :attr:`component`."""
        return getattr(self.slave.dll, name)

    def fast_function(self, name: str):
        """The FMU's C function ``name`` for a stepping loop: the same function as
        :meth:`c_function`, called with arguments the caller converted once (``c_component``, a
        ``c_size_t``, C arrays, ``c_double`` objects; plain ``int`` for ``fmi2Boolean``), so ctypes
        converts nothing per call (fmpy's argument types cost about 0.5 us per call), and without
        releasing the GIL around the call (a Python FMU takes it back at once; the host's other
        threads still run while the FMU runs Python). Returns the status (never raises)."""
        from ctypes import PYFUNCTYPE, c_int, cast, c_void_p

        fn = PYFUNCTYPE(c_int)(cast(self.c_function(name), c_void_p).value)
        fn._keep = self.slave.dll   # the library stays loaded as long as the function is used
        return fn

    @property
    def component(self):
        return self.slave.component

    @property
    def c_component(self):
        """The component pointer as a ``c_void_p`` (for :meth:`fast_function`)."""
        from ctypes import c_void_p

        return c_void_p(self.slave.component)

    def step_status(self, t: float, h: float) -> int:
        """fmi2DoStep (noSetFMUStatePriorToCurrentPoint) returning its status instead of raising."""
        return self.status(f"fmi2DoStep(t={t:.9g}, h={h:.9g})", self.c_function("fmi2DoStep"), self.component, t, h, 1)

    def do_step(self, t: float, h: float) -> None:
        self.call(f"fmi2DoStep(t={t:.9g}, h={h:.9g})", self.slave.doStep, t, h)

    # ------------------------------------------------------------------ variables
    def var(self, name: str):
        try:
            return self.vars[name]
        except KeyError:
            from harness.scene.schema import SceneError
            raise SceneError(f"{self.name}: FMU has no variable {name!r}") from None

    def set_value(self, name: str, value) -> None:
        """Set one variable, ``value`` converted by its FMI type as a scene's values are
        (:func:`harness.scene.schema.parameter_value`: 'off' is false; inf and NaN pass, for the FMU to refuse)."""
        from harness.scene.schema import SceneError, parameter_value

        v = self.var(name)
        value = parameter_value(f"{self.name}.{name}", v.type, value, finite=False)
        if v.type in ("Integer", "Enumeration") and isinstance(value, float) and not value.is_integer():
            raise SceneError(f"{self.name}.{name} = {value!r}: allowed an integer")
        kind = value_kind(v.type)
        if kind in SETTERS:
            cast = {"Real": float, "Integer": int, "Boolean": bool, "String": str}[kind]
            getattr(self.slave, SETTERS[kind])([v.valueReference], [cast(value)])

    def set_values(self, values: dict[str, Any], label: str = "") -> None:
        """Set variables by name as given, batched per type (one traced fmi2SetXXX call per type)."""
        groups: dict[str, tuple[list[int], list[Any], list[str]]] = {}
        for name, value in values.items():
            v = self.vars[name]
            vrs, vals, names = groups.setdefault(value_kind(v.type), ([], [], []))
            vrs.append(v.valueReference)
            vals.append(value)
            names.append(name)
        for kind, (vrs, vals, names) in groups.items():
            self.call(f"fmi2Set{kind}({', '.join(names)}){label}", getattr(self.slave, SETTERS[kind]), vrs, vals)

    def set_status(self, name: str, value: Any) -> int:
        """Set one variable through its C function and return the status (no exception)."""
        from ctypes import c_char_p

        from fmpy.fmi2 import fmi2Boolean, fmi2Integer, fmi2Real, fmi2ValueReference

        v = self.vars[name]
        kind = value_kind(v.type)
        vr = (fmi2ValueReference * 1)(v.valueReference)
        arr = {"Real": lambda: (fmi2Real * 1)(value), "Integer": lambda: (fmi2Integer * 1)(value),
               "Boolean": lambda: (fmi2Boolean * 1)(1 if value else 0),
               "String": lambda: (c_char_p * 1)(str(value).encode())}[kind]()
        return self.status(f"fmi2Set{kind}({name} = {value!r})", self.c_function(f"fmi2Set{kind}"),
                           self.component, vr, 1, arr)

    def read(self, variables: Sequence, label: str) -> list[float]:
        """Values of Real/Integer/Enumeration/Boolean ``variables`` as floats, in the given order."""
        by_kind: dict[str, list] = {}
        for i, v in enumerate(variables):
            by_kind.setdefault(value_kind(v.type), []).append((i, v.valueReference))
        row = [math.nan] * len(variables)
        for kind, items in by_kind.items():
            if kind not in GETTERS:
                continue
            vals = self.call(f"fmi2Get{kind}({label})", getattr(self.slave, GETTERS[kind]), [vr for _, vr in items])
            for (i, _), x in zip(items, vals):
                row[i] = float(x)
        return row

    # ------------------------------------------------------------------ messages
    def errors(self) -> list[str]:
        return [m for s, m in self.messages if s >= 3]  # fmi2Error, fmi2Fatal

    def last_messages(self, n: int = 3) -> str:
        """The last ``n`` warnings or worse (else the last messages) joined, or 'no message logged'."""
        errs = [m for s, m in self.messages if s >= 2] or [m for _, m in self.messages]
        return "; ".join(errs[-n:]) if errs else "no message logged"

    def last_message(self) -> str:
        """The last warning or worse (else the last message) on one line, at most 300 characters."""
        bad = [m for st, m in self.messages if st >= 1]
        text = (bad or [m for _, m in self.messages] or [""])[-1]
        return " ".join(text.split())[:300]


class Port:
    """fmi2Get/fmi2Set of one type (Real, Integer, Boolean) on a fixed list of value references,
    with the C arrays and every other argument converted once: a stepping loop calls the FMU's C
    function directly (:meth:`Instance.fast_function`; fmpy's wrappers convert lists to new arrays
    on every call). A status above warning calls ``fail(reason, t)``, which raises."""

    def __init__(self, inst: Instance, vrs: list[int], write: bool, fail: Callable[[str, float], None],
                 kind: str = "Real"):
        from ctypes import c_size_t

        from fmpy.fmi2 import fmi2Boolean, fmi2Integer, fmi2Real, fmi2ValueReference

        self.inst, self.n, self.fail = inst, len(vrs), fail
        self.vr = (fmi2ValueReference * self.n)(*vrs)
        self.val = ({"Real": fmi2Real, "Integer": fmi2Integer, "Boolean": fmi2Boolean}[kind] * self.n)()
        self.what = f"fmi2{'Set' if write else 'Get'}{kind}"
        self.fn = inst.fast_function(self.what)
        self.component = inst.c_component
        self.args = (self.component, self.vr, c_size_t(self.n), self.val)   # the call's arguments, converted once
        self.last = None   # values of the last set: inputs keep their values, an unchanged set is skipped

    def _failed(self, status: int, t: float) -> None:
        self.fail(f"{self.what} returned status {status}: {self.inst.last_messages()}", t)

    def set(self, values, t: float = math.nan) -> None:
        """Set ``values`` (a list or tuple, compared with the last set by value)."""
        if values == self.last:   # (call forget() after fmi2SetFMUstate, which restores old inputs)
            return
        self.val[:] = values
        status = self.fn(*self.args)
        if status > 1:
            self._failed(status, t)
        self.last = values

    def forget(self) -> None:
        self.last = None

    def get(self, t: float = math.nan) -> list:
        status = self.fn(*self.args)
        if status > 1:
            self._failed(status, t)
        return self.val[:]


RealPort = Port   # the master's name for its ports on Reals
