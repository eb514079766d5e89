"""WheelLoad.fmu and Vehicle.fmu through FMI (fmpy): validation, data, t = 0 outputs, errors, state,
independent instances, and the bundled data file loading inside the FMU."""
from __future__ import annotations

import json
import math
import subprocess
import sys
import textwrap

import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from harness.master import Instance
from spurdiff.datafile import read_data
from spurdiff.tyre import magic_formula

DATA = read_data()
R = DATA["wheel"]["R"]


@pytest.fixture(scope="module")
def wheel_fmu(fmu_files):
    return fmu_files["WheelLoad"]


@pytest.fixture(scope="module")
def vehicle_fmu(fmu_files):
    return fmu_files["Vehicle"]


def start(fmu, name, params=None, inputs=None, expect_error=False):
    inst = Instance(name, fmu)
    s = inst.slave
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    for k, v in {**(params or {}), **(inputs or {})}.items():
        inst.set_value(k, v)
    if expect_error:   # invalid parameters: fmi2ExitInitializationMode returns fmi2Error
        from fmpy.fmi1 import FMICallException
        with pytest.raises(FMICallException, match="status 3"):
            s.exitInitializationMode()
    else:
        s.exitInitializationMode()
    return inst


def get(inst, *names):
    return inst.slave.getReal([inst.var(n).valueReference for n in names])


def free(inst):
    inst.slave.terminate()
    inst.slave.freeInstance()


WHEEL_IN = {"flange.w": 31.0, "Fz": 3000.0, "mu": 1.0, "vx": 10.0}
CAR_IN = {"speedTarget": 10.0, "pathRadius": 20.0, "mu": 1.0}


def wheel_steps(inst, n, h=1e-3, t0=0.0, w=31.0):
    """Step a wheel with a flange turning at w (angle input consistent with the speed)."""
    for k in range(n):
        t = t0 + k * h
        inst.set_value("flange.phi", w * t)
        inst.slave.doStep(t, h)
    return t0 + n * h


def car_steps(inst, n, h=1e-3, t0=0.0, Fx=240.0):
    for k in range(n):
        inst.set_value("rearLeft.Fx", Fx)
        inst.set_value("rearRight.Fx", Fx)
        inst.slave.doStep(t0 + k * h, h)
    return t0 + n * h


# ---------------------------------------------------------------- model description
@pytest.mark.parametrize("name", ["WheelLoad", "Vehicle"])
def test_fmpy_validate_finds_no_problem(fmu_files, name):
    assert validate_fmu(str(fmu_files[name])) == []


@pytest.mark.parametrize("name", ["WheelLoad", "Vehicle"])
def test_every_real_has_a_unit_and_every_variable_a_description(fmu_files, name):
    md = read_model_description(str(fmu_files[name]))
    assert md.modelName == name and md.coSimulation.modelIdentifier == name
    assert all(v.unit for v in md.modelVariables if v.type == "Real")
    assert all(v.description for v in md.modelVariables)
    assert all(u.variable.causality in ("output", "calculatedParameter") for u in md.initialUnknowns)


def test_interfaces_and_display_units(wheel_fmu, vehicle_fmu):
    w = {v.name: v for v in read_model_description(str(wheel_fmu)).modelVariables}
    c = {v.name: v for v in read_model_description(str(vehicle_fmu)).modelVariables}
    assert {n for n, v in w.items() if v.causality == "input"} == {"flange.phi", "flange.w", "Fz", "mu", "vx", "shaftIn.tau",
                                                                     "shaftIn.dw"}
    assert {"flange.tau", "Fx", "wheel.w", "slip", "shaft.tau", "shaft.power", "workFlange", "energyLoss",
            "energyResidual"} <= {n for n, v in w.items() if v.causality == "output"}
    assert {n for n, v in c.items() if v.causality == "input"} == {
        "rearLeft.Fx", "rearRight.Fx", "speedTarget", "pathRadius", "steeringAngleCommand", "grade", "mu"}
    assert {"rearLeft.vx", "rearRight.vx", "rearLeft.Fz", "rearRight.Fz", "speed", "yawRate", "ax", "ay",
            "driveTorque", "x", "y", "psi", "steeringAngle"} <= {n for n, v in c.items() if v.causality == "output"}
    assert (w["flange.tau"].unit, w["flange.tau"].displayUnit) == ("N.m", "N.mm")
    assert (w["wheel.w"].unit, w["wheel.w"].displayUnit) == ("rad/s", "rpm")
    assert (w["vx"].unit, w["vx"].displayUnit) == ("m/s", "km/h")
    assert (w["wheel.R"].unit, w["wheel.R"].displayUnit) == ("m", "mm")
    assert (c["steeringAngle"].unit, c["steeringAngle"].displayUnit) == ("rad", "deg")
    assert (c["vehicle.L"].unit, c["vehicle.L"].displayUnit) == ("m", "mm")
    assert (c["speedTarget"].unit, c["speedTarget"].displayUnit) == ("m/s", "km/h")


def test_parameter_start_values_are_the_bundled_data(wheel_fmu, vehicle_fmu):
    w = {v.name: v for v in read_model_description(str(wheel_fmu)).modelVariables}
    c = {v.name: v for v in read_model_description(str(vehicle_fmu)).modelVariables}
    for section, keys in (("halfShaft", ("c", "d")), ("wheel", ("J", "R")),
                          ("tyre", ("B", "C", "E", "sigma", "f_rr", "w_eps", "k_max"))):
        for k in keys:
            assert float(w[f"{section}.{k}"].start) == DATA[section][k], f"{section}.{k}"
    assert float(w["wheelLoad.h_max"].start) == DATA["wheelLoad"]["h_max"]
    # the data file's NaN start values ("automatic") become switches in FMI
    assert math.isnan(DATA["wheel"]["w_start"]) and w["wheel.w_startFromFlange"].start in ("true", True)
    assert math.isnan(DATA["tyre"]["k_start"]) and w["tyre.k_startSteady"].start in ("true", True)
    for section in ("vehicle", "lateralTyre", "speedControl"):
        for k, value in DATA[section].items():
            assert float(c[f"{section}.{k}"].start) == value, f"{section}.{k}"
    assert int(c["steering.mode"].start) == DATA["steering"]["mode"]
    assert float(c["vehicle.R_wheel"].start) == DATA["wheel"]["R"]
    assert float(w["mu"].start) == float(c["mu"].start) == DATA["road"]["mu"]


# ---------------------------------------------------------------- outputs at t = 0
def test_wheel_outputs_at_time_zero(wheel_fmu):
    inst = start(wheel_fmu, "w0", params={"halfShaft.phi_rel_start": 0.01}, inputs=WHEEL_IN)
    tau, ftau, ww, k, Fx, power = get(inst, "shaft.tau", "flange.tau", "wheel.w", "slip", "Fx", "shaft.power")
    c = DATA["halfShaft"]["c"]
    k0 = (R * 31.0 - 10.0) / 10.0                 # steady transient slip for the start speeds
    assert tau == pytest.approx(c * 0.01, rel=1e-15) and ftau == -tau
    assert ww == 31.0                             # starts at the flange speed
    assert k == pytest.approx(k0, rel=1e-14)
    assert Fx == pytest.approx(3000.0 * magic_formula(k0, 10.0, 1.9, 0.97), rel=1e-14)
    assert power == pytest.approx(tau * 31.0, rel=1e-15)
    assert get(inst, "energyLoss", "workFlange") == [0.0, 0.0]
    free(inst)


def test_wheel_start_switches(wheel_fmu):
    inst = start(wheel_fmu, "w1", inputs=WHEEL_IN, params={
        "wheel.w_startFromFlange": False, "wheel.w_start": 30.0, "tyre.k_startSteady": False, "tyre.k_start": 0.05})
    assert get(inst, "wheel.w", "slip") == [30.0, 0.05]
    free(inst)


def test_vehicle_outputs_at_time_zero(vehicle_fmu):
    """Started in the steady 20 m turn at 10 m/s: kinematics and load sums are exact at t = 0."""
    inst = start(vehicle_fmu, "car0", params={"vehicle.vx_start": 10.0}, inputs=CAR_IN)
    vx, r, vl, vr, fl, fr, fa, ra, T, delta = get(inst, "vx", "yawRate", "rearLeft.vx", "rearRight.vx",
                                                  "rearLeft.Fz", "rearRight.Fz", "frontAxle.Fz", "rearAxle.Fz",
                                                  "driveTorque", "steeringAngle")
    v = DATA["vehicle"]
    assert vx == 10.0 and r == pytest.approx(0.5, rel=1e-15)
    assert vl == pytest.approx(10.0 - 0.5 * v["trackRear"] / 2, rel=1e-15)
    assert vr == pytest.approx(10.0 + 0.5 * v["trackRear"] / 2, rel=1e-15)
    assert fr > fl > 0.0 and fl + fr == pytest.approx(ra, rel=1e-14)
    assert fa + ra == pytest.approx(v["m"] * 9.80665, rel=1e-14)
    assert T > 0.0                                 # holding torque against drag and cornering drag
    assert 0.0 < delta < 0.6 and delta == pytest.approx(math.atan(v["L"] / 20.0), rel=0.2)
    free(inst)


# ---------------------------------------------------------------- errors
@pytest.mark.parametrize("name,params,param,allowed", [
    ("WheelLoad", {"halfShaft.c": -8000.0}, "halfShaft.c", "> 0"),
    ("WheelLoad", {"tyre.C": 2.5}, "tyre.C", "0 < C <= 2"),
    ("WheelLoad", {"wheelLoad.h_max": 0.5}, "wheelLoad.h_max", "between 0 and 0.1"),
    ("Vehicle", {"vehicle.l_f": 3.0}, "vehicle.l_f", "0 < l_f < L"),
    ("Vehicle", {"steering.mode": 2}, "steering.mode", "0 (path radius) or 1"),
    ("Vehicle", {"speedControl.driveTorqueMin": 100.0}, "speedControl.driveTorqueMin", "<= 0"),
])
def test_bad_parameter_is_logged_by_name_and_steps_refused(fmu_files, name, params, param, allowed):
    from fmpy.fmi1 import FMICallException
    inst = start(fmu_files[name], "bad", params=params, expect_error=True)
    errs = inst.errors()
    assert errs and param in errs[0] and allowed in errs[0]
    with pytest.raises(FMICallException):
        inst.slave.doStep(0.0, 1e-3)
    assert any(param in m for m in inst.errors()[1:])   # the refusal repeats the reason
    free(inst)


@pytest.mark.parametrize("name,inputs,bad", [
    ("WheelLoad", WHEEL_IN, "Fz"),
    ("WheelLoad", WHEEL_IN, "flange.w"),
    ("Vehicle", CAR_IN, "steeringAngleCommand"),
    ("Vehicle", CAR_IN, "rearLeft.Fx"),
])
def test_nan_input_discards_the_step_names_it_and_keeps_the_state(fmu_files, name, inputs, bad):
    from fmpy.fmi1 import FMICallException
    params = {"vehicle.vx_start": 10.0} if name == "Vehicle" else {}
    stepper = wheel_steps if name == "WheelLoad" else car_steps
    inst = start(fmu_files[name], "nan", params=params, inputs=inputs)
    ref = start(fmu_files[name], "ref", params=params, inputs=inputs)
    t = stepper(inst, 5)
    stepper(ref, 5)
    good = get(inst, bad) if inst.var(bad).causality == "input" else None
    inst.slave.setReal([inst.var(bad).valueReference], [float("nan")])   # past the harness's own check
    with pytest.raises(FMICallException):
        inst.slave.doStep(t, 1e-3)
    # fmpy's logger proxy (addLoggerProxy) keeps one static logger per process, so the message
    # reaches the callback of the instance instantiated last: look in both instances' logs
    errs = [m for s, m in inst.messages + ref.messages if s >= 2]   # the refusal is logged with fmi2Discard
    assert len(errs) == 1 and bad in errs[0] and "finite" in errs[0]
    inst.set_value(bad, good[0])
    stepper(inst, 5, t0=t)          # recovers from the last successful state
    stepper(ref, 5, t0=t)
    outs = [v for v in inst.vars.values() if v.causality == "output" and v.type == "Real"]
    vrs = [v.valueReference for v in outs]
    assert inst.slave.getReal(vrs) == ref.slave.getReal(vrs)
    free(inst)
    free(ref)


# ---------------------------------------------------------------- state, instances
@pytest.mark.parametrize("serialize", [False, True])
@pytest.mark.parametrize("name", ["WheelLoad", "Vehicle"])
def test_state_restore_reproduces_the_continuation(fmu_files, name, serialize):
    params = {"vehicle.vx_start": 10.0} if name == "Vehicle" else {}
    inputs = CAR_IN if name == "Vehicle" else WHEEL_IN
    stepper = wheel_steps if name == "WheelLoad" else car_steps
    inst = start(fmu_files[name], "st", params=params, inputs=inputs)
    t = stepper(inst, 20)
    state = inst.slave.getFMUstate()
    if serialize:
        blob = inst.slave.serializeFMUstate(state)
        inst.slave.freeFMUstate(state)
        state = inst.slave.deSerializeFMUstate(blob)
    stepper(inst, 40, t0=t)
    outs = [v.valueReference for v in inst.vars.values() if v.causality == "output" and v.type == "Real"]
    first = inst.slave.getReal(outs)
    inst.slave.setFMUstate(state)
    stepper(inst, 40, t0=t)
    assert inst.slave.getReal(outs) == first
    free(inst)


def test_two_wheel_instances_are_independent(wheel_fmu):
    """Two instances stepped in turn with different inputs give exactly what each gives alone."""
    def run(insts, n=50):
        for k in range(n):
            for inst, w in insts:
                inst.set_value("flange.phi", w * k * 1e-3)
                inst.slave.doStep(k * 1e-3, 1e-3)
        return [get(inst, "shaft.tau", "wheel.w", "slip", "Fx") for inst, _ in insts]

    b_in = {**WHEEL_IN, "flange.w": 40.0, "mu": 0.3, "Fz": 2000.0}
    a = start(wheel_fmu, "a", inputs=WHEEL_IN)
    b = start(wheel_fmu, "b", inputs=b_in, params={"halfShaft.c": 4000.0})
    together = run([(a, 31.0), (b, 40.0)])
    free(a)
    free(b)
    alone_a = start(wheel_fmu, "a", inputs=WHEEL_IN)
    ra = run([(alone_a, 31.0)])[0]
    free(alone_a)
    alone_b = start(wheel_fmu, "b", inputs=b_in, params={"halfShaft.c": 4000.0})
    rb = run([(alone_b, 40.0)])[0]
    free(alone_b)
    assert together == [ra, rb]
    assert together[0] != together[1]


def test_wheel_energy_outputs_balance(wheel_fmu):
    inst = start(wheel_fmu, "e", inputs={**WHEEL_IN, "flange.w": 33.0})
    wheel_steps(inst, 200, w=33.0)
    work, road, loss, ke, pe, res = get(inst, "workFlange", "workRoad", "energyLoss", "kineticEnergy",
                                        "potentialEnergy", "energyResidual")
    assert work > 0.0 and road > 0.0 and loss > 0.0
    assert abs(res) <= 1e-9 * work
    assert inst.slave.getInteger([inst.var("internalSteps").valueReference]) == [200]
    free(inst)


# ---------------------------------------------------------------- bundled package and data
def test_the_fmus_load_their_bundled_package_and_data(wheel_fmu, vehicle_fmu, tmp_path):
    """In a process where the editable spurdiff is hidden, the FMUs import spurdiff from their
    own resources/ folder and read their bundled passenger_car.toml."""
    code = textwrap.dedent(f"""
        import json, sys
        sys.meta_path[:] = [f for f in sys.meta_path if "Editable" not in type(f).__name__
                            and "Editable" not in getattr(f, "__name__", "")]
        try:
            import spurdiff
            raise SystemExit("spurdiff importable outside the FMU: " + spurdiff.__file__)
        except ImportError:
            pass
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave
        out = {{}}
        for path in ({str(wheel_fmu)!r}, {str(vehicle_fmu)!r}):
            d = extract(path, unzipdir={str(tmp_path)!r} + "/" + path.rsplit("/", 1)[1])
            md = read_model_description(d)
            vr = {{v.name: v.valueReference for v in md.modelVariables}}
            s = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier,
                          instanceName="x")
            s.instantiate()
            s.setupExperiment(startTime=0.0)
            s.enterInitializationMode()
            s.exitInitializationMode()
            s.doStep(0.0, 1e-3)
            name = md.modelName
            key = "halfShaft.c" if name == "WheelLoad" else "vehicle.m"
            out[name] = {{"value": s.getReal([vr[key]])[0], "package": sys.modules["spurdiff"].__file__,
                          "data": sys.modules["spurdiff.datafile"].read_data()["vehicle"]["m"]}}
            s.terminate()
            s.freeInstance()
        print(json.dumps(out))
    """)
    p = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr + p.stdout
    out = json.loads(p.stdout.strip().splitlines()[-1])
    assert out["WheelLoad"]["value"] == DATA["halfShaft"]["c"]
    assert out["Vehicle"]["value"] == DATA["vehicle"]["m"]
    for name in ("WheelLoad", "Vehicle"):
        assert str(tmp_path) in out[name]["package"] and "/resources/spurdiff/" in out[name]["package"]
        assert out[name]["data"] == DATA["vehicle"]["m"]
