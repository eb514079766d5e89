"""The FMU state of the project's FMUs (fmi2GetFMUstate, fmi2SetFMUstate and their serialization),
as methods :class:`~spurdiff.fmi.adapter.ModelFmu` inherits, and the fmi2Status codes.

A state carries the whole model state (integrator memory included) with the variable values, the
phase of the FMI state machine and the time; a serialized state is validated (format, version, the
FMU it belongs to, every variable's type, the parameter ranges through a model built from its
values, the model state) before it can be set, and a state of another fidelity is refused.
"""
from __future__ import annotations

import json
import math
from typing import Any

from spurdiff import __version__
from spurdiff.errors import ParameterError
from spurdiff.attrpath import record

OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3     # fmi2Status
_STATE_FORMAT = "spurdiff-fmu-state"
_STATE_VERSION = 1


@record
class FmuState:
    """An FMU state: what ``fmi2GetFMUstate`` hands out (opaque to the host)."""

    kind: str
    values: dict
    phase: str
    failure: str
    time: float
    model: Any


def _not_finite(x: Any, ref: Any, path: str = "") -> tuple[str, float] | None:
    """The first number of the model state ``x`` that is NaN or infinite where the freshly built model's
    state ``ref`` holds a finite number or nothing (a state this FMU wrote has a non-finite number only
    where a fresh model has one, e.g. a mesh force not solved yet): (its path, its value), or None."""
    if isinstance(x, float):
        if math.isfinite(x) or isinstance(ref, float) and not math.isfinite(ref):
            return None
        return path, x
    if isinstance(x, dict):
        r = ref if isinstance(ref, dict) else {}
        for k, v in x.items():
            bad = _not_finite(v, r.get(k), f"{path}.{k}" if path else str(k))
            if bad is not None:
                return bad
    elif isinstance(x, (list, tuple)):
        r = ref if isinstance(ref, (list, tuple)) else ()
        for i, v in enumerate(x):
            bad = _not_finite(v, r[i] if i < len(r) else None, f"{path}[{i}]")
            if bad is not None:
                return bad
    return None


class FmuStateMethods:
    """The FMU-state methods of :class:`~spurdiff.fmi.adapter.ModelFmu` (they use its ``values``,
    ``phase``, ``model``, ``VARIABLES``, ``_fixed``, ``_built``, ``build_model`` and ``_refuse``)."""

    def fmi2_get_state(self) -> FmuState:
        return FmuState(type(self).__name__, dict(self.values), self.phase, self.failure, self.time,
                        self.model.get_state() if self.model is not None else None)

    def fmi2_set_state(self, state: FmuState) -> int:
        if not isinstance(state, FmuState) or state.kind != type(self).__name__:
            return self._refuse(ERROR, "fmi2SetFMUstate: not a state of this FMU")
        # a fixed parameter that differs: refused once initialized, else the model is rebuilt from the state
        differ = next((n for n in sorted(self._fixed) if n not in state.values
                       or state.values[n] != self.values[n]), None)
        if differ is not None and self.phase not in ("instantiated", "initializing"):
            return self._refuse(ERROR, f"fmi2SetFMUstate: the state has {differ} = {state.values.get(differ)!r}, "
                                       f"this instance {self.values[differ]!r} (another configuration "
                                       "or fidelity): fmi2Reset first")
        try:
            model = self.model
            if state.model is not None and (model is None or differ is not None):
                model = self.build_model(dict(state.values))
            if state.model is not None:
                model.set_state(state.model)
        except Exception as e:
            return self._refuse(ERROR, f"fmi2SetFMUstate: the state does not fit this FMU: {type(e).__name__}: {e}")
        self.values.clear()
        self.values.update(state.values)
        self.model = model if state.model is not None else None
        self.phase, self.failure, self.time = state.phase, state.failure, state.time
        self.terminated = self.step_failed = False
        self._dirty = False
        self._inputs_ok = False
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
                fresh = model.get_state()
                model.set_state(state.model)
            except ParameterError as e:
                raise ValueError(f"invalid parameter in the state: {e}") from None
            except Exception as e:
                raise ValueError(f"the state's model part does not fit: {type(e).__name__}: {e}") from None
            bad = _not_finite(state.model, fresh)
            if bad is not None:
                raise ValueError(f"model.{bad[0]} = {bad[1]!r} in the state is not a finite number (the model "
                                 "never holds one there): refused, as a non-finite input is")
        return state

    # pythonfmu's protocol (an FMU built without a C compiler runs on pythonfmu's wrapper)
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
