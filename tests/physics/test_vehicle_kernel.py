"""The compiled steps of the car and the wheel (fmu_src/native/kernels/vehicle_kernel.c through
spurdiff.vehicle.kernel) against their Python reference: the models' whole state after every step
from the same inputs (path and angle steering, command ramps, grade, friction changes, a lifted
wheel; the wheel in both couplings with load and speed ramps), every recorded variable of the
vehicle scenes with solver.kernel = compiled and python, all bit for bit; the error paths; the
switch and the fallback."""
from __future__ import annotations

import dataclasses
import logging
import math

import numpy as np
import pytest

from harness.build.fmu import BuildError, kernel_library
from harness.run.direct import run_direct
from harness.run.runner import prepare_scene
from spurdiff.errors import ParameterError, StepError
from spurdiff.vehicle import kernel as vehicle_kernel
from spurdiff.vehicle.car import STEER_ANGLE, Vehicle, VehicleParams
from spurdiff.vehicle.wheel import WheelLoad, WheelLoadParams


@pytest.fixture(scope="module")
def library():
    try:
        kernel_library()          # the mesh and rigid kernels too: the scenes' differential runs as usual
    except BuildError as e:      # no compiler here: nothing to compare
        pytest.skip(f"the kernels cannot be compiled here: {e}")
    lib, where = vehicle_kernel.load()
    assert lib is not None, where
    return where


def _same(a: dict, b: dict) -> list[str]:
    """The keys whose values differ (NaN equal to NaN), bit for bit."""
    return [k for k in a if not (a[k] == b[k] or (isinstance(a[k], float) and math.isnan(a[k]) and math.isnan(b[k])))]


def _pair(cls, params, kernel_attrs: dict | None = None):
    out = []
    for k in ("python", "compiled"):
        m = cls(dataclasses.replace(params) if params is not None else None)
        m.kernel = k
        for name, v in (kernel_attrs or {}).items():
            setattr(m, name, v)
        out.append(m)
    return out


def _car_inputs(i: int) -> dict:
    """A sequence of car inputs that visits what the rate function branches on."""
    t = 0.005 * i
    return {"rearLeft_Fx": 800.0 * math.sin(0.7 * t) + 150.0, "rearRight_Fx": 600.0 * math.cos(0.5 * t),
            "speedTarget": 12.0 + 6.0 * math.sin(0.3 * t), "speedTargetRate": 1.8 * math.cos(0.3 * t),
            "pathRadius": (30.0 + 15.0 * math.sin(0.4 * t)) if i % 200 < 150 else math.inf,
            "pathRadiusRate": 6.0 * math.cos(0.4 * t) if i % 200 < 150 else 0.0,
            "grade": 0.1 * math.sin(0.2 * t), "mu": 1.0 if i % 300 < 200 else 0.35,
            "steering_angle_cmd": 0.3 * math.sin(1.3 * t)}


def _car_params(mode: str) -> VehicleParams:
    """The car from 8 m/s, steered along a path or by the wheel angle (``mode`` "path" or "angle")."""
    p = VehicleParams.defaults()
    p.vehicle.vx_start = 8.0
    if mode == "angle":
        p.steering.mode = STEER_ANGLE
    return p


def _started(models: list, inputs: dict, **attrs) -> list:
    """``models`` given ``inputs`` and ``attrs`` and initialized at t = 0."""
    for m in models:
        for k, v in {**inputs, **attrs}.items():
            setattr(m, k, v)
        m.initialize(0.0)
    return models


@pytest.mark.parametrize("mode", ["path", "angle"])
def test_car_state_after_every_step(library, mode):
    ref, cmp_ = _started(_pair(Vehicle, _car_params(mode)), _car_inputs(0))
    assert ref.kernel_note.startswith("python") and cmp_.kernel_note == "compiled"
    assert ref.get_state() == cmp_.get_state()
    t, steps = 0.0, 0
    for i in range(1, 1200):
        h = 0.005 if i % 7 else 0.013           # a longer step now and then: more RK4 sub-steps
        for m in (ref, cmp_):
            for k, v in _car_inputs(i).items():
                setattr(m, k, v)
            m.do_step(t, h)
        t += h
        steps += 1
        diff = _same(ref.get_state(), cmp_.get_state())
        assert not diff, (i, diff)
    assert ref.n_substeps == cmp_.n_substeps > steps


def test_car_nonfinite_step_refused_state_kept(library):
    ref, cmp_ = _pair(Vehicle, VehicleParams.defaults())
    for m in (ref, cmp_):
        m.speedTarget, m.pathRadius = 10.0, 20.0
        m.initialize(0.0)
        m.do_step(0.0, 0.005)
        before = m.get_state()
        m.rearLeft_Fx = 1e308                 # finite input, non-finite result
        m.rearRight_Fx = 1e308
        with pytest.raises(StepError, match="non-finite"):
            m.do_step(0.005, 0.005)
        assert _same(before, m.get_state()) == ["rearLeft_Fx", "rearRight_Fx"]


def _wheel_inputs(i: int, wheel_mode: bool) -> dict:
    t = 0.005 * i
    out = {"Fz": 3000.0 + 1500.0 * math.sin(0.9 * t) if i % 250 < 230 else -100.0,   # lifted now and then
           "dFz": 1350.0 * math.cos(0.9 * t), "vx": 8.0 + 4.0 * math.sin(0.4 * t), "dvx": 1.6 * math.cos(0.4 * t),
           "mu": 1.0 if i % 300 < 200 else 0.3}
    if wheel_mode:
        out.update(tau_in=300.0 * math.sin(0.8 * t) + 60.0 * math.sin(9.0 * t), dw_in=0.05 * math.cos(2.0 * t))
    else:
        w = 25.0 + 8.0 * math.sin(0.6 * t)
        out.update(flange_w=w, flange_phi=25.0 * t - 8.0 / 0.6 * (math.cos(0.6 * t) - 1.0) + 1e-3 * math.sin(5 * t))
    return out


@pytest.mark.parametrize("coupling, anchor, h", [("wheel", "end", 0.005), ("wheel", "start", 0.0023),
                                                 ("torque", "start", 2e-4), ("torque", "end", 0.0021)])
def test_wheel_state_after_every_step(library, coupling, anchor, h):
    p = WheelLoadParams.defaults()
    p.shaftCoupling, p.rampAnchor = coupling, anchor
    wheel_mode = coupling == "wheel"
    ref, cmp_ = _started(_pair(WheelLoad, p), _wheel_inputs(0, wheel_mode), flange_w=25.0)
    assert ref.kernel_note.startswith("python") and cmp_.kernel_note == "compiled"
    t = 0.0
    for i in range(1, 1500):
        for m in (ref, cmp_):
            for k, v in _wheel_inputs(i, wheel_mode).items():
                setattr(m, k, v)
            m.do_step(t, h)
        t += h
        diff = _same(ref.get_state(), cmp_.get_state())
        assert not diff, (i, diff)
    assert ref.n_substeps == cmp_.n_substeps >= 1499
    assert ref.work_road != 0.0 and ref.loss_slip > 0.0


def test_wheel_nonfinite_as_the_reference(library):
    """shaftCoupling = wheel: a step with a non-finite result is refused with the state kept (both);
    torque: not refused (the adapter's snapshot covers it), the same state both ways."""
    for coupling, attrs in (("wheel", {"dw_in": 1e308}), ("torque", {"flange_w": 1e308})):
        p = WheelLoadParams.defaults()
        p.shaftCoupling = coupling
        ref, cmp_ = _pair(WheelLoad, p)
        for m in (ref, cmp_):
            m.Fz, m.vx, m.flange_w = 3000.0, 10.0, 30.0
            m.initialize(0.0)
            m.do_step(0.0, 0.001)
            before = m.get_state()
            for k, v in attrs.items():
                setattr(m, k, v)
            if coupling == "wheel":
                with pytest.raises(StepError, match="non-finite"):
                    m.do_step(0.001, 0.001)
                assert _same(before, m.get_state()) == ["dw_in"]
            else:
                m.do_step(0.001, 0.001)
        assert not _same(ref.get_state(), cmp_.get_state())
        assert coupling == "wheel" or math.isinf(cmp_.w)


VEHICLE_SCENES = ["vehicle-cornering", "split-mu-launch", "tip-in-tip-out", "standstill-launch", "wheel-lift"]


def _with_kernel(scene, kernel: str):
    insts = [dataclasses.replace(s, parameters={**s.parameters, "solver.kernel": kernel})
             if s.fmu in ("Vehicle", "WheelLoad") else s for s in scene.instances]
    return dataclasses.replace(scene, instances=insts)


@pytest.mark.parametrize("name", VEHICLE_SCENES)
def test_scene_runs_identical(library, name):
    scene = prepare_scene(name)
    a = run_direct(_with_kernel(scene, "python"))
    b = run_direct(_with_kernel(scene, "compiled"))
    assert a.failure is None and b.failure is None
    assert a.data.shape == b.data.shape and a.data.shape[0] > 100
    assert np.array_equal(a.data, b.data), float(np.max(np.abs(a.data - b.data)))


def test_switch_values_and_fallback(library, monkeypatch, caplog):
    m = Vehicle()
    m.kernel = "fortran"
    with pytest.raises(ParameterError, match="solver.kernel"):
        m.initialize(0.0)
    # no library anywhere: auto runs the reference and says why once; compiled refuses
    monkeypatch.setattr(vehicle_kernel, "_LIB", None)
    monkeypatch.setattr(vehicle_kernel, "_candidates", lambda: [])
    monkeypatch.setattr(vehicle_kernel, "_REPORTED", set())
    with caplog.at_level(logging.WARNING, logger="spurdiff.vehicle"):
        for cls in (Vehicle, WheelLoad, WheelLoad):
            m = cls()
            m.initialize(0.0)
            assert m._vk is None and m.kernel_note == f"python ({vehicle_kernel.MISSING})"
    assert sum(vehicle_kernel.MISSING in r.getMessage() for r in caplog.records) == 1
    w = WheelLoad()
    w.kernel = "compiled"
    with pytest.raises(ParameterError, match="solver.kernel"):
        w.initialize(0.0)


def test_fmu_interfaces_carry_the_switch(library):
    from spurdiff.fmi import vehicle_fmu, wheel_fmu

    for iface in (vehicle_fmu, wheel_fmu):
        values = {v.name: v.start for v in iface.VARIABLES}
        assert values["solver.kernel"] == "auto"
        iface.build_model(values)
        assert values["solver.kernelInUse"] == "compiled"
        assert "compiled implementation" in iface.build_message(values)
        values = {v.name: v.start for v in iface.VARIABLES}
        values["solver.kernel"] = "python"
        model = iface.build_model(values)
        assert model._vk is None and values["solver.kernelInUse"].startswith("python")
