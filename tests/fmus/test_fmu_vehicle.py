"""WheelLoad.fmu and Vehicle.fmu through FMI (fmpy): interfaces, data, t = 0 outputs, start switches,
the wheel's energy balance, and the bundled data file loading inside the FMU (the FMI contract
every FMU meets, validation, state, errors, independent instances, is tests/fmus/test_fmu_contract.py)."""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap

import pytest
from fmpy import read_model_description

from fmu_session import free, get, start
from spurdiff.datafile import read_data
from spurdiff.vehicle.tyre import magic_formula
from spurdiff.fmi.vehicle_fmu import DEFAULT_SPEED

DATA = read_data()
R = DATA["wheel"]["R"]


@pytest.fixture(scope="module")
def wheel_fmu(fmu_files):
    return fmu_files["WheelLoad"]


@pytest.fixture(scope="module")
def vehicle_fmu(fmu_files):
    return fmu_files["Vehicle"]


WHEEL_IN = {"flange.w": 31.0, "Fz": 3000.0, "mu": 1.0, "vx": 10.0}
CAR_IN = {"speedTarget": 10.0, "pathRadius": 20.0, "mu": 1.0}


def wheel_steps(inst, n, h=1e-3, t0=0.0, w=31.0):
    """Step a wheel with a flange turning at w (angle input consistent with the speed)."""
    for k in range(n):
        t = t0 + k * h
        inst.set_value("flange.phi", w * t)
        inst.slave.doStep(t, h)
    return t0 + n * h


# ---------------------------------------------------------------- model description
def test_interfaces_and_display_units(wheel_fmu, vehicle_fmu):
    w = {v.name: v for v in read_model_description(str(wheel_fmu)).modelVariables}
    c = {v.name: v for v in read_model_description(str(vehicle_fmu)).modelVariables}
    assert {n for n, v in w.items() if v.causality == "input"} == {"flange.phi", "flange.w", "Fz", "mu", "vx", "shaftIn.tau",
                                                                     "shaftIn.dw", "FzRate", "vxRate"}
    assert {"flange.tau", "Fx", "wheel.w", "slip", "shaft.tau", "shaft.power", "workFlange", "energyLoss",
            "energyResidual"} <= {n for n, v in w.items() if v.causality == "output"}
    assert {n for n, v in c.items() if v.causality == "input"} == {
        "rearLeft.Fx", "rearRight.Fx", "speedTarget", "pathRadius", "steeringAngleCommand", "grade", "mu",
        "speedTargetRate", "pathRadiusRate"}
    assert {"rearLeft.vx", "rearRight.vx", "rearLeft.Fz", "rearRight.Fz", "speed", "yawRate", "ax", "ay",
            "driveTorque", "x", "y", "psi", "steeringAngle", "rearLeft.FzRate", "rearRight.FzRate", "rearLeft.vxRate",
            "rearRight.vxRate"} <= {n for n, v in c.items() if v.causality == "output"}
    assert (w["FzRate"].unit, c["rearLeft.FzRate"].unit, w["vxRate"].unit) == ("N/s", "N/s", "m/s2")
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
            if (section, k) == ("vehicle", "vx_start"):   # the default experiment's speed, not vehicle data
                assert float(c["vehicle.vx_start"].start) == DEFAULT_SPEED and value == 0.0
                continue
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
# ---------------------------------------------------------------- state, instances
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
    """In a process where the editable spurdiff is hidden, the FMUs import their own copy of the
    package from their resources/ folder (under a private name, never as ``spurdiff``) and read
    their bundled passenger_car.toml."""
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
            pkg = [m for n, m in sys.modules.items() if n.startswith("_spurdiff_fmu_") and "." not in n
                   and str(getattr(m, "__file__", "")).startswith(str(d))]
            assert len(pkg) == 1 and "spurdiff" not in sys.modules, (pkg, "spurdiff" in sys.modules)
            out[name] = {{"value": s.getReal([vr[key]])[0], "package": pkg[0].__file__,
                          "data": sys.modules[pkg[0].__name__ + ".datafile"].read_data()["vehicle"]["m"]}}
            s.terminate()
            s.freeInstance()
        print(json.dumps(out))
    """)
    # the Python started at fmi2Instantiate: at their defaults the FMUs would start natively, no package loaded
    p = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=120,
                       env={**os.environ, "SPURDIFF_FMU_START": "python"})
    assert p.returncode == 0, p.stderr + p.stdout
    out = json.loads(p.stdout.strip().splitlines()[-1])
    assert out["WheelLoad"]["value"] == DATA["halfShaft"]["c"]
    assert out["Vehicle"]["value"] == DATA["vehicle"]["m"]
    for name in ("WheelLoad", "Vehicle"):
        assert str(tmp_path) in out[name]["package"] and "/resources/spurdiff.zip/spurdiff/" in out[name]["package"]
        assert out[name]["data"] == DATA["vehicle"]["m"]


# ---------------------------------------------------------------- the compiled steps
def test_the_fmus_run_their_compiled_step_bit_for_bit(wheel_fmu, vehicle_fmu):
    """solver.kernel: the Vehicle and WheelLoad FMUs carry the compiled kernel (spurdiff.vehicle.kernel)
    and say which implementation runs (solver.kernelInUse); through FMI the compiled and the Python
    step give the same outputs bit for bit over 300 steps."""
    import shutil

    cases = ((wheel_fmu, WHEEL_IN, ("flange.tau", "Fx", "wheel.w", "slip", "shaft.tau", "workFlange", "energyLoss")),
             (vehicle_fmu, CAR_IN, ("vx", "vy", "yawRate", "rearLeft.Fz", "rearRight.vx", "driveTorque", "ay", "x",
                                    "rearLeft.FzRate", "speed")))
    for fmu, inputs, names in cases:
        seen, outs = {}, {}
        for kernel in ("python", "auto"):
            inst = start(fmu, f"k{kernel}", params={"solver.kernel": kernel}, inputs=inputs)
            seen[kernel] = inst.slave.getString([inst.var("solver.kernelInUse").valueReference])[0].decode()
            rows = []
            for k in range(300):
                t = k * 2e-3
                if "flange.w" in inputs:
                    inst.set_value("flange.phi", 31.0 * t + 0.01 * math.sin(40.0 * t))
                else:
                    inst.set_value("rearLeft.Fx", 300.0 + 200.0 * math.sin(3.0 * t))
                inst.slave.doStep(t, 2e-3)
                rows.append(get(inst, *names))
            outs[kernel] = rows
            free(inst)
        assert seen["python"] == "python (kernel = python)", seen
        if shutil.which("cc") or shutil.which("gcc"):   # the build shipped the library
            assert seen["auto"] == "compiled", seen
        assert outs["python"] == outs["auto"]
        assert outs["python"][0] != outs["python"][-1]
