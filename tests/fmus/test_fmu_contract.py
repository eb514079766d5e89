"""The FMI 2.0 co-simulation contract, one suite over our three FMUs (through fmpy).

What every FMU must do: pass fmpy's validation, declare a unit for every Real and a description
for every variable, run two instances independently, reproduce a run after fmi2Reset and a
continuation from a (serialized) state, refuse a step before initialization, name an invalid
parameter and a non-finite input in the log. Misuse sequences a careless or hostile host can send, each answered with the status the standard
asks for and a logged reason, never fmi2Fatal and never a crash, the instance staying usable:
Initialization Mode entered again after stepping, a communication point that is not the FMU's
time, a step past the stop time, inputs so large the result is not finite, tampered and foreign
serialized states, garbage bytes, invalid value references, a wrong GUID, a missing resources
folder; and outputs valid in Initialization Mode.
"""
from __future__ import annotations

import json
import math
import shutil
import zipfile

import pytest
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.validation import validate_fmu

from fmu_session import enter_initialization, status_of, steps

from harness.run.master import Instance, _make_logger

# a case per FMU: the inputs of a normal run, an input that can be driven to overflow, a
# parameter whose tampered value is out of range, and a fixed (structural) parameter; a second
# configuration (other parameters and inputs) for the independence of two instances
CASES = {
    "SpurDifferential": dict(inputs={"carrier.w_ref": 1.389, "left.tau": -1050.0, "right.tau": -1040.0},
                             huge=("left.tau", 1e308), bad_param=("mu_pin", -5.0), output="left.w",
                             other=dict(params={"lockingLaw": "paper"},
                                        inputs={"carrier.w_ref": 1.389, "left.tau": -1110.201, "right.tau": -989.799})),
    "WheelLoad": dict(inputs={"flange.w": 30.0, "Fz": 4000.0, "mu": 0.9, "vx": 10.0},
                      huge=("Fz", 1e300), bad_param=("halfShaft.c", -1.0), output="wheel.w",
                      other=dict(params={"halfShaft.c": 4000.0},
                                 inputs={"flange.w": 40.0, "Fz": 2000.0, "mu": 0.3, "vx": 10.0})),
    "Vehicle": dict(inputs={"rearLeft.Fx": 500.0, "rearRight.Fx": 480.0, "speedTarget": 10.0, "pathRadius": 20.0},
                    huge=("rearLeft.Fx", 1e300), bad_param=("vehicle.m", -1.0), output="vx",
                    other=dict(params={"vehicle.m": 1500.0, "vehicle.vx_start": 5.0},
                               inputs={"rearLeft.Fx": 800.0, "rearRight.Fx": 700.0, "speedTarget": 12.0})),
}
H = 1e-3


def start(fmu, name, case, stop=None, params=None):
    inst = enter_initialization(Instance(name, fmu), params, case["inputs"], stop)
    inst.slave.exitInitializationMode()
    return inst


def outputs(inst) -> list[float]:
    """Every Real output of ``inst`` now."""
    return inst.slave.getReal([v.valueReference for v in inst.vars.values()
                               if v.causality == "output" and v.type == "Real"])


def get(inst, name):
    return inst.slave.getReal([inst.var(name).valueReference])[0]


def last(inst) -> str:
    return inst.messages[-1][1] if inst.messages else ""


@pytest.fixture(params=list(CASES))
def fmu(request, fmu_files):
    return request.param, fmu_files[request.param], CASES[request.param]


def test_fmpy_validate_finds_no_problem(fmu):
    name, path, case = fmu
    assert validate_fmu(str(path)) == []


def test_every_real_has_a_unit_and_every_variable_a_description(fmu):
    name, path, case = fmu
    md = read_model_description(str(path))
    assert md.modelName == name and md.coSimulation.modelIdentifier == name
    assert all(v.unit for v in md.modelVariables if v.type == "Real")
    assert all(v.description for v in md.modelVariables)
    assert all(u.variable.causality in ("output", "calculatedParameter") for u in md.initialUnknowns)


def test_two_instances_are_independent(fmu):
    """Two instances stepped in turn with different parameters and inputs give exactly what each
    gives alone."""
    name, path, case = fmu
    configs = (case, case["other"])

    def run(insts, n=50):
        for k in range(n):
            for inst in insts:
                inst.slave.doStep(k * H, H)
        return [outputs(inst) for inst in insts]

    a, b = (start(path, n, c, params=c.get("params")) for n, c in zip("ab", configs))
    together = run([a, b])
    alone = []
    for n, c in zip("ab", configs):
        inst = start(path, n, c, params=c.get("params"))
        alone += run([inst])
        inst.slave.freeInstance()
    a.slave.freeInstance()
    b.slave.freeInstance()
    assert together == alone
    assert together[0] != together[1]


def test_reset_gives_the_same_run(fmu):
    name, path, case = fmu
    inst = start(path, "reset", case)
    steps(inst, 30)
    first = outputs(inst)
    s = inst.slave
    s.reset()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    for k, v in case["inputs"].items():
        inst.set_value(k, v)
    s.exitInitializationMode()
    steps(inst, 30)
    assert outputs(inst) == first
    s.freeInstance()


@pytest.mark.parametrize("serialize", [False, True])
def test_state_restore_reproduces_the_continuation(fmu, serialize):
    name, path, case = fmu
    inst = start(path, "st", case)
    t = steps(inst, 20)
    state = inst.slave.getFMUstate()
    if serialize:
        blob = inst.slave.serializeFMUstate(state)
        inst.slave.freeFMUstate(state)
        state = inst.slave.deSerializeFMUstate(blob)
    steps(inst, 40, t)
    first = outputs(inst)
    inst.slave.setFMUstate(state)
    steps(inst, 40, t)
    assert outputs(inst) == first
    inst.slave.freeInstance()


def test_a_step_before_initialization_is_refused(fmu):
    name, path, case = fmu
    inst = Instance("early", path)
    inst.slave.setupExperiment(startTime=0.0)
    assert status_of(lambda: inst.slave.doStep(0.0, H)) == 3
    assert "refused in state 'instantiated'" in last(inst)
    inst.slave.freeInstance()


@pytest.mark.parametrize("name,params,param,allowed", [
    ("SpurDifferential", {"mu_pin": -0.5}, "mu_pin", "between 0 and 1"),   # the whole declared range
    ("WheelLoad", {"halfShaft.c": -8000.0}, "halfShaft.c", "> 0"),
    ("WheelLoad", {"tyre.C": 2.5}, "tyre.C", "0 < C <= 2"),
    ("WheelLoad", {"wheelLoad.h_max": 0.5}, "wheelLoad.h_max", "between 0 and 0.1"),
    ("Vehicle", {"vehicle.l_f": 3.0}, "vehicle.l_f", "0 < l_f < L"),
    ("Vehicle", {"steering.mode": 2}, "steering.mode", "0 (path radius) or 1"),
    ("Vehicle", {"speedControl.driveTorqueMin": 100.0}, "speedControl.driveTorqueMin", "<= 0"),
])
def test_a_bad_parameter_is_logged_by_name_and_steps_refused(fmu_files, name, params, param, allowed):
    inst = Instance("bad", fmu_files[name])
    s = inst.slave
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    for k, v in {**params, **CASES[name]["inputs"]}.items():
        inst.set_value(k, v)
    assert status_of(s.exitInitializationMode) == 3
    errs = inst.errors()
    assert errs and param in errs[0] and allowed in errs[0]
    assert status_of(lambda: s.doStep(0.0, H)) == 3   # the instance is in the error state
    assert any(param in m for m in inst.errors()[1:])   # the refusal repeats the reason
    s.freeInstance()


@pytest.mark.parametrize("name,bad", [
    ("SpurDifferential", "left.tau"),
    ("WheelLoad", "Fz"),
    ("WheelLoad", "flange.w"),
    ("Vehicle", "steeringAngleCommand"),
    ("Vehicle", "rearLeft.Fx"),
])
def test_a_nan_input_discards_the_step_names_it_and_keeps_the_state(fmu_files, name, bad):
    case = CASES[name]
    inst = start(fmu_files[name], "nan", case)
    ref = start(fmu_files[name], "ref", case)
    t = steps(inst, 5)
    steps(ref, 5)
    good = inst.slave.getReal([inst.var(bad).valueReference])[0]
    inst.slave.setReal([inst.var(bad).valueReference], [float("nan")])   # past the harness's own check
    assert status_of(lambda: inst.slave.doStep(t, H)) == 2               # fmi2Discard
    # fmpy's logger proxy (addLoggerProxy) keeps one static logger per process, so the message
    # reaches the callback of the instance instantiated last: look in both instances' logs
    errs = [m for st, m in inst.messages + ref.messages if st >= 2]
    assert len(errs) == 1 and bad in errs[0] and "finite" in errs[0]
    inst.set_value(bad, good)
    steps(inst, 5, t)          # recovers from the last successful state
    steps(ref, 5, t)
    assert outputs(inst) == outputs(ref)
    inst.slave.freeInstance()
    ref.slave.freeInstance()


def test_initialization_mode_cannot_be_entered_again_after_stepping(fmu):
    name, path, case = fmu
    inst = start(path, "a", case)
    t = steps(inst, 5)
    before = get(inst, case["output"])
    assert status_of(inst.slave.enterInitializationMode) == 3
    assert "EnterInitializationMode refused in state 'stepping'" in last(inst)
    assert status_of(lambda: inst.slave.setupExperiment(startTime=0.0)) == 3
    steps(inst, 5, t)   # went on from where it was, not from t = 0
    assert get(inst, case["output"]) != pytest.approx(0.0) or before == pytest.approx(0.0)
    assert inst.slave.getRealStatus(2) == pytest.approx(t + 5 * H)   # fmi2LastSuccessfulTime
    inst.slave.terminate()
    inst.slave.freeInstance()


def test_outputs_are_valid_in_initialization_mode(fmu):
    """What libcosim reads between enter- and exitInitializationMode: the values the FMU will
    report at t = 0, computed from the parameters and inputs set so far."""
    name, path, case = fmu
    inst = Instance("init", path)
    s = inst.slave
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    for k, v in case["inputs"].items():
        inst.set_value(k, v)
    outs = [v for v in inst.vars.values() if v.causality in ("output", "calculatedParameter") and v.type == "Real"]
    vrs = [v.valueReference for v in outs]
    during = s.getReal(vrs)
    s.exitInitializationMode()
    after = s.getReal(vrs)
    assert during == after
    assert any(abs(x) > 0 for x in during)   # computed, not the start values 0
    s.terminate()
    s.freeInstance()


def test_a_communication_point_that_is_not_the_fmus_time_is_refused(fmu):
    name, path, case = fmu
    inst = start(path, "t", case)
    t = steps(inst, 3)
    for bad in (t + 0.5, t - 2 * H, float("nan")):
        assert status_of(lambda: inst.slave.doStep(bad, H)) == 2   # fmi2Discard, state kept
        assert "not the FMU's time" in last(inst)
    assert inst.slave.getRealStatus(2) == pytest.approx(t)
    steps(inst, 2, t)   # the right time still works
    inst.slave.freeInstance()


def test_a_step_past_the_stop_time_is_refused_and_says_terminated(fmu):
    name, path, case = fmu
    inst = start(path, "stop", case, stop=3 * H)
    t = steps(inst, 3)
    assert status_of(lambda: inst.slave.doStep(t, H)) == 3   # fmi2Error (FMI 2.0 section 2.1.6)
    assert "past the stopTime" in last(inst)
    assert inst.slave.getBooleanStatus(3) is True or inst.slave.getBooleanStatus(3) == 1   # fmi2Terminated
    inst.slave.freeInstance()


def test_an_input_that_makes_the_result_overflow_is_discarded_and_the_state_kept(fmu):
    name, path, case = fmu
    inst = start(path, "huge", case)
    ref = start(path, "ref", case)
    t = steps(inst, 5)
    steps(ref, 5)
    var, value = case["huge"]
    good = get(inst, var)
    inst.set_value(var, value)
    assert status_of(lambda: inst.slave.doStep(t, H)) == 2
    assert var in last(inst) and "state kept" in last(inst)
    assert not inst.slave.getBooleanStatus(3)    # fmi2Terminated false: the master can correct the input
    outs = [v.valueReference for v in inst.vars.values() if v.causality == "output" and v.type == "Real"]
    assert inst.slave.getReal(outs) == ref.slave.getReal(outs)   # the outputs of the last good step
    inst.set_value(var, good)
    steps(inst, 5, t)           # not poisoned: goes on exactly like the reference
    steps(ref, 5, t)
    assert inst.slave.getReal(outs) == ref.slave.getReal(outs)
    inst.slave.freeInstance()
    ref.slave.freeInstance()


def test_a_failed_internal_integration_discards_says_terminated_and_fmpy_stops(fmu_files):
    """The differential's integrator gives up (maxInternalSteps = 10 over a contact start
    transient): fmi2Discard with the reason, fmi2Terminated true (fmpy's simulate_fmu retries a
    discarded step until the FMU says so: it looped forever before), the state kept; a shorter
    step from there succeeds and clears fmi2Terminated."""
    from fmpy import simulate_fmu

    path = fmu_files["SpurDifferential"]
    params = {"meshModel": "contact", "mesh.preload": False, "maxInternalSteps": 10}
    inst = start(path, "fail", CASES["SpurDifferential"], params=params)
    assert status_of(lambda: inst.slave.doStep(0.0, H)) == 2
    assert "maxInternalSteps" in last(inst) and "state kept at t = 0" in last(inst)
    assert inst.slave.getBooleanStatus(3) and inst.slave.getRealStatus(2) == 0.0
    inst.slave.doStep(0.0, 1e-6)     # a master may retry with a shorter step (FMI 2.0 section 4.2.3)
    assert not inst.slave.getBooleanStatus(3)
    inst.slave.freeInstance()
    res = simulate_fmu(str(path), stop_time=0.01, output_interval=H,
                       start_values={**params, **CASES["SpurDifferential"]["inputs"]})
    assert res["time"][-1] == 0.0     # ended at the last successful time, not hung


def _serialized(inst) -> bytes:
    state = inst.slave.getFMUstate()
    data = bytes(inst.slave.serializeFMUstate(state))
    inst.slave.freeFMUstate(state)
    return data


def _stepped(path, name, case):
    """An instance after five steps, its time, its Real outputs and its serialized state."""
    inst = start(path, name, case)
    t = steps(inst, 5)
    return inst, t, outputs(inst), _serialized(inst)


def test_tampered_foreign_and_garbage_states_are_refused_and_the_instance_kept(fmu, fmu_files):
    name, path, case = fmu
    inst, t, before, good = _stepped(path, "s", case)
    doc = json.loads(good)
    param, bad_value = case["bad_param"]
    doc["values"][param] = bad_value
    tampered = json.dumps(doc).encode()
    other = next(n for n in fmu_files if n != name)
    foreign_inst = start(fmu_files[other], "f", CASES[other])
    foreign = _serialized(foreign_inst)
    foreign_inst.slave.freeInstance()
    for data, why in ((tampered, param), (foreign, "not of"), (b"\x00garbage\xff" * 10, "not"),
                      (good[: len(good) // 2], "not"), (b"", "not")):
        assert status_of(lambda: inst.slave.deSerializeFMUstate(data)) == 3, why
        assert why in last(inst), (why, last(inst))
    assert outputs(inst) == before   # untouched
    # a valid state still restores exactly, and the instance still steps
    state = inst.slave.deSerializeFMUstate(good)
    steps(inst, 3, t)
    inst.slave.setFMUstate(state)
    assert outputs(inst) == before
    inst.slave.freeFMUstate(state)
    steps(inst, 3, t)
    inst.slave.freeInstance()


def _finite_paths(x, path=()):
    """The paths of the finite floats in a JSON document."""
    if isinstance(x, float) and math.isfinite(x):
        yield path
    elif isinstance(x, dict):
        for k, v in x.items():
            yield from _finite_paths(v, path + (k,))
    elif isinstance(x, list):
        for i, v in enumerate(x):
            yield from _finite_paths(v, path + (i,))


def test_nan_and_inf_inside_a_deserialized_state_are_refused_like_inputs(fmu):
    """A serialized state whose model part holds NaN or an infinity where the model holds a number
    (the speeds, the integrator's memory, the bookkeeping) is refused with fmi2Error naming the entry,
    the instance untouched; the good state still restores (issue 45 item 5)."""
    name, path, case = fmu
    inst, t, before, good = _stepped(path, "nan", case)
    doc = json.loads(good)
    paths = list(_finite_paths(doc["model"]))
    assert len(paths) > 5
    for i, bad in ((0, math.nan), (len(paths) // 2, math.inf), (len(paths) - 1, -math.inf)):
        d = json.loads(good)
        node = d["model"]
        for k in paths[i][:-1]:
            node = node[k]
        node[paths[i][-1]] = bad
        assert status_of(lambda: inst.slave.deSerializeFMUstate(json.dumps(d).encode())) == 3, paths[i]
        msg = last(inst)
        # named by the model state's entry, or by the parameter the model's own set_state checks it as
        assert "finite number" in msg and ("model." in msg or "invalid parameter" in msg), msg
    assert outputs(inst) == before
    state = inst.slave.deSerializeFMUstate(good)
    inst.slave.setFMUstate(state)
    inst.slave.freeFMUstate(state)
    steps(inst, 2, t)
    inst.slave.freeInstance()


def test_invalid_value_references_are_an_error_not_fatal(fmu):
    name, path, case = fmu
    inst = start(path, "vr", case)
    n = max(v.valueReference for v in inst.vars.values())
    assert status_of(lambda: inst.slave.getReal([n + 1000])) == 3
    assert "value reference" in last(inst)
    out = inst.var(case["output"]).valueReference
    assert status_of(lambda: inst.slave.setReal([out], [1.0])) == 3    # an output is not settable
    for _ in range(5):   # repeated errors never poison the instance (pythonfmu's wrapper crashed after four fatals)
        status_of(lambda: inst.slave.getReal([n + 1000]))
    steps(inst, 2)
    inst.slave.freeInstance()


def test_a_fixed_parameter_set_after_initialization_is_an_error_and_ignored(fmu):
    name, path, case = fmu
    param = case["bad_param"][0]
    inst = start(path, "fixed", case)
    t = steps(inst, 2)
    v = inst.var(param)
    assert status_of(lambda: inst.slave.setReal([v.valueReference], [123.0])) == 3
    assert "fixed parameter" in last(inst)
    assert inst.slave.getReal([v.valueReference])[0] != 123.0
    steps(inst, 2, t)
    inst.slave.freeInstance()


def _instantiate_raw(fmu, tmp_path, guid=None, drop_resources=False):
    md = read_model_description(str(fmu))
    unzip = tmp_path / "fmu"
    with zipfile.ZipFile(fmu) as z:
        z.extractall(unzip)
    if drop_resources:
        shutil.rmtree(unzip / "resources")
    from fmpy.fmi2 import fmi2CallbackFunctions
    messages = []
    cb = fmi2CallbackFunctions()
    cb.logger = _make_logger(messages)
    slave = FMU2Slave(guid=guid or md.guid, unzipDirectory=str(unzip),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="raw")
    with pytest.raises(Exception):
        slave.instantiate(callbacks=cb)
    slave.freeLibrary()
    return messages


def test_a_wrong_guid_is_refused_with_the_reason(fmu, tmp_path):
    name, path, case = fmu
    messages = _instantiate_raw(path, tmp_path, guid="{00000000-0000-0000-0000-000000000000}")
    assert any("GUID" in m and "does not match" in m for _, m in messages), messages


def test_a_missing_resources_folder_is_refused_with_the_reason(fmu, tmp_path):
    name, path, case = fmu
    messages = _instantiate_raw(path, tmp_path, drop_resources=True)
    assert any("resources" in m and "does not exist" in m for _, m in messages), messages


@pytest.mark.parametrize("uri", ["http://example.invalid/resources", "ftp://host/resources", "urn:x:resources",
                                 "file://host/resources"])
def test_a_resource_uri_that_is_no_local_file_is_refused_as_such(fmu, tmp_path, uri):
    """A URI of another scheme or host: "not a local file URI", not "does not exist" (a plain path)."""
    from ctypes import byref

    from fmpy.fmi2 import fmi2CallbackFunctions
    name, path, case = fmu
    md = read_model_description(str(path))
    with zipfile.ZipFile(path) as z:
        z.extractall(tmp_path / "fmu")
    messages = []
    cb = fmi2CallbackFunctions()
    cb.logger = _make_logger(messages)
    slave = FMU2Slave(guid=md.guid, unzipDirectory=str(tmp_path / "fmu"),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="raw")
    try:
        assert not slave.fmi2Instantiate(b"raw", 1, md.guid.encode(), uri.encode(), byref(cb), 0, 0)
    finally:
        slave.freeLibrary()
    assert [m for _, m in messages] == [f"fmi2Instantiate: fmuResourceLocation '{uri}' is not a local file URI"], messages


def test_a_reused_value_reference_buffer_is_read_for_what_it_holds_now(fmu):
    """A host that keeps one value-reference array and rewrites it in place between calls (as a
    master's preallocated ports may) gets the variables the array names at each call: the bridge
    reuses its tuple of the references and the adapter its getter only for the same contents."""
    from fmpy.fmi2 import fmi2Real, fmi2ValueReference

    name, path, case = fmu
    inst = start(path, "buf", case)
    t = steps(inst, 3)
    s = inst.slave
    ins = [inst.var(k).valueReference for k in case["inputs"]][:2]
    out = inst.var(case["output"]).valueReference
    get_fn, set_fn = s._functions["fmi2GetReal"], s._functions["fmi2SetReal"]
    vr, val = (fmi2ValueReference * 2)(), (fmi2Real * 2)()

    def get_pair(a, b):
        vr[0], vr[1] = a, b
        assert get_fn(s.component, vr, 2, val) == 0
        return val[0], val[1]

    x_out, x_in = s.getReal([out])[0], s.getReal([ins[0]])[0]
    assert get_pair(out, ins[0]) == (x_out, x_in)
    assert get_pair(out, ins[0]) == (x_out, x_in)       # the same vector again
    assert get_pair(ins[0], out) == (x_in, x_out)       # rewritten in place: the new order
    vr[0] = max(v.valueReference for v in inst.vars.values()) + 1000
    assert get_fn(s.component, vr, 2, val) == 3 and "value reference" in last(inst)
    # setting through the same array: inputs while stepping, then a fixed parameter among them
    vr[0], vr[1] = ins
    val[0], val[1] = 1.25 * case["inputs"][next(iter(case["inputs"]))], 0.5 * list(case["inputs"].values())[1]
    assert set_fn(s.component, vr, 2, val) == 0
    assert s.getReal(ins) == [val[0], val[1]]
    fixed = inst.var(case["bad_param"][0]).valueReference
    before = s.getReal([fixed])[0]
    vr[1] = fixed
    assert set_fn(s.component, vr, 2, val) == 3 and "fixed parameter" in last(inst)
    assert s.getReal([fixed])[0] == before
    steps(inst, 2, t)
    s.freeInstance()

