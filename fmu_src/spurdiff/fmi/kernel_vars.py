"""The ``solver.*`` variables of a model whose step has a compiled kernel and a native step (the
car's, the wheel's): which implementation runs the step, whether the native step is on, and which
implementation runs; and the model built from the FMI values, saying which runs. Declared once for
the FMUs that carry such a kernel (Vehicle, WheelLoad)."""
from __future__ import annotations

from spurdiff.fmi.binding import bindings
from spurdiff.fmi.variables import Var


def kernel_variables(step: str) -> list[Var]:
    """``solver.kernel``, ``solver.nativeStep`` and ``solver.kernelInUse`` of a model whose compiled
    kernel runs ``step`` (e.g. "the car's Runge-Kutta step")."""
    return [
        Var("solver.kernel", "parameter", f"Implementation of {step}: auto (the compiled kernel "
            "shipped in the FMU when it loads, else the Python reference, with the reason logged) | compiled "
            "(refuse to start without it) | python (the pure-Python reference; the same results bit for bit, "
            "slower)", None, None, "auto", kind="String", bind="kernel"),
        Var("solver.nativeStep", "parameter", "With the compiled kernel in use: true = the whole communication step "
            "runs in C without entering Python (the FMU's native step: the inputs checked, the step, the outputs; the "
            "same results bit for bit; the state is handed back to Python before any other call reads it) | false = "
            "every step runs through the Python model around the compiled kernel (for comparison)",
            None, None, True, kind="Boolean", bind="nativeStep"),
        Var("solver.kernelInUse", "calculatedParameter", f"Implementation that runs {step}: "
            "compiled | python (and why)", None, None, "", kind="String"),
    ]


def initialized(model, variables: list[Var], values: dict):
    """``model`` with the FMI ``values`` pushed in (by the bindings of ``variables``), initialized at
    t = 0, and ``values["solver.kernelInUse"]`` saying which implementation runs its step."""
    bindings(variables).push(model, values)
    model.initialize(0.0)
    values["solver.kernelInUse"] = model.kernel_note
    return model


def kernel_message(values: dict, step: str) -> str:
    """What the FMU logs once the model is built: which implementation runs ``step``."""
    return f"solver.kernel = {values['solver.kernel']}: {values['solver.kernelInUse']} implementation of {step}"
