"""The FMI 3.0 co-simulation FMUs (``NAME-fmi3.fmu``, harness/build/fmu3.py) against their FMI 2.0 twins.

Same declaration, same model: the FMI 3.0 modelDescription.xml passes fmpy's validation and
carries the FMI 2.0 one's variables (value references, units, ranges, starts, descriptions) plus
the independent variable ``time``; fmpy's FMI 3.0 run gives the FMI 2.0 run's numbers exactly.
The FMI 3.0 state machine and statuses: an invalid parameter is fmi3Error naming it and its range,
an input out of range or not finite fmi3Discard naming it (lastSuccessfulTime the FMU's time),
every function the FMU does not offer (Model Exchange, Event Mode, clocks, other types, arrays) a
logged fmi3Error, never a crash; FMU state, serialization and reset reproduce a run; log lines
name the FMI 3.0 functions.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi3 import FMU3Model, FMU3Slave
from fmpy.validation import validate_fmu
from fmu_session import enter_initialization, status_of
from test_fmu_contract import CASES

from harness.fmi.instance import fmu_cache
from harness.fmi.instance3 import Instance3, open_instance

H = 1e-3
TIME_VR = 2147483647


@pytest.fixture(scope="session")
def fmu3_files(fmu_files):
    from harness.build.fmu3 import build

    return dict(zip(fmu_files, build(list(fmu_files), quiet=True)))


@pytest.fixture(params=list(CASES))
def pair(request, fmu_files, fmu3_files):
    name = request.param
    return name, fmu_files[name], fmu3_files[name], CASES[name]


def start3(path, name, case, stop=None, params=None) -> Instance3:
    inst = open_instance(name, path)
    assert isinstance(inst, Instance3)
    enter_initialization(inst, params, case["inputs"], stop)
    inst.slave.exitInitializationMode()
    return inst


def fmu3(path, name="raw") -> FMU3Slave:
    """A bare fmpy FMU3Slave of ``path`` instantiated with a logger collecting (status, text)."""
    unzipdir, md = fmu_cache().get(path)
    s = FMU3Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName=name)
    s.log = []
    s.instantiate(loggingOn=True, logMessage=lambda env, st, cat, msg: s.log.append((st, msg.decode())))
    return s


def real_outputs(inst) -> list[float]:
    return inst.slave.getReal([v.valueReference for v in inst.vars.values()
                               if v.causality == "output" and v.type == "Real"])


def test_fmpy_validates_the_fmi3_description(pair):
    name, _, path3, _ = pair
    assert validate_fmu(str(path3)) == []


def test_the_fmi3_fmu_carries_the_windows_side_with_an_fmi3_loader(pair):
    """Where the FMI 2.0 FMU has its win64 side, the FMI 3.0 FMU has it under binaries/x86_64-windows/
    with the FMI 3.0 loader as the model's DLL (the same bridge, runtime and description); none
    under the FMI 2.0 platform name. (Run under wine: tests/harness/test_win64.py.)"""
    import zipfile
    name, path2, path3, _ = pair
    with zipfile.ZipFile(path2) as z2, zipfile.ZipFile(path3) as z3:
        names2, names3 = z2.namelist(), z3.namelist()
        assert f"binaries/x86_64-linux/{name}.so" in names3
        assert not [n for n in names3 if n.startswith("binaries/win64/")]
        if f"binaries/win64/{name}.dll" not in names2:
            assert not [n for n in names3 if n.startswith(("binaries/x86_64-windows/", "resources/python-win64/"))
                        or n == "resources/python_runtime_win64.cfg"]
            pytest.skip("built without mingw-w64: no Windows side in either FMU")
        windows = sorted(n for n in names3 if n.startswith("binaries/x86_64-windows/"))
        assert windows == sorted(n.replace("binaries/win64/", "binaries/x86_64-windows/")
                                 for n in names2 if n.startswith("binaries/win64/"))
        loader3 = z3.read(f"binaries/x86_64-windows/{name}.dll")
        assert loader3 != z2.read(f"binaries/win64/{name}.dll")
        assert b"fmi3InstantiateCoSimulation" in loader3 and b"fmi2Instantiate" in loader3
        assert z3.read("binaries/x86_64-windows/fmi2_pybridge.dll") == z2.read("binaries/win64/fmi2_pybridge.dll")
        assert z3.read("resources/python_runtime_win64.cfg") == z2.read("resources/python_runtime_win64.cfg")
        assert sorted(n for n in names3 if n.startswith("resources/python-win64/")) == \
            sorted(n for n in names2 if n.startswith("resources/python-win64/"))


def test_the_fmi3_description_carries_the_fmi2_variables(pair):
    name, path2, path3, _ = pair
    md2, md3 = read_model_description(str(path2)), read_model_description(str(path3))
    assert md3.fmiVersion == "3.0" and md3.guid == md2.guid and md3.coSimulation.modelIdentifier == name
    assert not md3.coSimulation.hasEventMode and md3.modelExchange is None
    v2 = {v.name: v for v in md2.modelVariables}
    v3 = {v.name: v for v in md3.modelVariables}
    assert v3.pop("time").causality == "independent"
    assert set(v3) == set(v2)
    types = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}
    for n, a in v2.items():
        b = v3[n]
        assert (b.valueReference, b.causality, b.variability, b.description) == \
               (a.valueReference, a.causality, a.variability, a.description), n
        assert b.type == types[a.type], n
        assert (b.unit, b.displayUnit, b.min, b.max, b.start) == (a.unit, a.displayUnit, a.min, a.max, a.start), n
    assert [u.variable.name for u in md3.outputs] == [u.variable.name for u in md2.outputs]
    assert sorted(u.variable.name for u in md3.initialUnknowns) == sorted(u.variable.name for u in md2.initialUnknowns)


def test_fmpy_runs_fmi3_to_the_fmi2_numbers_exactly(pair):
    name, path2, path3, case = pair
    # from the folders the harness unpacked them to (fmpy runs a folder as it runs the file)
    r2 = simulate_fmu(fmu_cache().get(path2)[0], stop_time=0.05, output_interval=H, start_values=case["inputs"])
    r3 = simulate_fmu(fmu_cache().get(path3)[0], stop_time=0.05, output_interval=H, start_values=case["inputs"])
    assert len(r2) == len(r3) == 51
    compared = 0
    for n in r2.dtype.names:
        if r2[n].dtype.kind == "f":
            assert np.array_equal(r2[n], r3[n], equal_nan=True), f"{n}: {np.max(np.abs(r2[n] - r3[n]))}"
            compared += 1
    assert compared >= 5


def test_an_invalid_parameter_is_fmi3Error_naming_it_and_its_range(pair):
    name, _, path3, case = pair
    param, value = case["bad_param"]
    inst = open_instance(name, path3)
    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    inst.set_value(param, value)
    assert status_of(inst.slave.exitInitializationMode) == 3   # fmi3Error
    text = inst.messages[-1][1]
    assert param in text and "allowed" in text, text
    assert "fmi2" not in text
    # the FMU's state is Error: a step is refused, fmi3Reset makes it usable again
    assert status_of(lambda: inst.slave.doStep(0.0, H)) == 3
    inst.slave.reset()
    inst.close()


def test_an_input_out_of_range_is_fmi3Discard_at_the_FMUs_time(pair):
    name, _, path3, case = pair
    inst = start3(path3, name, case)
    do = inst.c_function("fmi2DoStep")
    assert do(inst.component, 0.0, H, 1) == 0
    big = next(k for k in case["inputs"])
    hi = inst.var(big).max
    for bad in (math.nan, math.inf, 10 * float(hi) if hi is not None else 1e300):
        inst.set_value(big, bad)
        assert do(inst.component, H, H, 1) == 2, bad               # fmi3Discard
        event, terminate, early, last = inst.last_step
        assert last == pytest.approx(H) and not early and not event
        assert big in inst.messages[-1][1] and "fmi3DoStep" in inst.messages[-1][1], inst.messages[-1]
    inst.set_value(big, case["inputs"][big])
    assert do(inst.component, H, H, 1) == 0                       # usable again
    # a communication point that is not the FMU's time
    assert do(inst.component, 5 * H, H, 1) == 2
    assert "not the FMU's time" in inst.messages[-1][1]
    # an illegal step size is fmi3Error (FMI 3.0 2.2.4: illegal arguments), the state untouched
    for h in (0.0, -H, math.nan, math.inf):
        assert do(inst.component, 2 * H, h, 1) == 3, h
        assert "communicationStepSize" in inst.messages[-1][1] and "fmi3DoStep" in inst.messages[-1][1]
    inst.close()


def test_what_the_fmu_does_not_offer_is_a_logged_fmi3Error(differential_fmu, fmu3_files):
    path3 = fmu3_files["SpurDifferential"]
    unzipdir, md = fmu_cache().get(path3)
    # Model Exchange, and Event Mode asked for at instantiation: NULL, logged
    me = FMU3Model(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier="SpurDifferential", instanceName="me")
    log = []
    with pytest.raises(Exception):
        me.instantiate(loggingOn=True, logMessage=lambda env, st, cat, msg: log.append(msg.decode()))
    assert "Co-Simulation only" in log[-1]
    s = FMU3Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier="SpurDifferential", instanceName="ev")
    log.clear()
    with pytest.raises(Exception):
        s.instantiate(loggingOn=True, eventModeUsed=True, logMessage=lambda env, st, cat, msg: log.append(msg.decode()))
    assert "hasEventMode = false" in log[-1]
    # a wrong instantiation token
    s = FMU3Slave(guid="{not-ours}", unzipDirectory=unzipdir, modelIdentifier="SpurDifferential", instanceName="tok")
    log.clear()
    with pytest.raises(Exception):
        s.instantiate(loggingOn=True, logMessage=lambda env, st, cat, msg: log.append(msg.decode()))
    assert "does not match" in log[-1] and "fmi3InstantiateCoSimulation" in log[-1]

    s = fmu3(path3)
    s.enterInitializationMode(startTime=0.0)
    assert status_of(lambda: s.getFloat32([0])) == 3 and "Float32" in s.log[-1][1]
    assert status_of(lambda: s.getFloat64([0], nValues=2)) == 3 and "nValues" in s.log[-1][1]
    assert status_of(lambda: s.setFloat64([TIME_VR], [1.0])) == 3 and "time" in s.log[-1][1]
    assert status_of(lambda: s.getFloat64([123456])) == 3 and "Float64 variable" in s.log[-1][1]
    assert s.getFloat64([TIME_VR]) == [0.0]
    s.exitInitializationMode()
    assert status_of(s.enterEventMode) == 3 and "Event Mode" in s.log[-1][1]
    assert status_of(s.enterStepMode) == 3
    assert status_of(lambda: s.getOutputDerivatives([0], [1])) == 3
    assert status_of(lambda: s.enterInitializationMode(startTime=0.0)) == 3   # not again while stepping
    assert "fmi3EnterInitializationMode" in s.log[-1][1] and "fmi2" not in s.log[-1][1]
    s.doStep(0.0, H)
    assert s.getFloat64([TIME_VR]) == [pytest.approx(H)]
    # NULL arrays and NULL output arguments: fmi3Error with the reason, no crash
    dll, comp = s.dll, s.component
    assert dll.fmi3GetFloat64(comp, None, 1, None, 1) == 3 and "NULL" in s.log[-1][1]
    assert dll.fmi3SetBoolean(comp, None, 2, None, 2) == 3 and "NULL" in s.log[-1][1]
    assert dll.fmi3DoStep(comp, H, H, True, None, None, None, None) == 3 and "eventHandlingNeeded" in s.log[-1][1]
    assert dll.fmi3GetFloat64(None, None, 0, None, 0) == 3   # not an instance
    s.terminate()
    s.freeInstance()


def test_state_serialization_and_reset_reproduce_a_run(differential_fmu, fmu3_files):
    case = CASES["SpurDifferential"]
    inst = start3(fmu3_files["SpurDifferential"], "SpurDifferential", case)
    f = inst.slave._fmu
    for k in range(10):
        inst.slave.doStep(k * H, H)
    state = f.getFMUState()
    blob = f.serializeFMUState(state)
    for k in range(10, 20):
        inst.slave.doStep(k * H, H)
    ref = real_outputs(inst)
    f.setFMUState(f.deserializeFMUState(blob))
    assert f.getFloat64([TIME_VR]) == [pytest.approx(10 * H)]
    for k in range(10, 20):
        inst.slave.doStep(k * H, H)
    assert real_outputs(inst) == ref
    f.setFMUState(state)
    for k in range(10, 20):
        inst.slave.doStep(k * H, H)
    assert real_outputs(inst) == ref
    f.freeFMUState(state)
    # reset: a fresh run from t = 0 gives the same numbers
    f.reset()
    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    for k, v in case["inputs"].items():
        inst.set_value(k, v)
    inst.slave.exitInitializationMode()
    for k in range(20):
        inst.slave.doStep(k * H, H)
    assert real_outputs(inst) == ref
    inst.close()
