"""The native start of the FMI 3.0 binary (fmi3_loader.c over fmi2_loader.c and native_start.c) at its
edges, against its Python start (SPURDIFF_FMU_START=python): the stop time and a step past it, a step at
the wrong time or within the time tolerance, h = 0 and NaN, a NaN input, Initialization Mode left twice,
fmi3Terminate twice, the independent variable read in every mode, a long run then an FMU state; every
status, value (bit for bit) and message compared. (FMI 2.0: test_native_start_edges.py.)"""
from __future__ import annotations

import math
import struct

import pytest

from harness.fmi.instance import fmu_cache

H = 1e-3
TIME_VR = 2147483647      # the FMI 3.0 FMU's independent variable


def _trace3(path, mode, program, monkeypatch):
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi3 import FMU3Slave

    monkeypatch.setenv("SPURDIFF_FMU_START", mode)
    unzipdir, md = fmu_cache().get(path)
    s = FMU3Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="ns3")
    log = []
    s.instantiate(loggingOn=True, logMessage=lambda env, st, cat, msg: log.append((st, msg.decode())))
    outs = [v.valueReference for v in md.modelVariables if v.causality == "output" and v.type in ("Real", "Float64")]
    ins = [v.valueReference for v in md.modelVariables if v.causality == "input" and v.type in ("Real", "Float64")]
    assert outs and ins
    out = []
    for op, *a in program:
        try:
            if op == "init":
                s.enterInitializationMode(startTime=a[0], stopTime=a[1])
                s.exitInitializationMode()
                r = None
            elif op == "step":
                r = s.doStep(currentCommunicationPoint=a[0], communicationStepSize=a[1])
                r = (tuple(r), [struct.pack("<d", x).hex() for x in s.getFloat64(outs)])
            elif op == "set":
                r = s.setFloat64([ins[0]], [a[0]])
            elif op == "exit":
                r = s.exitInitializationMode()
            elif op == "state":
                st = s.getFMUState()
                s.setFMUState(st)
                s.freeFMUState(st)
                r = None
            elif op == "terminate":
                r = s.terminate()
            elif op == "read":     # the independent variable and every output, in any mode
                r = [struct.pack("<d", x).hex() for x in s.getFloat64([TIME_VR] + outs)]
            elif op == "enter":
                r = s.enterInitializationMode(startTime=a[0], stopTime=a[1])
            out.append((op, "ok", r))
        except FMICallException as e:
            out.append((op, "failed", e.status))
    try:
        s.terminate()
    except Exception:
        pass
    s.freeInstance()
    return out, log


PROGRAMS3 = {
    "stop-and-past": [("init", 0.0, 0.01)] + [("step", k * H, H) for k in range(10)] + [("step", 0.01, H)],
    "wrong-time": [("init", 0.0, None), ("step", 0.5, H), ("step", 0.0, H)],
    "h-zero-nan": [("init", 0.0, None), ("step", 0.0, 0.0), ("step", 0.0, math.nan), ("step", 0.0, H)],
    "nan-input": [("init", 0.0, None), ("step", 0.0, H), ("set", math.nan), ("step", H, H), ("step", H, H)],
    "exit-twice-terminate-twice": [("init", 0.0, None), ("exit",), ("step", 0.0, H), ("terminate",),
                                   ("terminate",), ("step", H, H)],
    "time-read": [("read",), ("enter", 2.5, 3.0), ("read",), ("exit",), ("read",), ("step", 2.5, H), ("read",),
                  ("terminate",), ("read",)],
    "time-offset": [("enter", 0.0, None), ("exit",), ("step", 1e-10, H), ("read",), ("step", H + 3e-10, H),
                    ("read",), ("step", 2 * H, H), ("read",)],
    "input-set-in-init": [("enter", 0.0, None), ("set", 0.0), ("read",), ("exit",), ("step", 0.0, H), ("read",)],
    "long-then-state": [("init", 0.0, None)] + [("step", k * H, H) for k in range(300)] + [("state",),
                                                                                         ("step", 0.3, H)],
}


@pytest.mark.parametrize("case", list(PROGRAMS3))
def test_fmi3(fmu_files, monkeypatch, case):
    from harness.build.fmu3 import build

    path = build(["SpurDifferential"], quiet=True)[0]
    assert _trace3(path, "auto", PROGRAMS3[case], monkeypatch) == _trace3(path, "python", PROGRAMS3[case],
                                                                          monkeypatch)
