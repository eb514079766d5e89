"""Helpers of the FMU tests: an instance initialized with parameters and inputs, its Reals, its steps,
the status of a refused call, its end (FMI 2.0 and, through harness.fmi.instance3, 3.0)."""
from __future__ import annotations

import pytest
from fmpy.fmi1 import FMICallException

from harness.run.master import Instance
from spurdiff.gears.design_sets import fmu_parameters

# The paper's straight-line case on the paper's gear set (SpurDifferential's default experiment before
# issue 46; the default now runs the designed set with a slip the locking stops): the start values the
# tests of the paper's numbers set explicitly
PAPER_CASE = {**fmu_parameters("paper"), "differential.w_start": 0.0, "carrier.w_ref": 1.389, "left.tau": -1050.0,
              "right.tau": -1050.0}


def start(fmu, name: str, params: dict | None = None, inputs: dict | None = None,
          expect_error: bool = False) -> Instance:
    """An instance of ``fmu`` through Initialization Mode with ``params`` and ``inputs`` set;
    ``expect_error``: fmi2ExitInitializationMode must answer fmi2Error (invalid parameters)."""
    inst = enter_initialization(Instance(name, fmu), params, inputs)
    if expect_error:
        with pytest.raises(FMICallException, match="status 3"):
            inst.slave.exitInitializationMode()
    else:
        inst.slave.exitInitializationMode()
    return inst


def enter_initialization(inst, params: dict | None = None, inputs: dict | None = None, stop: float | None = None):
    """``inst`` (FMI 2.0 or 3.0) in Initialization Mode from t = 0 (to ``stop``) with ``params`` and
    ``inputs`` set."""
    s = inst.slave
    s.setupExperiment(startTime=0.0, stopTime=stop)
    s.enterInitializationMode()
    for k, v in {**(params or {}), **(inputs or {})}.items():
        inst.set_value(k, v)
    return inst


def get(inst: Instance, *names: str) -> list[float]:
    return inst.slave.getReal([inst.var(n).valueReference for n in names])


def free(inst: Instance) -> None:
    inst.slave.terminate()
    inst.slave.freeInstance()


def steps(inst, n: int, t0: float = 0.0, h: float = 1e-3) -> float:
    """``n`` doSteps of ``h`` from ``t0``; the time after them."""
    t = t0
    for _ in range(n):
        inst.slave.doStep(t, h)
        t += h
    return t


def status_of(call) -> int:
    """The status of ``call()``, which must be refused (fmpy raises on anything but fmi2OK/fmi2Warning)."""
    with pytest.raises(FMICallException) as e:
        call()
    return e.value.status
