"""Thin adapter between FMI 2.0 co-simulation and the project's physics models.

An FMU script declares its interface as a list of :class:`Var` (name, causality, variability,
unit, display unit, description, start value, direct dependencies) and maps it onto a physics
model from this package. The same list drives

* the variables pythonfmu registers (value references in list order),
* the build-time post-processing of modelDescription.xml (units, display units, unit
  definitions, Outputs with dependencies, InitialUnknowns; see ``harness/modeldescription.py``).

The FMU's binary is our own bridge (``fmu_src/native``), not pythonfmu's wrapper: it calls the
``fmi2_*`` methods below, one per FMI function, and takes their return value as the status
(``None`` is fmi2OK). So every refusal has the status the standard asks for, the instance
stays usable after it, and nothing here needs to raise. The FMI state machine (FMI 2.0
section 4.2.4) is tracked in ``phase``:

``instantiated`` -> ``initializing`` -> ``stepping`` -> ``terminated``, and ``error`` after an
initialization that failed (only fmi2Reset and fmi2FreeInstance help then).

* Parameters and inputs are validated in fmi2ExitInitializationMode (fmi2Error, with the logged
  reason naming the variable and its allowed range); outputs and calculated parameters read
  in initialization mode are computed from the values set so far (FMI 2.0 section 2.2.7,
  InitialUnknowns).
* fmi2DoStep refuses a step past a defined stop time with fmi2Error (section 2.1.6), and with
  fmi2Discard (state kept at the last successful time, logged reason) a
  communication point that is not the FMU's time, an input
  that is not finite or outside its declared range (``Var.min``/``max``, also in
  modelDescription.xml), and a step whose result is not finite.
* get/set FMU state carry the whole model state (integrator memory included); a serialized
  state is validated (kind, version, fixed parameters, the parameter ranges) before it can be
  set, and a state of another fidelity is refused.

pythonfmu's own protocol (``do_step`` returning a bool, ``exit_initialization_mode``...) is kept
on top, for an FMU built without a C compiler, which then runs on pythonfmu's wrapper.
"""
from __future__ import annotations

import json
import math
import operator
from dataclasses import dataclass
from typing import Any, Callable, Sequence

from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real, String
from pythonfmu.enums import Fmi2Status

from . import __version__
from .errors import ParameterError
from .fmi_vars import Var

OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3
_TYPES = {"Real": Real, "Integer": Integer, "Boolean": Boolean, "String": String}
_CAST = {"Real": float, "Integer": int, "Boolean": bool, "String": str}
_STATE_FORMAT = "spurdiff-fmu-state"
_STATE_VERSION = 1
# fmi2StatusKind
_DO_STEP_STATUS, _PENDING_STATUS, _LAST_SUCCESSFUL_TIME, _TERMINATED = range(4)


def _is_bad_number(v: Any) -> bool:
    return isinstance(v, float) and (math.isnan(v) or math.isinf(v))


def _time_tolerance(t: float, h: float) -> float:
    """How far a communication point may stand from the FMU's time: rounding of a sum of steps."""
    return 1e-9 * max(1.0, abs(t)) + 1e-6 * h


def _getter(names: Sequence[str]) -> Callable[[dict], tuple]:
    """A function of a dict returning the tuple of its values at ``names`` (one C-level call)."""
    names = tuple(names)
    if len(names) >= 2:
        return operator.itemgetter(*names)
    if len(names) == 1:
        name = names[0]
        return lambda d: (d[name],)
    return lambda d: ()


_CACHE_LIMIT = 256   # value-reference vectors remembered per FMU instance (a host uses a few)


@dataclass
class FmuState:
    """An FMU state: what ``fmi2GetFMUstate`` hands out (opaque to the host)."""

    kind: str
    values: dict
    phase: str
    failure: str
    time: float
    model: Any


class ModelFmu(Fmi2Slave):
    """Base class of the project's FMUs. A subclass delegates to an interface module of this
    package (e.g. :mod:`spurdiff.differential_fmu`) that defines, without any FMI dependency:

    * ``VARIABLES``: the list of :class:`Var`;
    * ``build_model(values) -> model``: construct and ``initialize`` the physics model from the
      parameter and input values (raise ParameterError for invalid ones), and set the calculated
      parameters in ``values``;
    * ``push_inputs(model, values)``: copy input values into the model before a step;
    * ``pull_outputs(model, values)``: copy model outputs into ``values``.
    Model objects provide ``do_step(t, h)``, ``get_state()``, ``set_state(state)``.
    The subclass sets ``VARIABLES`` and overrides the three hooks with one-line calls into that
    module (a module object stored as a class attribute crashes pythonfmu's second
    instantiation). The harness's direct (FMI-free) runner uses the same module, so both run
    the same code.
    """

    VARIABLES: Sequence[Var] = ()
    author = "spurdiff developers"
    license = "MIT"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self._bridged = "logging_on" in kwargs   # our bridge passes it, pythonfmu's wrapper does not
        self.values: dict[str, Any] = {}
        self._get: dict[str, dict[int, str]] = {k: {} for k in _TYPES}   # type -> vr -> name
        self._set: dict[str, dict[int, str]] = {k: {} for k in _TYPES}   # settable ones
        self._fixed: set[str] = {v.name for v in self.VARIABLES if v.fmi_variability == "fixed"}
        # inputs with their accepted range (modelDescription min/max; unbounded where none)
        self._inputs = [(v.name, -math.inf if v.min is None else v.min, math.inf if v.max is None else v.max)
                        for v in self.VARIABLES if v.causality == "input" and v.kind == "Real"]
        self._outputs = [v.name for v in self.VARIABLES if v.causality == "output" and v.kind == "Real"]
        # the hot path's tables (see _step, fmi2_get_real, fmi2_set_real): the inputs' values, lower
        # and upper bounds as parallel tuples, the Real outputs read in one C-level call, and per
        # value-reference vector a compiled getter / the names with "any fixed parameter among them"
        self._input_values = _getter([n for n, _, _ in self._inputs])
        self._input_lo = tuple(lo for _, lo, _ in self._inputs)
        self._input_hi = tuple(hi for _, _, hi in self._inputs)
        self._output_values = _getter(self._outputs)
        self._real_getters: dict[tuple, Callable[[dict], tuple]] = {}
        self._real_setters: dict[tuple, tuple[tuple, bool]] = {}
        self.model = None
        self.phase = "instantiated"
        self.failure = ""
        self.time = 0.0
        self.stop_time: float | None = None
        self.terminated = False          # fmi2Terminated: the FMU cannot go on (stop time reached)
        self.last_step_status = OK
        self._dirty = True               # values changed since the model was built
        self._categories: set[str] | None = None   # None: every category
        for v in self.VARIABLES:
            self.values[v.name] = v.start
            self._register(v)

    # ------------------------------------------------------------------ registration
    def _register(self, v: Var) -> None:
        values = self.values
        name = v.name
        settable = v.causality not in ("output", "calculatedParameter", "local")
        var = _TYPES[v.kind](
            name,
            causality=getattr(Fmi2Causality, v.causality),
            variability=getattr(Fmi2Variability, v.fmi_variability),
            description=v.description,
            getter=lambda: values[name],
            setter=self._setter(name) if settable else None,
        )
        self.register_variable(var, nested=False)
        self._get[v.kind][var.value_reference] = name
        if settable:
            self._set[v.kind][var.value_reference] = name

    def _setter(self, name: str) -> Callable[[Any], None]:
        def set_value(x):
            status = self._store([name], [x])
            if status != OK:
                raise RuntimeError(self.failure_of_last_set)
        return set_value

    # ------------------------------------------------------------------ logging
    def _log(self, msg: str, status: Fmi2Status = Fmi2Status.ok) -> None:
        # both our bridge and pythonfmu's wrapper hand the text to the host's logger as its format;
        # the bridge doubles '%' itself
        self.log(msg if self._bridged else msg.replace("%", "%%"), status)

    def log(self, msg, status=Fmi2Status.ok, category=None, debug=None):
        if category is None:
            category = f"logStatus{Fmi2Status(status).name.capitalize()}"
            if category not in self.log_categories:
                category = "logAll"
        if status == Fmi2Status.ok and self._categories is not None and category not in self._categories:
            return
        super().log(msg, status, category)

    def _refuse(self, status: int, msg: str) -> int:
        self._log(msg, Fmi2Status(status))
        return status

    # ------------------------------------------------------------------ values
    def _store(self, names: Sequence[str], xs: Sequence[Any]) -> int:
        phase = self.phase
        if phase in ("terminated", "error"):
            self.failure_of_last_set = (f"setting {names[0]} refused: the instance is in state '{phase}' "
                                        "(fmi2Reset first)")
            return self._refuse(ERROR, self.failure_of_last_set)
        for name in names:
            if name in self._fixed and phase not in ("instantiated", "initializing"):
                self.failure_of_last_set = (f"{name} is a fixed parameter: it cannot be set after "
                                            f"initialization (state '{phase}'); fmi2Reset first")
                return self._refuse(ERROR, self.failure_of_last_set)
        table = self.values
        for name, x in zip(names, xs):
            table[name] = x
        self._dirty = True
        return OK

    def _names(self, kind: str, vrs, settable: bool) -> list[str]:
        table = (self._set if settable else self._get)[kind]
        try:
            return [table[vr] for vr in vrs]
        except KeyError as e:
            vr = e.args[0]
            what = "settable " if settable and vr in self._get[kind] else ""
            raise ValueError(f"value reference {vr} is not a {what}{kind} variable of this FMU") from None

    def _read(self, kind: str, vrs) -> list:
        names = self._names(kind, vrs, settable=False)
        if self.phase == "initializing" and self._dirty:
            self._initial_outputs()
        cast, values = _CAST[kind], self.values
        return [cast(values[n]) for n in names]

    def _initial_outputs(self) -> None:
        """Outputs and calculated parameters from the values set so far (initialization mode)."""
        self.model = self._built(self.values)
        self.pull_outputs(self.model, self.values)
        self._dirty = False

    def _built(self, values: dict):
        """The model built from ``values`` (ParameterError for a non-finite parameter or input)."""
        for v in self.VARIABLES:
            if v.causality in ("parameter", "input") and _is_bad_number(values[v.name]):
                raise ParameterError(v.name, values[v.name], "a finite number")
        return self.build_model(values)

    # ------------------------------------------------------------------ FMI 2.0 (the bridge)
    def fmi2_set_debug_logging(self, on: bool, categories: list[str]) -> int:
        unknown = [c for c in categories if c not in self.log_categories]
        if unknown:
            return self._refuse(ERROR, f"fmi2SetDebugLogging: unknown log categories {unknown}; "
                                       f"declared: {sorted(self.log_categories)}")
        self._categories = set(categories) if (on and categories) else None
        return OK

    def fmi2_setup_experiment(self, tolerance_defined: bool, tolerance: float, start: float,
                              stop_defined: bool, stop: float) -> int:
        if self.phase != "instantiated":
            return self._refuse(ERROR, f"fmi2SetupExperiment refused in state '{self.phase}' "
                                       "(only after fmi2Instantiate or fmi2Reset)")
        if not math.isfinite(start):
            return self._refuse(ERROR, f"fmi2SetupExperiment: startTime = {start} must be finite")
        if stop_defined and not (math.isfinite(stop) and stop >= start):
            return self._refuse(ERROR, f"fmi2SetupExperiment: stopTime = {stop} must be finite and >= "
                                       f"startTime = {start}")
        self.time = start
        self.stop_time = stop if stop_defined else None
        return OK

    def fmi2_enter_initialization_mode(self) -> int:
        if self.phase != "instantiated":
            return self._refuse(ERROR, f"fmi2EnterInitializationMode refused in state '{self.phase}' "
                                       "(only once, after fmi2Instantiate or fmi2Reset)")
        self.phase = "initializing"
        return OK

    def fmi2_exit_initialization_mode(self) -> int:
        if self.phase != "initializing":
            return self._refuse(ERROR, f"fmi2ExitInitializationMode refused in state '{self.phase}'")
        try:
            if self._dirty or self.model is None:
                self._initial_outputs()
            self.phase = "stepping"
            return OK
        except ParameterError as e:
            self.failure = f"invalid parameter: {e}"
        except Exception as e:
            self.failure = f"initialization failed: {type(e).__name__}: {e}"
        self.phase = "error"
        self.model = None
        return self._refuse(ERROR, self.failure)

    def fmi2_terminate(self) -> int:
        if self.phase not in ("stepping", "error"):
            return self._refuse(ERROR, f"fmi2Terminate refused in state '{self.phase}'")
        self.phase = "terminated"
        return OK

    def fmi2_get_real(self, vrs) -> Sequence[float]:
        """The values at ``vrs`` (a tuple from our bridge, a list from pythonfmu's wrapper). The
        getter of each value-reference vector is compiled once (the names looked up, unknown
        references refused as in :meth:`_read`); the C side converts each value with
        ``PyFloat_AsDouble``, so values are not cast here."""
        key = vrs if vrs.__class__ is tuple else tuple(vrs)
        getter = self._real_getters.get(key)
        if getter is None:
            getter = _getter(self._names("Real", key, settable=False))
            if len(self._real_getters) >= _CACHE_LIMIT:
                self._real_getters.clear()
            self._real_getters[key] = getter
        if self._dirty and self.phase == "initializing":
            self._initial_outputs()
        if self._bridged:
            return getter(self.values)
        return [float(x) for x in getter(self.values)]

    def fmi2_get_integer(self, vrs) -> list:
        return self._read("Integer", vrs)

    def fmi2_get_boolean(self, vrs) -> list:
        return self._read("Boolean", vrs)

    def fmi2_get_string(self, vrs) -> list:
        return self._read("String", vrs)

    def fmi2_set_real(self, vrs, xs) -> int:
        """Store the values at ``vrs``; while stepping, a vector without fixed parameters goes
        straight into the value table (the names looked up once per vector), anything else
        through :meth:`_store` and its refusals."""
        key = vrs if vrs.__class__ is tuple else tuple(vrs)
        entry = self._real_setters.get(key)
        if entry is None:
            names = tuple(self._names("Real", key, True))
            entry = (names, any(n in self._fixed for n in names))
            if len(self._real_setters) >= _CACHE_LIMIT:
                self._real_setters.clear()
            self._real_setters[key] = entry
        names, fixed = entry
        if self.phase == "stepping" and not fixed:
            self.values.update(zip(names, xs))
            self._dirty = True
            return OK
        return self._store(names, xs)

    def fmi2_set_integer(self, vrs, xs) -> int:
        return self._store(self._names("Integer", vrs, True), xs)

    def fmi2_set_boolean(self, vrs, xs) -> int:
        return self._store(self._names("Boolean", vrs, True), xs)

    def fmi2_set_string(self, vrs, xs) -> int:
        return self._store(self._names("String", vrs, True), xs)

    def fmi2_do_step(self, t: float, h: float, no_set_prior: bool = False) -> int:
        status = self._step(t, h)
        self.last_step_status = status
        return status

    def _step(self, t: float, h: float) -> int:
        # the checks below are the hot path of every communication step: each is one comparison
        # or one C-level pass over a precomputed table; the messages are built only on refusal
        if self.phase != "stepping":
            why = f": {self.failure}" if self.failure else ""
            return self._refuse(ERROR, f"fmi2DoStep refused in state '{self.phase}'{why}")
        if not 0.0 < h < math.inf:   # NaN too
            return self._refuse(DISCARD, f"fmi2DoStep at t = {t:g} s refused: communicationStepSize = {h} "
                                         "must be > 0 and finite")
        at = t if t >= 0.0 else -t   # |t|; NaN fails the comparison below
        if not abs(t - self.time) <= 1e-9 * (at if at > 1.0 else 1.0) + 1e-6 * h or at == math.inf:
            return self._refuse(DISCARD, f"fmi2DoStep refused: currentCommunicationPoint = {t!r} s is not the "
                                         f"FMU's time {self.time!r} s (no gaps, no going back: use fmi2SetFMUstate)")
        if self.stop_time is not None and t + h > self.stop_time + _time_tolerance(self.stop_time, h):
            self.terminated = True   # FMI 2.0 section 2.1.6: computing past a defined stopTime is fmi2Error
            return self._refuse(ERROR, f"fmi2DoStep refused: t + h = {t + h:g} s is past the stopTime "
                                       f"{self.stop_time:g} s set by fmi2SetupExperiment; state kept at t = {self.time:g} s")
        values = self.values
        xs = self._input_values(values)
        if not (all(map(operator.le, self._input_lo, xs)) and all(map(operator.le, xs, self._input_hi))):
            for (name, lo, hi), x in zip(self._inputs, xs):
                if not lo <= x <= hi:   # NaN too
                    what = "is not a finite number" if not math.isfinite(x) else f"is outside [{lo:g}, {hi:g}]"
                    return self._refuse(DISCARD, f"fmi2DoStep at t = {t:g} s refused: input {name} = {x} {what}; "
                                                 f"state kept at t = {self.time:g} s")
        model = self.model
        # the rollback point; a model whose do_step leaves itself as it was on any error and never
        # commits a non-finite state says so with ATOMIC_STEP (no snapshot on the hot path)
        atomic = getattr(model, "ATOMIC_STEP", False)
        saved = None if atomic else model.get_state()
        try:
            self.push_inputs(model, values)
            model.do_step(t, h)
            self.pull_outputs(model, values)
            # all outputs finite if their sum is (a NaN or an infinity makes it so; a finite sum
            # that overflows is told apart by the exact check)
            if math.isfinite(sum(self._output_values(values))):
                bad = None
            else:
                bad = next((n for n in self._outputs if not math.isfinite(values[n])), None)
            if bad is None:
                self.time = t + h
                return OK
            msg = f"fmi2DoStep at t = {t:g} s refused: its result is not finite ({bad} = {values[bad]})"
        except ParameterError as e:
            msg = f"fmi2DoStep at t = {t:g} s refused: {e}"
        except Exception as e:
            msg = f"fmi2DoStep at t = {t:g} s failed: {type(e).__name__}: {e}"
        try:
            if saved is not None:
                model.set_state(saved)   # the last successful state stays valid
            self.pull_outputs(model, values)
        except Exception as e:
            self.phase, self.failure = "error", f"state lost after a failed step: {e}"
            return self._refuse(ERROR, msg + "; " + self.failure)
        return self._refuse(DISCARD, msg + f"; state kept at t = {self.time:g} s")

    def fmi2_cancel_step(self) -> int:
        return self._refuse(ERROR, "fmi2CancelStep: no asynchronous step is pending (fmi2DoStep never "
                                   "returns fmi2Pending)")

    def fmi2_get_status(self, kind: int, type_: str) -> tuple[int, Any]:
        if type_ == "status" and kind == _DO_STEP_STATUS:
            return OK, self.last_step_status
        if type_ == "real" and kind == _LAST_SUCCESSFUL_TIME:
            return OK, self.time
        if type_ == "boolean" and kind == _TERMINATED:
            return OK, self.terminated
        if kind == _PENDING_STATUS:
            return self._refuse(DISCARD, "fmi2PendingStatus: no asynchronous step is pending"), ""
        return self._refuse(ERROR, f"status kind {kind} is not defined for fmi2Get{type_.capitalize()}Status"), 0

    # ------------------------------------------------------------------ FMU state
    def fmi2_get_state(self) -> FmuState:
        return FmuState(type(self).__name__, dict(self.values), self.phase, self.failure, self.time,
                        self.model.get_state() if self.model is not None else None)

    def fmi2_set_state(self, state: FmuState) -> int:
        if not isinstance(state, FmuState) or state.kind != type(self).__name__:
            return self._refuse(ERROR, "fmi2SetFMUstate: not a state of this FMU")
        if self.phase not in ("instantiated", "initializing"):
            differ = next((n for n in sorted(self._fixed) if n in state.values
                           and state.values[n] != self.values[n]), None)
            if differ is not None:
                return self._refuse(ERROR, f"fmi2SetFMUstate: the state has {differ} = {state.values[differ]!r}, "
                                           f"this instance {self.values[differ]!r} (another configuration "
                                           "or fidelity): fmi2Reset first")
        try:
            model = self.model
            if state.model is not None and (model is None or any(
                    state.values[n] != self.values[n] for n in self._fixed)):
                model = self.build_model(dict(state.values))
            if state.model is not None:
                model.set_state(state.model)
        except Exception as e:
            return self._refuse(ERROR, f"fmi2SetFMUstate: the state does not fit this FMU: {type(e).__name__}: {e}")
        self.values.clear()
        self.values.update(state.values)
        self.model = model if state.model is not None else None
        self.phase, self.failure, self.time = state.phase, state.failure, state.time
        self.terminated = False
        self._dirty = False
        return OK

    def fmi2_serialize_state(self, state: FmuState) -> bytes:
        doc = {"format": _STATE_FORMAT, "version": _STATE_VERSION, "package": __version__,
               "kind": state.kind, "values": state.values, "phase": state.phase, "failure": state.failure,
               "time": state.time, "model": state.model}
        return json.dumps(doc, allow_nan=True).encode("utf-8")

    def fmi2_deserialize_state(self, data: bytes) -> FmuState:
        """A serialized state, validated before it can reach the instance: its format and
        version, the FMU it belongs to, every variable's name and type, the parameter ranges
        (the model is built from its values apart from this instance) and the model state."""
        if len(data) > 64 * 1024 * 1024:
            raise ValueError(f"serialized state of {len(data)} bytes: more than any state of this FMU")
        try:
            doc = json.loads(data.decode("utf-8"))
        except (UnicodeDecodeError, ValueError) as e:
            raise ValueError(f"not a serialized state of this FMU (not JSON: {e})") from None
        if not isinstance(doc, dict) or doc.get("format") != _STATE_FORMAT:
            raise ValueError("not a serialized spurdiff FMU state")
        if doc.get("version") != _STATE_VERSION:
            raise ValueError(f"state format version {doc.get('version')!r}, this FMU reads {_STATE_VERSION}")
        if doc.get("kind") != type(self).__name__:
            raise ValueError(f"a state of {doc.get('kind')!r}, not of {type(self).__name__}")
        values = doc.get("values")
        if not isinstance(values, dict) or set(values) != set(self.values):
            raise ValueError("the state's variables are not this FMU's")
        for v in self.VARIABLES:
            x = values[v.name]
            ok = (isinstance(x, (int, float)) and not isinstance(x, bool) if v.kind == "Real"
                  else isinstance(x, int) and not isinstance(x, bool) if v.kind == "Integer"
                  else isinstance(x, (bool, int)) if v.kind == "Boolean" else isinstance(x, str))
            if not ok:
                raise ValueError(f"{v.name} = {x!r} in the state is not a {v.kind}")
        if doc.get("phase") not in ("instantiated", "initializing", "stepping", "terminated", "error"):
            raise ValueError(f"unknown phase {doc.get('phase')!r} in the state")
        t = doc.get("time")
        if not isinstance(t, (int, float)) or not math.isfinite(t):
            raise ValueError(f"time {t!r} in the state is not finite")
        state = FmuState(doc["kind"], values, doc["phase"], str(doc.get("failure", "")), float(t), doc.get("model"))
        if state.model is not None:
            try:
                model = self._built(dict(values))
                model.set_state(state.model)
            except ParameterError as e:
                raise ValueError(f"invalid parameter in the state: {e}") from None
            except Exception as e:
                raise ValueError(f"the state's model part does not fit: {type(e).__name__}: {e}") from None
        return state

    # ------------------------------------------------------------------ pythonfmu's protocol
    # (an FMU built without a C compiler runs on pythonfmu's wrapper, which calls these)
    def get_real(self, vrs):
        return self.fmi2_get_real(vrs)

    def set_real(self, vrs, values):
        if self.fmi2_set_real(vrs, values) != OK:
            raise RuntimeError(self.failure_of_last_set)

    def enter_initialization_mode(self):
        self.fmi2_enter_initialization_mode()

    def exit_initialization_mode(self):
        self.fmi2_exit_initialization_mode()

    def do_step(self, current_time: float, step_size: float) -> bool:
        return self.fmi2_do_step(current_time, step_size) <= WARNING

    def terminate(self):
        self.fmi2_terminate()

    def _get_fmu_state(self) -> FmuState:
        return self.fmi2_get_state()

    def _set_fmu_state(self, state) -> None:
        if self.fmi2_set_state(state) != OK:
            raise RuntimeError("fmi2SetFMUstate refused (see the log)")

    @staticmethod
    def _fmu_state_to_bytes(state: FmuState) -> bytes:
        return json.dumps(vars(state)).encode("utf-8")

    @staticmethod
    def _fmu_state_from_bytes(data: bytes) -> FmuState:
        return FmuState(**json.loads(data.decode("utf-8")))

    # ------------------------------------------------------------------ interface hooks
    def build_model(self, values: dict):  # pragma: no cover - overridden
        raise NotImplementedError

    def push_inputs(self, model, values: dict) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    def pull_outputs(self, model, values: dict) -> None:  # pragma: no cover - overridden
        raise NotImplementedError
