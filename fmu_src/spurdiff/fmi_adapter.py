"""Thin pythonfmu adapter shared by the project's FMUs.

An FMU script declares its interface as a list of :class:`Var` (name, causality, variability,
unit, display unit, description, start value, direct dependencies) and maps it onto a physics
model from this package. The same list drives

* the variables pythonfmu registers (value references in list order),
* the build-time post-processing of modelDescription.xml (units, display units, unit
  definitions, Outputs with dependencies, InitialUnknowns; see ``harness/modeldescription.py``).

What pythonfmu 0.7 cannot do, and how the adapter copes:

* Every Python exception escaping a callback becomes fmi2Fatal (the instance is then unusable).
  So no callback here raises: setters only store values; parameters and inputs are validated in
  ``exit_initialization_mode`` and ``do_step``; a failure is logged with status error (message
  names the variable and the allowed range) and ``do_step`` returns False, which pythonfmu
  reports as fmi2Discard. ``exitInitializationMode`` itself cannot return an error status, so an
  invalid parameter set is reported by the logger there and every later doStep is refused.
* The FMI state machine is tracked: doStep before initialization, or after a failed
  initialization, is refused (fmi2Discard); setting a fixed parameter after initialization is
  refused by raising, which pythonfmu reports as fmi2Fatal (the only refusal a setter has).
* get/set FMU state carries the whole model state (including integrator memory), not only the
  registered variables.
"""
from __future__ import annotations

import math
from typing import Any, Callable, Sequence

from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real, String
from pythonfmu.enums import Fmi2Status

from .errors import ParameterError
from .fmi_vars import Var


_TYPES = {"Real": Real, "Integer": Integer, "Boolean": Boolean, "String": String}


def _is_bad_number(v: Any) -> bool:
    return isinstance(v, float) and (math.isnan(v) or math.isinf(v))


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
        self.values: dict[str, Any] = {}
        self._real_get: dict[int, str] = {}     # value reference -> name, every Real
        self._real_set: dict[int, str] = {}     # value reference -> name, settable Reals
        self._fixed: set[str] = {v.name for v in self.VARIABLES if v.fmi_variability == "fixed"}
        self.model = None
        self.phase = "instantiated"   # instantiated | initializing | stepping | failed | terminated
        self.failure = ""
        for v in self.VARIABLES:
            self.values[v.name] = v.start
            self._register(v)

    # ------------------------------------------------------------------ registration
    def _register(self, v: Var) -> None:
        values = self.values
        name = v.name
        var = _TYPES[v.kind](
            name,
            causality=getattr(Fmi2Causality, v.causality),
            variability=getattr(Fmi2Variability, v.fmi_variability),
            description=v.description,
            getter=lambda: values[name],
            setter=None if v.causality in ("output", "calculatedParameter", "local") else self._setter(name),
        )
        self.register_variable(var, nested=False)
        if v.kind == "Real":
            self._real_get[var.value_reference] = name
            if v.causality not in ("output", "calculatedParameter", "local"):
                self._real_set[var.value_reference] = name

    # ------------------------------------------------------------------ Real access
    # pythonfmu's own get_real/set_real look up each variable object and call its lambda; these
    # read and write the value table directly (same behaviour, a third of the cost per call:
    # the FMI overhead of a coupled run is mostly these calls, see docs/performance.md)
    def get_real(self, vrs):
        values, names = self.values, self._real_get
        try:
            return [float(values[names[vr]]) for vr in vrs]
        except KeyError as e:
            raise TypeError(f"Variable with valueReference={e.args[0]} is not of type Real!") from None

    def set_real(self, vrs, values):
        table, names = self.values, self._real_set
        for vr, x in zip(vrs, values):
            name = names.get(vr)
            if name is None:
                raise TypeError(f"Variable with valueReference={vr} is not a settable Real")
            self._refuse_fixed_after_init(name)
            table[name] = x

    def _setter(self, name: str) -> Callable[[Any], None]:
        values = self.values

        def set_value(x):
            self._refuse_fixed_after_init(name)
            values[name] = x
        return set_value

    def _refuse_fixed_after_init(self, name: str) -> None:
        if name in self._fixed and self.phase not in ("instantiated", "initializing"):
            # FMI 2.0 forbids it; raising is the only refusal pythonfmu 0.7 offers (fmi2Fatal)
            raise RuntimeError(f"{name} is a fixed parameter: it cannot be set after initialization "
                               f"(state '{self.phase}'); use fmi2Reset first")

    # ------------------------------------------------------------------ logging
    def _log(self, msg: str, status: Fmi2Status = Fmi2Status.ok) -> None:
        # pythonfmu passes the text as a printf format: escape '%'
        self.log(msg.replace("%", "%%"), status)

    # ------------------------------------------------------------------ FMI callbacks
    def enter_initialization_mode(self):
        self.phase = "initializing"

    def exit_initialization_mode(self):
        try:
            for v in self.VARIABLES:
                if v.causality in ("parameter", "input") and _is_bad_number(self.values[v.name]):
                    raise ParameterError(v.name, self.values[v.name], "a finite number")
            self.model = self.build_model(self.values)
            self.pull_outputs(self.model, self.values)
            self.phase = "stepping"
        except ParameterError as e:
            self.phase = "failed"
            self.failure = f"invalid parameter: {e}"
            self._log(self.failure, Fmi2Status.error)
        except Exception as e:  # never let an exception reach pythonfmu (fmi2Fatal)
            self.phase = "failed"
            self.failure = f"initialization failed: {type(e).__name__}: {e}"
            self._log(self.failure, Fmi2Status.error)

    def do_step(self, current_time: float, step_size: float) -> bool:
        if self.phase != "stepping":
            if self.phase == "failed":
                self._log(f"doStep refused at t = {current_time:g} s: {self.failure}", Fmi2Status.error)
            else:
                self._log(f"doStep refused: called in state '{self.phase}' (exitInitializationMode first)",
                          Fmi2Status.error)
            return False
        model = self.model
        saved = None
        try:
            if not step_size > 0.0 or math.isinf(step_size):
                raise ParameterError("communicationStepSize", step_size, "> 0 and finite")
            # the rollback point; a model whose do_step restores itself on any error says so
            # with ATOMIC_STEP (no second snapshot on the hot path)
            saved = None if getattr(model, "ATOMIC_STEP", False) else model.get_state()
            self.push_inputs(model, self.values)
            model.do_step(current_time, step_size)
            self.pull_outputs(model, self.values)
            return True
        except ParameterError as e:
            msg = f"doStep at t = {current_time:g} s refused: {e}"
        except Exception as e:
            msg = f"doStep at t = {current_time:g} s failed: {type(e).__name__}: {e}"
        if saved is not None:
            try:
                model.set_state(saved)  # the last successful state stays valid
            except Exception:
                pass
        self._log(msg + f"; last successful time {model_time(model, current_time):g} s", Fmi2Status.error)
        return False

    def terminate(self):
        self.phase = "terminated"

    # ------------------------------------------------------------------ state
    def _get_fmu_state(self) -> dict:
        return {
            "values": dict(self.values),
            "phase": self.phase,
            "failure": self.failure,
            "model": self.model.get_state() if self.model is not None else None,
        }

    def _set_fmu_state(self, state: dict) -> None:
        self.values.clear()
        self.values.update(state["values"])
        self.phase = state["phase"]
        self.failure = state["failure"]
        if state["model"] is not None:
            if self.model is None:
                self.model = self.build_model(self.values)
            self.model.set_state(state["model"])

    # ------------------------------------------------------------------ interface hooks
    def build_model(self, values: dict):  # pragma: no cover - overridden
        raise NotImplementedError

    def push_inputs(self, model, values: dict) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    def pull_outputs(self, model, values: dict) -> None:  # pragma: no cover - overridden
        raise NotImplementedError


def model_time(model, fallback: float) -> float:
    return float(getattr(model, "t", fallback))
