"""First-order hold between the car and the wheels (issue 19 item 2): the vehicle's rate outputs
(``rearLeft.FzRate``, ``.vxRate``: the mean rates over its last step), the wheel's rate inputs
(``FzRate``, ``vxRate``, ``wheelLoad.rampAnchor``) and the vehicle's command-input rates
(``speedTargetRate``, ``pathRadiusRate``). Unconnected (0) they change nothing; connected, the
inputs ramp over the step, which is exact for a ramp whatever the step sequence."""
from __future__ import annotations

import math
import random

import pytest

from spurdiff.errors import ParameterError
from spurdiff.vehicle.car import Vehicle, VehicleParams
from spurdiff.vehicle.wheel import WheelLoad, WheelLoadParams

R = 0.3266


def wheel(shaft="torque", anchor="start", Fz=3000.0, vx=10.0, w=31.0) -> WheelLoad:
    p = WheelLoadParams.defaults()
    p.shaftCoupling, p.rampAnchor, p.interfaceStiffness = shaft, anchor, 0
    m = WheelLoad(p)
    m.Fz, m.vx, m.mu, m.flange_w, m.flange_phi = Fz, vx, 1.0, w, 0.0
    m.tau_in = 150.0
    m.initialize(0.0)
    return m


def car(h_cg=0.55, vx=11.0) -> Vehicle:
    p = VehicleParams.defaults()
    p.vehicle.h_cg, p.vehicle.vx_start = h_cg, vx
    v = Vehicle(p)
    v.mu, v.speedTarget, v.pathRadius = 1.0, vx, 30.0
    v.initialize(0.0)
    return v


def step_wheel(m: WheelLoad, t: float, h: float) -> None:
    m.do_step(t, h)
    m.flange_phi += m.flange_w * h


# Fz and vx as functions of time: a ramp each (the first-order hold is exact for them)
def Fz_of(t):
    return 3000.0 - 4000.0 * t


def vx_of(t):
    return 10.0 + 3.0 * t


@pytest.mark.parametrize("shaft", ["torque", "wheel"])
def test_unconnected_rates_are_the_held_inputs_bit_for_bit(shaft):
    """Rates 0 (the defaults, what an unconnected input holds), with either anchor: the same
    trajectory, bit for bit, as a wheel never given them (the held inputs); a rate changes it."""
    ref = wheel(shaft)
    for t in range(20):
        step_wheel(ref, t * 5e-3, 5e-3)
    for anchor in ("start", "end"):
        m = wheel(shaft, anchor)
        for t in range(20):
            m.dFz, m.dvx = 0.0, 0.0
            step_wheel(m, t * 5e-3, 5e-3)
        assert m.get_state() == ref.get_state()
    m = wheel(shaft)
    m.dFz = -1000.0
    step_wheel(m, 0.0, 5e-3)
    assert m.Fx != wheel(shaft).Fx and m.w != ref.w


def test_unconnected_command_rates_are_the_held_inputs_bit_for_bit():
    a, b = car(), car()
    for k in range(50):
        for v in (a, b):
            v.rearLeft_Fx = v.rearRight_Fx = 200.0
            v.pathRadius = 30.0 - 10.0 * k * 5e-3
        b.speedTargetRate = b.pathRadiusRate = 0.0
        a.do_step(k * 5e-3, 5e-3)
        b.do_step(k * 5e-3, 5e-3)
    assert a.get_state() == b.get_state()


@pytest.mark.parametrize("shaft", ["torque", "wheel"])
def test_a_ramp_over_one_step_is_sub_stepping_with_the_midpoint_inputs(shaft):
    """One 10 ms step with the inputs ramping (the wheel sub-steps at 1 ms) ends where ten 1 ms
    steps with the inputs held at each one's midpoint value end."""
    coarse = wheel(shaft)
    coarse.Fz, coarse.vx, coarse.dFz, coarse.dvx = Fz_of(0.0), vx_of(0.0), -4000.0, 3.0
    step_wheel(coarse, 0.0, 1e-2)
    fine = wheel(shaft)
    for i in range(10):
        fine.Fz, fine.vx = Fz_of((i + 0.5) * 1e-3), vx_of((i + 0.5) * 1e-3)
        step_wheel(fine, i * 1e-3, 1e-3)
    # (theta: with shaftCoupling = wheel the deviation from the step's anchor motion, per step)
    for k in ("w", "k", "phi", "work_road", "loss_slip", "loss_rolling") + (("theta",) if shaft == "torque" else ()):
        assert getattr(coarse, k) == pytest.approx(getattr(fine, k), rel=1e-12, abs=1e-15), k
    # the outputs are those at the end of the ramp
    assert coarse.Fx == pytest.approx(fine.Fx * Fz_of(1e-2) / Fz_of(9.5e-3), rel=1e-12)
    assert abs(coarse.energy_residual) < 1e-9


def test_end_anchor_is_the_ramp_that_ends_at_the_inputs():
    """rampAnchor = end (a wheel stepped after the car, which hands its outputs at the end of the
    step): the same ramp as rampAnchor = start given the values at the start."""
    a, b = wheel(anchor="start"), wheel(anchor="end")
    h = 1e-2
    a.Fz, a.vx, a.dFz, a.dvx = Fz_of(0.0), vx_of(0.0), -4000.0, 3.0
    b.Fz, b.vx, b.dFz, b.dvx = Fz_of(h), vx_of(h), -4000.0, 3.0
    step_wheel(a, 0.0, h)
    step_wheel(b, 0.0, h)
    for k in ("w", "k", "theta", "Fx", "work_road"):
        assert getattr(b, k) == pytest.approx(getattr(a, k), rel=1e-12), k


def test_a_load_ramping_through_zero_lifts_the_wheel_inside_the_step():
    """The load reaches 0 in the middle of the step: the tyre carries force until then, none
    after (the sub-steps take the ramp, not below 0); at the end Fx = 0."""
    h = 1e-2
    m = wheel(Fz=400.0)
    m.dFz = -80000.0            # 0 at 5 ms
    step_wheel(m, 0.0, h)
    assert m.Fx == 0.0
    held0, held_end = wheel(Fz=400.0), wheel(Fz=0.0)
    step_wheel(held0, 0.0, h)
    step_wheel(held_end, 0.0, h)
    # half a step of load: the wheel's slip work lies between none and a full step's
    assert 0.0 < m.loss_slip < held0.loss_slip
    assert held_end.loss_slip == 0.0


def test_ramped_inputs_are_second_order_against_held_ones():
    """Smooth inputs sampled at each step's start and end (a car stepped before the wheel): the
    ramp between the samples (rampAnchor = end, the car's mean rates) is far closer to a fine
    run than the held end values (the coupling before)."""
    def Fz(t):
        return 3000.0 + 1500.0 * math.sin(6.0 * t)

    def vx(t):
        return 10.0 + 2.0 * math.sin(3.0 * t)

    def go(h, ramp):
        m = wheel(anchor="end")
        for k in range(int(round(0.6 / h))):
            t = k * h
            m.Fz, m.vx = Fz(t + h), vx(t + h)
            if ramp:
                m.dFz, m.dvx = (Fz(t + h) - Fz(t)) / h, (vx(t + h) - vx(t)) / h
            step_wheel(m, t, h)
        return m

    ref = go(1e-4, True)
    held, ramped = go(1e-2, False), go(1e-2, True)
    e_held, e_ramp = abs(held.w - ref.w), abs(ramped.w - ref.w)
    assert e_ramp < 0.05 * e_held
    assert abs(ramped.Fx - ref.Fx) < 0.05 * abs(held.Fx - ref.Fx)


def test_car_rate_outputs_are_the_mean_rates_over_the_step_and_derivatives_at_the_start():
    v = car()
    v.rearLeft_Fx = v.rearRight_Fx = 600.0       # more than the steady drive: the car speeds up
    v.initialize(0.0)
    assert v.rearLeft_dFz == 0.0 and v.rearRight_dFz == 0.0    # load transfer at its fixed point
    s0 = (v.rearLeft_vx, v.rearRight_vx)
    d0 = (v.rearLeft_dvx, v.rearRight_dvx)
    assert d0[0] > 0.1 and d0[1] > 0.1
    v.do_step(0.0, 1e-7)
    assert (v.rearLeft_vx - s0[0]) / 1e-7 == pytest.approx(d0[0], rel=1e-5)
    assert (v.rearRight_vx - s0[1]) / 1e-7 == pytest.approx(d0[1], rel=1e-5)
    t = 1e-7
    for k in range(30):
        v.pathRadius = 30.0 - 400.0 * t            # tightening: load moves to the right wheel
        before = (v.rearLeft_vx, v.rearRight_vx, v.rearLeft_Fz, v.rearRight_Fz)
        v.do_step(t, 1e-2)
        t += 1e-2
        after = (v.rearLeft_vx, v.rearRight_vx, v.rearLeft_Fz, v.rearRight_Fz)
        rates = (v.rearLeft_dvx, v.rearRight_dvx, v.rearLeft_dFz, v.rearRight_dFz)
        assert rates == tuple((a - b) / 1e-2 for a, b in zip(after, before))
    assert v.rearLeft_dFz < -100.0 and v.rearRight_dFz > 100.0


def test_command_ramps_over_a_coarse_step_match_fine_steps():
    """pathRadius and speedTarget ramping (30 -> 20 m, 11 -> 12 m/s over 0.5 s): 10 ms steps with
    the rates end where 0.1 ms steps end; held over the 10 ms step they lag by half a step (the
    error of wheel-lift's path radius before its scene gave the rate).
    (The rear tyre forces are constant here: their own coupling is another matter.)"""
    def go(h, rates):
        v = car()
        for k in range(int(round(0.5 / h))):
            t = k * h
            v.rearLeft_Fx = v.rearRight_Fx = 400.0
            v.pathRadius, v.speedTarget = 30.0 - 20.0 * t, 11.0 + 2.0 * t
            if rates:
                v.pathRadiusRate, v.speedTargetRate = -20.0, 2.0
            v.do_step(t, h)
        return v

    ref = go(1e-4, True)
    held, ramped = go(1e-2, False), go(1e-2, True)
    for q in ("yawRate", "ay", "rearRight_Fz", "driveTorque"):
        e_held, e_ramp = abs(getattr(held, q) - getattr(ref, q)), abs(getattr(ramped, q) - getattr(ref, q))
        assert e_ramp < 1e-3 * e_held, q          # exact for a ramp (up to the integrator's error)
    assert ramped.yawRate == pytest.approx(ref.yawRate, rel=1e-8)


def coupled(steps, T=0.8):
    """Car and two wheels (driven by half the car's drive torque each), Gauss-Seidel with the car
    first as in the vehicle scenes: the wheels ramp to the car's outputs (rampAnchor = end), the
    car's path radius ramps (its input and rate at the step's start). The car's state at T."""
    v = car(h_cg=0.7)
    wheels = []
    for side in ("Left", "Right"):
        m = wheel("wheel", "end", Fz=getattr(v, f"rear{side}_Fz"), vx=getattr(v, f"rear{side}_vx"))
        m.params.wheel.w_start = getattr(v, f"rear{side}_vx") / R * 1.002
        m.tau_in = v.driveTorque / 2.0
        m.initialize(0.0)
        wheels.append(m)
    t = 0.0
    while t < T - 1e-12:
        h = min(steps(), T - t)
        v.rearLeft_Fx, v.rearRight_Fx = wheels[0].Fx, wheels[1].Fx
        v.pathRadius, v.pathRadiusRate = (30.0 - 25.0 * t, -25.0) if t < 0.6 else (15.0, 0.0)
        v.do_step(t, h)
        for m, side in zip(wheels, ("Left", "Right")):
            m.Fz, m.vx = getattr(v, f"rear{side}_Fz"), getattr(v, f"rear{side}_vx")
            m.dFz, m.dvx = getattr(v, f"rear{side}_dFz"), getattr(v, f"rear{side}_dvx")
            m.tau_in = v.driveTorque / 2.0
            m.do_step(t, h)
        t += h
    return t, v, wheels


def test_any_step_sequence_agrees_with_fixed_steps():
    """Alternating 2/6 ms and random steps (0.5 to 10 ms) end where the fixed 4 ms run ends:
    the ramps take each step's own length, nothing assumes a constant step."""
    _, fixed, fw = coupled(lambda: 4e-3)
    seq = iter([2e-3, 6e-3] * 1000)
    rng = random.Random(19)
    for steps in (lambda: next(seq), lambda: rng.uniform(5e-4, 1e-2)):
        t, v, ws = coupled(steps)
        assert t == pytest.approx(0.8, abs=1e-12)
        # within the coupling error of the coarsest step (measured: 1e-5 and below)
        assert v.yawRate == pytest.approx(fixed.yawRate, rel=5e-5)
        assert v.vx == pytest.approx(fixed.vx, rel=3e-5)
        assert v.rearLeft_Fz == pytest.approx(fixed.rearLeft_Fz, rel=1e-4)
        for m, f in zip(ws, fw):
            assert m.w == pytest.approx(f.w, rel=5e-5)


def test_bad_rates_and_anchor_are_named_and_leave_the_state():
    m = wheel()
    step_wheel(m, 0.0, 1e-3)
    m.flange_phi += 1e-4   # the flange off the angle its held speed predicts: the step corrects the twist
    before = m.get_state()
    for attr, name in (("dFz", "FzRate"), ("dvx", "vxRate")):
        setattr(m, attr, math.nan)
        with pytest.raises(ParameterError, match=name):
            m.do_step(1e-3, 1e-3)
        setattr(m, attr, 0.0)
        assert m.get_state() == before
    v = car()
    v.do_step(0.0, 1e-3)
    state = v.get_state()
    for attr in ("pathRadiusRate", "speedTargetRate"):
        setattr(v, attr, math.inf)
        with pytest.raises(ParameterError, match=attr):
            v.do_step(1e-3, 1e-3)
        setattr(v, attr, 0.0)
        assert v.get_state() == state
    p = WheelLoadParams.defaults()
    p.rampAnchor = "middle"
    with pytest.raises(ParameterError, match=r"wheelLoad\.rampAnchor.*start or end"):
        WheelLoad(p).initialize(0.0)
