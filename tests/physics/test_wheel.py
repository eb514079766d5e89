"""WheelLoad (spurdiff.vehicle.wheel): half-shaft + wheel + tyre, stepped as the FMU will step it."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from spurdiff.errors import ParameterError
from spurdiff.vehicle.tyre import magic_formula, slip_for_force_ratio
from spurdiff.vehicle.wheel import WheelLoad, WheelLoadParams

R = 0.3266  # default rolling radius (checked below against the data file)


def make(Fz=3000.0, mu=1.0, vx=0.0, w_flange=0.0, **over) -> WheelLoad:
    """A wheel with default data; ``over`` sets parameters by structured name, e.g. ``tyre_k_start``."""
    p = WheelLoadParams.defaults()
    for key, value in over.items():
        group, name = key.split("_", 1) if "_" in key and key.split("_", 1)[0] in ("halfShaft", "wheel", "tyre") \
            else (None, key)
        setattr(getattr(p, group) if group else p, name, value)
    m = WheelLoad(p)
    m.Fz, m.mu, m.vx, m.flange_w, m.flange_phi = Fz, mu, vx, w_flange, 0.0
    m.initialize(0.0)
    return m


def run(m: WheelLoad, h: float, n: int, t0: float = 0.0, inputs=None) -> None:
    """Step n times, advancing the flange angle consistently with the held flange speed."""
    for i in range(n):
        t = t0 + i * h
        if inputs is not None:
            inputs(m, t)
        m.do_step(t, h)
        m.flange_phi += m.flange_w * h


def test_data_file_and_dataclass_defaults_agree():
    from_file = WheelLoadParams.defaults()
    built_in = WheelLoadParams()
    for group in ("halfShaft", "wheel", "tyre"):
        a, b = getattr(from_file, group), getattr(built_in, group)
        for k, va in vars(a).items():
            vb = getattr(b, k)
            assert (math.isnan(va) and math.isnan(vb)) or va == vb, f"{group}.{k}"
    assert (from_file.h_max, from_file.followFlangeAngle) == (built_in.h_max, built_in.followFlangeAngle)
    assert from_file.wheel.R == R


def test_unknown_data_key_is_named():
    with pytest.raises(ParameterError) as e:
        WheelLoadParams.from_data({"halfShaft": {"stiffness": 1.0}})
    assert e.value.name == "halfShaft.stiffness"


def test_standstill_with_zero_inputs_stays_at_rest():
    m = make(Fz=3000.0, vx=0.0, w_flange=0.0)
    run(m, 1e-3, 500)
    for name in ("flange_tau", "Fx", "wheel_w", "slip", "shaft_tau", "shaft_power"):
        assert getattr(m, name) == 0.0, name
    assert m.energy_dissipated == 0.0 and m.work_flange == 0.0


def test_outputs_at_t0_follow_the_start_state():
    m = make(Fz=3000.0, vx=10.0, w_flange=31.0, halfShaft_phi_rel_start=0.01)
    c = m.params.halfShaft.c
    assert m.shaft_tau == pytest.approx(c * 0.01, rel=1e-15)
    assert m.flange_tau == -m.shaft_tau
    assert m.wheel_w == 31.0
    k0 = (R * 31.0 - 10.0) / 10.0                     # steady transient slip for the start speeds
    assert m.slip == pytest.approx(k0, rel=1e-14)
    assert m.Fx == pytest.approx(3000.0 * magic_formula(k0, 10.0, 1.9, 0.97), rel=1e-14)


def test_driving_forward_gives_a_resisting_flange_torque_and_forward_force():
    v = 20.0
    m = make(Fz=3000.0, vx=v, w_flange=1.03 * v / R, wheel_w_start=v / R, tyre_k_start=0.0)
    run(m, 1e-3, 300)
    assert m.flange_tau < 0.0 < m.Fx
    assert m.shaft_power > 0.0 and m.slip > 0.0


def test_no_force_without_load_or_friction_and_spinning_at_standstill_is_finite():
    for Fz, mu in ((0.0, 1.0), (-800.0, 1.0), (3000.0, 0.0)):
        m = make(Fz=Fz, mu=mu, vx=0.0, w_flange=30.0, wheel_w_start=0.0)
        run(m, 1e-3, 3000)                                   # shaft mode decays as exp(-6.4 t)
        assert m.Fx == 0.0
        assert abs(m.slip) <= m.params.tyre.k_max            # the transient slip is bounded
        assert m.wheel_w == pytest.approx(30.0, rel=1e-6)    # the shaft spins the unloaded wheel up
        # in steady state the twist carries only the rolling resistance; the start transient
        # (about 2400 N m) decays as exp(-d t / 2J) = exp(-19) by t = 3 s, to about 1e-5 N m
        assert m.shaft_tau == pytest.approx(m.params.tyre.f_rr * max(Fz, 0.0) * R * math.tanh(30.0 / 0.5),
                                            rel=1e-6, abs=1e-4)
        assert all(math.isfinite(v) for v in m.get_state().values())
        assert abs(m.energy_residual) <= 1e-9 * m.work_flange


def test_driven_wheel_reaches_the_steady_slip_of_the_magic_formula_inverse():
    """Torque-driven test rig: a flange inertia with a constant torque T drives the wheel through
    the shaft (co-simulated here, Gauss-Seidel), the road moves at constant v (drum). In steady
    state the shaft carries T, so Fx = (T - M_rr)/R and the slip must be the MF inverse of Fx/(mu Fz)."""
    v, Fz, mu, T, J_f, h = 20.0, 3500.0, 0.9, 600.0, 1.0, 1e-3
    m = make(Fz=Fz, mu=mu, vx=v, w_flange=v / R)
    w_f, phi_f = v / R, 0.0
    for i in range(3000):
        m.flange_w, m.flange_phi = w_f, phi_f
        m.do_step(i * h, h)
        w_new = w_f + h * (T + m.flange_tau) / J_f
        phi_f += 0.5 * (w_f + w_new) * h
        w_f = w_new
    ty = m.params.tyre
    M_rr = ty.f_rr * Fz * R * math.tanh(m.wheel_w / ty.w_eps)
    Fx = (T - M_rr) / R
    k_expected = slip_for_force_ratio(Fx / (mu * Fz), ty.B, ty.C, ty.E)
    assert m.shaft_tau == pytest.approx(T, rel=1e-9)
    assert m.Fx == pytest.approx(Fx, rel=1e-9)
    assert m.slip == pytest.approx(k_expected, rel=1e-8)
    assert m.wheel_w == pytest.approx(v * (1.0 + k_expected) / R, rel=1e-9)


def test_first_step_takes_the_angle_reference_from_its_input():
    """A Gauss-Seidel master that steps the differential first hands the wheel the flange angle at
    the end of each step, w h ahead of the angle at initialization: the first step must not twist
    the shaft by w h (a torque pulse c w h), later angle corrections must still act."""
    v, w, h = 10.0, 31.0, 2e-4
    jacobi = make(Fz=3000.0, vx=v, w_flange=w)        # angle input = angle at the step start
    seidel = make(Fz=3000.0, vx=v, w_flange=w)        # angle input = angle at the step end
    for k in range(20):
        jacobi.flange_phi, seidel.flange_phi = w * k * h, w * (k + 1) * h
        jacobi.do_step(k * h, h)
        seidel.do_step(k * h, h)
        assert seidel.shaft_tau == pytest.approx(jacobi.shaft_tau, rel=1e-9, abs=1e-9)   # not + c w h = 50 N m
    # after the first step an angle step is followed: the shaft twists by it
    jacobi.flange_phi, seidel.flange_phi = w * 20 * h, w * 21 * h + 1e-3
    jacobi.do_step(20 * h, h)
    seidel.do_step(20 * h, h)
    c = seidel.params.halfShaft.c
    assert seidel.shaft_tau - jacobi.shaft_tau == pytest.approx(c * 1e-3, rel=0.05)
    assert abs(seidel.energy_residual) <= 1e-9 * max(1.0, abs(seidel.work_flange))


@pytest.mark.parametrize("h", [1e-3, 1e-2])
def test_power_balance_closes(h):
    """Shaft work in = work to the vehicle + dKE + dPE + dissipated, over a run with varying inputs
    (load on/off, negative load, friction change, braking, reversing, flange angle that does not
    follow the zero-order hold exactly)."""
    m = make(Fz=3000.0, vx=0.0, w_flange=0.0)
    phi = [0.0]

    def inputs(mod, t):
        mod.flange_w = 40.0 * math.sin(3.0 * t) + 10.0 * math.sin(17.0 * t)
        mod.flange_phi = phi[0]
        phi[0] += (40.0 / 3.0) * (math.cos(3.0 * t) - math.cos(3.0 * (t + h))) \
            + (10.0 / 17.0) * (math.cos(17.0 * t) - math.cos(17.0 * (t + h)))   # exact angle
        mod.Fz = 3000.0 + 3500.0 * math.sin(5.0 * t)                              # lifts off at times
        mod.mu = 1.0 if t < 1.0 else 0.3
        mod.vx = 12.0 * math.sin(2.0 * t)

    for i in range(int(round(2.0 / h))):
        inputs(m, i * h)
        m.do_step(i * h, h)
    scale = abs(m.work_flange) + abs(m.work_road) + m.energy_dissipated + m.kinetic_energy + m.potential_energy
    assert scale > 1e3
    assert abs(m.energy_residual) <= 1e-10 * scale
    assert m.loss_damping > 0.0 and m.loss_rolling > 0.0 and m.loss_slip > 0.0


def _reference(v, w_in, Fz, mu, T):
    p = WheelLoadParams.defaults()
    c, d, J, ty = p.halfShaft.c, p.halfShaft.d, p.wheel.J, p.tyre

    def rhs(t, y):
        th, w, k = y
        tau = c * th + d * (w_in - w)
        F = mu * Fz * magic_formula(k, ty.B, ty.C, ty.E)
        M = ty.f_rr * Fz * R * math.tanh(w / ty.w_eps)
        return [w_in - w, (tau - R * F - M) / J, (R * w - v - abs(v) * k) / ty.sigma]

    ts = np.arange(1, int(round(T / 1e-3)) + 1) * 1e-3
    sol = solve_ivp(rhs, (0.0, T), [0.0, v / R, 0.0], method="Radau", rtol=1e-12, atol=1e-12, t_eval=ts)
    return ts, c * sol.y[0] + d * (w_in - sol.y[1])


def test_second_order_convergence_to_a_reference_solution():
    v, Fz, mu, T = 15.0, 3000.0, 1.0, 0.2
    w_in = 1.05 * v / R
    ts, tau_ref = _reference(v, w_in, Fz, mu, T)
    peak = float(np.max(np.abs(tau_ref)))
    errors = {}
    for h in (2e-3, 1e-3):
        m = make(Fz=Fz, mu=mu, vx=v, w_flange=w_in, wheel_w_start=v / R, tyre_k_start=0.0, h_max=h)
        err = 0.0
        for i in range(int(round(T / h))):
            m.do_step(i * h, h)
            m.flange_phi += w_in * h
            t_end = (i + 1) * h
            j = int(round(t_end / 1e-3)) - 1
            err = max(err, abs(m.shaft_tau - tau_ref[j]))
        errors[h] = err / peak
    assert errors[1e-3] < 2e-4
    assert 3.0 < errors[2e-3] / errors[1e-3] < 5.0        # halving the step quarters the error


def test_stable_with_a_1e_2_communication_step():
    """A hard transient (wheel spin-up on a slippery road, then grip) at h = 1e-2 s stays finite,
    bounded by the fine-step response, and ends in the same steady state (the slowest mode, the
    twist relaxing through the tyre's slip damping, has a time constant of about 0.15 s)."""
    def scenario(h, h_max):
        m = make(Fz=3000.0, mu=0.2, vx=5.0, w_flange=5.0 / R, h_max=h_max)
        peak = 0.0
        for i in range(int(round(5.0 / h))):
            t = i * h
            m.flange_w = 3.0 * 5.0 / R if t < 1.0 else 1.02 * 5.0 / R
            m.mu = 0.2 if t < 1.5 else 1.0
            m.do_step(t, h)
            m.flange_phi += m.flange_w * h
            assert all(math.isfinite(x) for x in (m.shaft_tau, m.wheel_w, m.slip, m.Fx))
            peak = max(peak, abs(m.shaft_tau))
        return m, peak

    coarse, peak_coarse = scenario(1e-2, 1e-2)      # one implicit sub-step per 10 ms
    fine, peak_fine = scenario(1e-4, 1e-4)
    assert peak_coarse <= 1.5 * peak_fine
    assert coarse.shaft_tau == pytest.approx(fine.shaft_tau, rel=1e-6)
    assert coarse.wheel_w == pytest.approx(fine.wheel_w, rel=1e-9)
    assert coarse.slip == pytest.approx(fine.slip, rel=1e-6)


def test_rollback_reproduces_the_continuation_bit_for_bit():
    m = make(Fz=3000.0, vx=8.0, w_flange=8.5 / R)

    def inputs(mod, t):
        mod.flange_w = 8.5 / R + 5.0 * math.sin(20.0 * t)
        mod.Fz = 3000.0 + 500.0 * math.sin(7.0 * t)

    run(m, 1e-3, 100, inputs=inputs)
    saved = json.loads(json.dumps(m.get_state()))
    first = []
    run(m, 1e-3, 200, t0=0.1, inputs=lambda mod, t: (inputs(mod, t), first.append(mod.get_state())))
    end_first = m.get_state()
    m.set_state(saved)
    second = []
    run(m, 1e-3, 200, t0=0.1, inputs=lambda mod, t: (inputs(mod, t), second.append(mod.get_state())))
    assert second == first
    assert m.get_state() == end_first


@pytest.mark.parametrize("group,field,value,name", [
    ("halfShaft", "c", -8000.0, "halfShaft.c"),
    ("halfShaft", "d", math.nan, "halfShaft.d"),
    ("wheel", "J", 0.0, "wheel.J"),
    ("wheel", "R", -0.3, "wheel.R"),
    ("tyre", "B", -1.0, "tyre.B"),
    ("tyre", "sigma", 0.0, "tyre.sigma"),
    (None, "h_max", 0.0, "wheelLoad.h_max"),
    (None, "followFlangeAngle", 2, "wheelLoad.followFlangeAngle"),
])
def test_bad_parameters_are_named(group, field, value, name):
    p = WheelLoadParams.defaults()
    setattr(getattr(p, group) if group else p, field, value)
    m = WheelLoad(p)
    with pytest.raises(ParameterError) as e:
        m.initialize(0.0)
    assert e.value.name == name
    assert "allowed" in str(e.value)


@pytest.mark.parametrize("attr,value,name", [
    ("flange_w", math.nan, "flange.w"), ("flange_phi", math.inf, "flange.phi"),
    ("Fz", math.nan, "Fz"), ("mu", -0.1, "mu"), ("vx", -math.inf, "vx"),
])
def test_bad_inputs_are_named_and_leave_the_state_unchanged(attr, value, name):
    m = make(Fz=3000.0, vx=5.0, w_flange=5.0 / R)
    run(m, 1e-3, 10)
    before = m.get_state()
    setattr(m, attr, value)
    with pytest.raises(ParameterError) as e:
        m.do_step(0.01, 1e-3)
    assert e.value.name == name
    after = m.get_state()
    after[attr] = before[attr]
    assert after == before


@pytest.mark.parametrize("vx, w, mu", [(10.0, 10.0 / R * 1.02, 1.0), (10.0, 10.0 / R * 1.3, 0.1), (0.0, 0.5, 1.0),
                                        (5.0, 5.0 / R * 0.97, 0.8)])
def test_interface_model_outputs_are_the_wheel_derivatives(vx, w, mu):
    """shaftCoupling = wheel: the linear model reported for the next step (wheel.aFree, wheel.invJ,
    tyre.torqueRate, tyre.torqueStiffness, tyre.relaxationRate) is the wheel's own derivative: a
    step of 1e-8 s with the shaft torque held gives the reported wheel acceleration and tyre-torque
    rate, and a second torque the reported 1 / J."""
    def fresh():
        m = make(Fz=3000.0, mu=mu, vx=vx, shaftCoupling="wheel", wheel_w_start=w, interfaceStiffness=0)
        m.do_step(0.0, 1e-3)          # leave the start state: some transient slip
        return m

    m = fresh()
    s = m.get_state()
    h = 1e-8
    out = []
    for tau in (0.0, 100.0):
        m.set_state(s)
        m.tau_in = tau
        F0 = m.params.wheel.R * m.Fx
        m.do_step(m.t, h)
        out.append(((m.w - s["w"]) / h, (m.params.wheel.R * m.Fx - F0) / h))
        m.set_state(s)
    m.set_state(s)
    a_free, inv_J, q_rate = s["sur_a"], s["sur_invJ"], s["sur_qrate"]
    assert out[0][0] == pytest.approx(a_free, rel=1e-4, abs=1e-3)
    assert (out[1][0] - out[0][0]) / 100.0 == pytest.approx(inv_J, rel=1e-4)
    assert out[0][1] == pytest.approx(q_rate, rel=1e-3, abs=1e-2 * abs(q_rate) + 1.0)
    assert s["sur_ct"] >= 0.0 and s["sur_rt"] == pytest.approx(abs(vx) / m.params.tyre.sigma)
    assert s["sur_dadw"] <= 0.0


def test_predicted_speed_change_input_defaults_to_the_held_speed():
    """shaftIn.dw = 0 (the default) is the speed held over the step: the same step as before the
    input existed (the anchor speed is the wheel speed at the start of the step)."""
    a = make(Fz=3000.0, vx=10.0, shaftCoupling="wheel", wheel_w_start=31.0)
    b = make(Fz=3000.0, vx=10.0, shaftCoupling="wheel", wheel_w_start=31.0)
    for m in (a, b):
        m.tau_in = 120.0
    b.dw_in = 0.0
    run(a, 5e-3, 10)
    run(b, 5e-3, 10)
    assert a.get_state() == b.get_state()
    c = make(Fz=3000.0, vx=10.0, shaftCoupling="wheel", wheel_w_start=31.0)
    c.tau_in, c.dw_in = 120.0, 0.5
    run(c, 5e-3, 1)
    assert c.shaft_tau != a.shaft_tau   # the interface stiffness acts on the deviation from the ramp
