"""What the FMI 2.0 and FMI 3.0 sessions share: the defaults, the trace file, the logger's findings, "the same
outputs" and a perturbed start value. A session (:class:`.fmi2.Session`, :class:`.fmi3.Session3`) names its
version (``fmi``: "fmi2" / "fmi3"), its output columns (``columns``: one per value, arrays flattened) and the
columns of its scalar Real / Float64 outputs (``real_columns``)."""
from __future__ import annotations

import math
import os
from typing import Any

DEFAULT_STEP_SIZE = 1e-3          # s, when the FMU has no DefaultExperiment stepSize
DEFAULT_TOLERANCE = 1e-4          # relative, when the DefaultExperiment gives none (fmpy's and the cross-check default)
SAME_RTOL, SAME_ATOL = 1e-9, 1e-12  # "same outputs": rounding-level differences only
ENV_BASE = 0x5D1F0000  # componentEnvironment values handed out: ENV_BASE + 16 k
LOGGER_VIOLATIONS: list[str] = []              # messages with a wrong environment or instance name


class Tracer:
    """Writes the FMI call about to be made to a file (unbuffered), for crash reports."""

    def __init__(self, path: str):
        self.fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)

    def __call__(self, text: str) -> None:
        os.write(self.fd, (text + "\n").encode("utf-8", "replace"))


def perturbed(v, value: Any) -> Any | None:
    """A value different from ``value`` within the variable's min/max (None if there is none or ``value`` is
    an array's list)."""
    if isinstance(value, list):
        return None
    if v.type == "Boolean":
        return not value
    if v.type == "String":
        return str(value) + "_changed"
    lo = float(v.min) if v.min is not None else -math.inf
    hi = float(v.max) if v.max is not None else math.inf
    if v.type in ("Real", "Float64", "Float32"):
        d = 0.1 * abs(value) if value != 0 else 0.1
        cands = [value + d, value - d]
        if math.isfinite(hi):
            cands.append(0.5 * (value + hi))
        if math.isfinite(lo):
            cands.append(0.5 * (value + lo))
    elif isinstance(value, int) and not isinstance(value, bool):
        cands = [value + 1, value - 1]
    else:
        return None
    for c in cands:
        if lo <= c <= hi and c != value:
            return c
    return None


def first_difference(s, a: list[list[float]], b: list[list[float]], start: str = "after initialization") -> str | None:
    """None when the two output trajectories are the same (see SAME_RTOL/SAME_ATOL), else where they first
    differ; ``start`` names the moment of sample 0."""
    import numpy as np
    A, B = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if A.shape != B.shape:
        return f"{A.shape[0]} samples vs {B.shape[0]}"
    ok = np.isclose(A, B, rtol=SAME_RTOL, atol=SAME_ATOL, equal_nan=True)
    if ok.all():
        return None
    i, j = map(int, np.argwhere(~ok)[0])
    where = start if i == 0 else f"after step {i}"
    return f"{s.columns[j]} {where}: {float(A[i, j])!r} vs {float(B[i, j])!r}"


def finite(xs) -> bool:
    return all(math.isfinite(x) for x in xs)


# calls both versions make alike: verb -> {version: (the call's name in the trace, fmpy's method)}
SHARED_CALLS = {
    "exit_init": {"fmi2": ("fmi2ExitInitializationMode", "exitInitializationMode"),
                  "fmi3": ("fmi3ExitInitializationMode", "exitInitializationMode")},
    "reset": {"fmi2": ("fmi2Reset", "reset"), "fmi3": ("fmi3Reset", "reset")},
    "get_state": {"fmi2": ("fmi2GetFMUstate", "getFMUstate"), "fmi3": ("fmi3GetFMUState", "getFMUState")},
    "set_state": {"fmi2": ("fmi2SetFMUstate", "setFMUstate"), "fmi3": ("fmi3SetFMUState", "setFMUState")},
    "free_state": {"fmi2": ("fmi2FreeFMUstate", "freeFMUstate"), "fmi3": ("fmi3FreeFMUState", "freeFMUState")},
    "serialize_state": {"fmi2": ("fmi2SerializeFMUstate", "serializeFMUstate"),
                        "fmi3": ("fmi3SerializeFMUState", "serializeFMUState")},
    "deserialize_state": {"fmi2": ("fmi2DeSerializeFMUstate", "deSerializeFMUstate"),
                          "fmi3": ("fmi3DeserializeFMUState", "deserializeFMUState")},
    "directional_derivative": {"fmi2": ("fmi2GetDirectionalDerivative", "getDirectionalDerivative"),
                               "fmi3": ("fmi3GetDirectionalDerivative", "getDirectionalDerivative")},
}


class SharedCalls:
    """The calls an instance of either version makes alike (:data:`SHARED_CALLS`), for a class with ``s`` (its
    session, ``s.fmi`` the version), ``slave`` (fmpy's object) and ``call`` (trace, call, a refusal raises)."""

    def initialize(self, overrides: dict[str, Any] | None = None, instantiate: bool = True,
                   stop_time: float | None = None, **how) -> None:
        """[instantiate (``how``: FMI 3.0's early_return, event_mode),] start values (with overrides), setup
        (FMI 2.0's fmi2SetupExperiment; FMI 3.0: the stop time for fmi3EnterInitializationMode), enter and exit
        initialization. FMI 2.0 2.1.6: before fmi2EnterInitializationMode only variables with initial exact or
        approx may be set ("Setting other variables is not allowed"); inputs have no initial: they are set in
        Initialization Mode (FMI 3.0 2.3.3 allows it there too)."""
        if instantiate:
            self.instantiate(**how)
        values = dict(self.s.start_values)
        values.update(overrides or {})
        early = {n: x for n, x in values.items() if self.s.by_name[n].causality != "input"}
        inputs = {n: x for n, x in values.items() if n not in early}
        if early:
            self.set_values(early, " start values")
        self.setup(stop_time)
        self.enter_init()
        if inputs:
            self.set_values(inputs, " inputs")
        self.exit_init()

    def _shared(self, verb: str, *args, label: str = ""):
        name, method = SHARED_CALLS[verb][self.s.fmi]
        return self.call(name + label, getattr(self.slave, method), *args)

    def exit_init(self) -> None:
        self._shared("exit_init")

    def reset(self) -> None:
        self._shared("reset")

    def get_state(self):
        return self._shared("get_state")

    def set_state(self, state, label: str = "") -> None:
        self._shared("set_state", state, label=label)

    def free_state(self, state) -> None:
        self._shared("free_state", state)

    def serialize_state(self, state) -> bytes:
        return self._shared("serialize_state", state)

    def deserialize_state(self, blob: bytes):
        return self._shared("deserialize_state", blob)

    def directional_derivative(self, label: str, unknowns: list[int], knowns: list[int], seed: list[float]):
        return self._shared("directional_derivative", unknowns, knowns, seed, label=f"({label})")

    def outputs(self) -> list[float]:
        """Every numeric and Boolean output, as floats (arrays flattened), in model-description order."""
        return self.read(self.s.outputs, "outputs")
