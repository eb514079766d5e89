"""The native step through FMI (fmu_src/native/fmi/fmi2_pybridge.c with spurdiff.fmi.native_methods):
Vehicle, WheelLoad and SpurDifferential (rigid: shaftCoupling = wheel, and torque with the FMU's defaults) step in C without Python while the host only steps them and sets and gets
Reals; an instance with solver.nativeStep = true answers exactly as one with false through a run
that sets inputs every step, takes and restores an FMU state, reads an Integer output and a
parameter mid-run, stores a bad input (refused, named, state kept) and ends; and its Python step
runs only where the native one cannot."""
from __future__ import annotations

import math

import pytest
from fmpy.fmi1 import FMICallException

from harness.measure.bench.core import fmu_copies
from spurdiff.differential.rigid import RigidDifferential
from spurdiff.differential.shafts import ShaftedDifferential
from spurdiff.vehicle.car import Vehicle
from spurdiff.vehicle.wheel import WheelLoad
from tests.fmus.fmu_session import start

H = 5e-3
def _surrogate(side: str, i: int) -> dict:
    return {f"{side}Wheel.aFree": -4.0 + 0.05 * i, f"{side}Wheel.invJ": 0.8, f"{side}Wheel.dadw": -0.02,
            f"{side}Wheel.tyreTorqueRate": 30.0 * math.sin(0.3 * i), f"{side}Wheel.tyreStiffness": 60.0,
            f"{side}Wheel.tyreRelaxation": 1.5}


CASES = {   # inputs per step i; an input to spoil; a parameter and an Integer output to read; parameters
    "Vehicle": (lambda i: {"rearLeft.Fx": 500.0 + 40.0 * math.sin(0.1 * i), "rearRight.Fx": 480.0,
                           "speedTarget": 10.0 + 0.02 * i, "pathRadius": 20.0 if i < 40 else math.inf},
                "grade", "vehicle.m", "internalSteps", {}),
    "WheelLoad": (lambda i: {"flange.w": 30.0 + 0.1 * i, "flange.phi": 0.15 * i + 5e-4 * i * i, "Fz": 4000.0,
                             "mu": 0.9, "vx": 10.0, "FzRate": 100.0 * math.cos(0.2 * i)},
                  "mu", "wheel.J", "internalSteps", {}),
    "SpurDifferential": (lambda i: {"carrier.tau": 150.0 + 3.0 * i * (1 if i < 30 else -1),
                                    "leftWheel.phi": 0.147 * i, "leftWheel.w": 29.5 + 0.01 * i,
                                    "rightWheel.phi": 0.159 * i, "rightWheel.w": 31.9, **_surrogate("left", i),
                                    **_surrogate("right", i)},
                         "leftWheel.invJ", "J_carrier", "internalSteps",
                         {"shaftCoupling": "wheel", "carrierDrive": "torque", "J_carrier": 13.1,
                          "carrier.w_start": 30.7161, "differential.w_start": -1.1706}),
    # the FMU's default interface (shaftCoupling = torque, rigid, the pin-load law): stuck, breaking away, slipping
    "SpurDifferential-torque": (lambda i: {"carrier.tau": 150.0 + 3.0 * i * (1 if i < 30 else -1),
                                           "left.tau": -60.0 - (120.0 if 15 <= i < 25 else 0.0) + 2.0 * i,
                                           "right.tau": -80.0 + 1.5 * i},
                                "left.tau", "J_carrier", "modeSwitches", {"carrier.w_start": 30.7, "overspeedLimit": 1e4}),
}
# the model class whose Python steps are counted (the outermost model's class, or its plain class)
COUNTED = {"Vehicle": Vehicle, "WheelLoad": WheelLoad, "SpurDifferential": ShaftedDifferential,
           "SpurDifferential-torque": RigidDifferential}


class _Counted:
    """The FMUs' own copies of the model classes with do_step counted (the Python steps taken)."""

    def __init__(self, cls: type):
        self.calls = 0
        self.saved = {}
        self.cls = cls

    def __enter__(self):
        for c in fmu_copies({self.cls}):
            f = self.saved[c] = c.__dict__["do_step"]

            def counted(model, t, h, _f=f):
                self.calls += 1
                return _f(model, t, h)
            c.do_step = counted
        return self

    def __exit__(self, *exc):
        for c, f in self.saved.items():
            c.do_step = f


def _script(path, name: str, native: bool, case, counted: _Counted) -> list:
    """The run's observations: the Real outputs after every step, the refusals, the reads; the
    Python steps counted into ``counted``."""
    inputs, bad, param, integer, params = case
    inst = start(path, name, params={**params, "solver.nativeStep": native}, inputs=inputs(0))
    with counted:   # (the FMU's package is imported now)
        return _run(inst, case)


def _run(inst, case) -> list:
    inputs, bad, param, integer, _ = case
    s = inst.slave
    outs = sorted(v.valueReference for v in inst.vars.values() if v.causality == "output" and v.type == "Real")
    ins = [inst.var(k).valueReference for k in inputs(0)]
    seen, t, state, t_state = [], 0.0, None, None
    i = 0
    while i < 60:
        s.setReal(ins, list(inputs(i).values()))
        if i == 35:   # a bad input: refused, named, the state kept; the good value back
            vr = inst.var(bad).valueReference
            good = s.getReal([vr])[0]
            s.setReal([vr], [math.nan])
            with pytest.raises(FMICallException) as e:
                s.doStep(t, H)
            seen.append(("refused", e.value.status, bad in inst.last_message()))
            s.setReal([vr], [good])
        s.doStep(t, H)
        t += H
        seen.append(tuple(s.getReal(outs)))
        if i == 10:
            state, t_state = s.getFMUState(), t
        if i == 20 and state is not None:   # back to step 10's end, once
            s.setFMUState(state)
            s.freeFMUState(state)
            state, t, i = None, t_state, 10
            seen.append(("restored",))
        if i == 30:
            seen.append((s.getInteger([inst.var(integer).valueReference])[0],
                         s.getReal([inst.var(param).valueReference])[0]))
        i += 1
    s.terminate()
    seen.append(tuple(s.getReal(outs)))
    s.freeInstance()
    return seen


@pytest.mark.parametrize("fmu", list(CASES))
def test_native_instance_answers_as_the_python_one(fmu, fmu_files, monkeypatch):
    # the start cache off: an instance it started (its values seen twice by earlier runs) takes its first
    # steps natively and hands them to the Python at the FMU state call, so the count would depend on them
    monkeypatch.setenv("SPURDIFF_FMU_START_CACHE", "off")
    path = fmu_files[fmu.split("-")[0]]
    python, native = _Counted(COUNTED[fmu]), _Counted(COUNTED[fmu])
    ref = _script(path, "python", False, CASES[fmu], python)
    got = _script(path, "native", True, CASES[fmu], native)
    assert got == ref
    assert ("refused", 2, True) in got and ("restored",) in got
    assert python.calls == 60 + 10       # every step taken (ten of them again after the restore)
    # natively the Python step takes three steps only: the first (its inputs not checked yet), the one
    # after the refused step (the good value stored through the slave) and the one after the restored
    # state; the Integer output and the parameter read mid-run come from the native step's array
    assert native.calls == 3
