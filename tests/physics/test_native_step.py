"""The native steps of the car and the wheel (spurdiff.native_step; vk_car_native, vk_wheel_native in
fmu_src/native/kernels/vehicle_kernel.c): the whole communication step in C on one array equals the
model's Python step with the compiled kernel (itself bit for bit the Python reference, see
test_vehicle_kernel.py) bit for bit, state and every output after every step; a step the Python step
refuses is not taken (nothing but scratch changed) and the Python step then says why; the switch."""
from __future__ import annotations

import dataclasses
import math

import pytest

from spurdiff.errors import ParameterError, StepError
from spurdiff.vehicle.car import Vehicle, VehicleParams
from spurdiff.vehicle.wheel import WheelLoad, WheelLoadParams
from tests.physics.test_vehicle_kernel import _car_inputs, _car_params, _same, _started, _wheel_inputs, library  # noqa: F401


def _both(cls, params):
    """Two initialized models: the first steps in Python (around the compiled kernel), the second natively."""
    return [cls(dataclasses.replace(params)) for _ in range(2)]


def _outputs(plan, m) -> dict:
    return {k: getattr(m, k) for k in plan.outputs}


def _native_outputs(plan) -> dict:
    n = len(plan.inputs)
    return dict(zip(plan.outputs, plan.v[n:n + len(plan.outputs)]))


@pytest.mark.parametrize("mode", ["path", "angle"])
def test_car_native_step_is_the_python_step(library, mode):
    ref, nat = _started(_both(Vehicle, _car_params(mode)), _car_inputs(0))
    plan = nat.native_step()
    assert plan is not None and ref.kernel_note == "compiled"
    plan.load(nat)
    t = 0.0
    for i in range(1, 900):
        h = 0.005 if i % 7 else 0.013
        inputs = _car_inputs(i)
        for k, v in inputs.items():
            setattr(ref, k, v)
        ref.do_step(t, h)
        plan.v[0:len(plan.inputs)] = [inputs[k] for k in plan.inputs]
        assert plan.step(t, h)
        t += h
        assert _native_outputs(plan) == _outputs(plan, ref), i   # every output the FMU reads, bit for bit
        if i % 50 == 0 or i > 890:
            plan.store(nat)
            assert not _same(ref.get_state(), nat.get_state()), i
    assert nat.n_steps == ref.n_steps == 899 and nat.n_substeps == ref.n_substeps


@pytest.mark.parametrize("coupling, anchor, follow, h", [("wheel", "end", 1, 0.005), ("wheel", "start", 1, 0.0023),
                                                         ("torque", "start", 1, 2e-4), ("torque", "end", 0, 0.0021)])
def test_wheel_native_step_is_the_python_step(library, coupling, anchor, follow, h):
    p = WheelLoadParams.defaults()
    p.shaftCoupling, p.rampAnchor, p.followFlangeAngle = coupling, anchor, follow
    wheel_mode = coupling == "wheel"
    ref, nat = _started(_both(WheelLoad, p), _wheel_inputs(0, wheel_mode), flange_w=25.0)
    plan = nat.native_step()
    plan.load(nat)
    t = 0.0
    for i in range(1, 1200):
        inputs = _wheel_inputs(i, wheel_mode)
        for k, v in inputs.items():
            setattr(ref, k, v)
        ref.do_step(t, h)
        for j, k in enumerate(plan.inputs):
            if k in inputs:
                plan.v[j] = inputs[k]
        assert plan.step(t, h)
        t += h
        assert _native_outputs(plan) == _outputs(plan, ref), i
        if i % 100 == 0 or i > 1190:
            plan.store(nat)
            assert not _same(ref.get_state(), nat.get_state()), i
    assert ref.loss_slip > 0.0 and nat.n_substeps == ref.n_substeps


def _scratch_free(plan, start: int) -> list:
    """The array but its scratch (the io array of the step inside it, from ``start``)."""
    v = [x if x == x else "nan" for x in plan.v]
    return v[:start] + v[start + 60:]


def test_car_native_step_refuses_what_the_python_step_refuses(library):
    m = Vehicle(VehicleParams.defaults())
    m.speedTarget, m.pathRadius = 10.0, 20.0
    m.initialize(0.0)
    plan = m.native_step()
    plan.load(m)
    assert plan.step(0.0, 0.005)
    ins = list(plan.v[0:9])
    for slot, bad, error in ((0, math.nan, ParameterError), (7, 0.8, ParameterError), (8, -0.1, ParameterError),
                             (4, math.inf, ParameterError), (3, math.nan, ParameterError),
                             (0, 1e308, StepError)):
        plan.v[0:9] = ins
        plan.v[slot] = bad
        if error is StepError:
            plan.v[1] = 1e308
        before = _scratch_free(plan, 48)
        assert not plan.step(0.005, 0.005), (slot, bad)
        assert _scratch_free(plan, 48) == before
        plan.store(m)
        for k, x in zip(plan.inputs, plan.v[0:9]):
            setattr(m, k, x)
        state = m.get_state()
        with pytest.raises(error):
            m.do_step(0.005, 0.005)
        assert m.t == state["t"] == 0.005
    plan.v[0:9] = ins
    assert not plan.step(0.005, 0.0) and not plan.step(0.005, math.inf)   # the step size too
    assert plan.step(0.005, 0.005)


def test_wheel_native_step_refuses_what_the_python_step_refuses(library):
    p = WheelLoadParams.defaults()
    p.shaftCoupling = "wheel"
    m = WheelLoad(p)
    m.flange_w, m.Fz, m.mu, m.vx = 25.0, 3000.0, 1.0, 8.0
    m.initialize(0.0)
    plan = m.native_step()
    plan.load(m)
    assert plan.step(0.0, 0.005)
    ins = list(plan.v[0:9])
    for slot, bad in ((3, -0.5), (4, math.nan), (5, math.inf), (2, math.nan), (7, math.nan)):
        plan.v[0:9] = ins
        plan.v[slot] = bad
        assert not plan.step(0.005, 0.005), (slot, bad)
        plan.store(m)
        for k, x in zip(plan.inputs, plan.v[0:9]):
            setattr(m, k, x)
        with pytest.raises(ParameterError):
            m.do_step(0.005, 0.005)
        assert m.t == 0.005


def test_the_switch(library):
    """solver.nativeStep false or the Python kernel: no native step; a new kernel: a new plan."""
    for cls, params in ((Vehicle, VehicleParams.defaults()), (WheelLoad, WheelLoadParams.defaults())):
        on, off, py = (cls(dataclasses.replace(params)) for _ in range(3))
        off.params.nativeStep = 0
        py.kernel = "python"
        for m in (on, off, py):
            if cls is WheelLoad:
                m.flange_w, m.Fz, m.vx = 25.0, 3000.0, 8.0
            m.initialize(0.0)
        assert on.native_step() is on.native_step() is not None
        assert off.native_step() is None and py.native_step() is None
    bad = VehicleParams.defaults()
    bad.nativeStep = 2
    with pytest.raises(ParameterError, match="solver.nativeStep"):
        bad.validate()
