"""Helpers of the FMU tests: an instance initialized with parameters and inputs, its Reals, its end."""
from __future__ import annotations

import pytest

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
    inst = Instance(name, fmu)
    s = inst.slave
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    for k, v in {**(params or {}), **(inputs or {})}.items():
        inst.set_value(k, v)
    if expect_error:
        from fmpy.fmi1 import FMICallException
        with pytest.raises(FMICallException, match="status 3"):
            s.exitInitializationMode()
    else:
        s.exitInitializationMode()
    return inst


def get(inst: Instance, *names: str) -> list[float]:
    return inst.slave.getReal([inst.var(n).valueReference for n in names])


def free(inst: Instance) -> None:
    inst.slave.terminate()
    inst.slave.freeInstance()
