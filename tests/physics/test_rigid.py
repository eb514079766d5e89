"""Rigid differential: kinematics, power balance, exact stick-slip, state, bad input."""
import math

import pytest
from hypothesis import given, settings, strategies as st

from spurdiff.errors import ParameterError
from spurdiff.differential.params import DifferentialParams
from spurdiff.differential.rigid import RigidDifferential, StepError

W0 = 1.389


def model(tau_L=-1050.0, tau_R=-1050.0, drive="speed", w_ref=W0, tau_c=0.0, **kw):
    # the pin law's identities without the planets' centrifugal pin loads (1e-5 of the capacity at
    # 1.389 rad/s); with them: tests/physics/test_speed_law.py
    kw.setdefault("pinSpeedLoads", False)
    m = RigidDifferential(DifferentialParams(carrierDrive=drive, **kw))
    m.w_ref, m.tau_L, m.tau_R, m.tau_c = w_ref, tau_L, tau_R, tau_c
    m.w_start_carrier = W0
    m.initialize()
    return m


def run(m, t_end=0.3, h=1e-3):
    n = int(round(t_end / h))
    for k in range(n):
        m.do_step(k * h, h)
    return m


def balance(m, ke0):
    """work in - (kinetic energy change + friction loss): zero up to rounding."""
    return m.work_in - (m.kinetic_energy - ke0) - m.energy_loss


def test_straight_line_matches_theory():
    m = run(model())
    assert m.w_L == m.w_R == W0
    assert m.tau_drive == pytest.approx(2100.0, rel=1e-12)
    assert m.tau_mesh_L == pytest.approx(1050.0, rel=1e-12)
    assert m.tau_mesh_R == pytest.approx(1050.0, rel=1e-12)
    assert m.mesh_forces.F_A1 == pytest.approx(6897.45, rel=1e-5)
    assert m.stuck


def test_stick_below_capacity_holds_exactly():
    # difference 50 N m < K T0 = 59.5 N m: no relative motion at all, the friction holds it
    m = run(model(tau_L=-1075.0, tau_R=-1025.0))
    assert m.wd == 0.0 and m.w_L == m.w_R == W0
    assert m.locking_torque == pytest.approx(50.0, rel=1e-9)
    assert abs(m.locking_torque) <= m.locking_capacity
    assert m.energy_loss == 0.0
    assert m.n_mode_switches == 0


def test_slip_above_capacity_with_loss_equal_friction_times_speed():
    # the paper's cornering loads: twice the capacity of the paper's law
    m = model(tau_L=-1110.201, tau_R=-989.799, lockingLaw="paper")
    ke0 = m.kinetic_energy
    loss_prev, wd_prev = 0.0, 0.0
    h = 1e-3
    for k in range(100):
        m.do_step(k * h, h)
        # constant accelerations within the step: loss = |Q_f| * mean |w_d| * h
        assert m.energy_loss - loss_prev == pytest.approx(abs(m.Qf) * 0.5 * abs(m.wd + wd_prev) * h, rel=1e-9)
        loss_prev, wd_prev = m.energy_loss, m.wd
    assert m.wd < 0.0  # sun A (more load) slows, sun B speeds up
    assert m.w_L + m.w_R == pytest.approx(2 * m.wc, rel=1e-12)
    assert abs(m.locking_torque) == pytest.approx(m.locking_capacity, rel=1e-9)
    assert m.ad < 0.0
    assert balance(m, ke0) == pytest.approx(0.0, abs=1e-9 * m.work_in + 1e-12)


def test_friction_opposes_relative_motion_at_full_capacity():
    m = run(model(tau_L=-1110.201, tau_R=-989.799, lockingLaw="paper"), 0.05)
    # sun A slows relative to the carrier; the friction pushes it forward with K |T_A + T_B|
    assert m.wd < 0.0 and m.locking_torque > 0.0
    assert m.locking_torque == pytest.approx(m.K * abs(m.tau_mesh_L + m.tau_mesh_R), rel=1e-9)


@pytest.mark.parametrize("law,D", [("paper", 120.402), ("pinFriction", 800.0)])
def test_re_stick_after_reversal_without_chattering(law, D):
    m = model(tau_L=-1050.0 - D / 2, tau_R=-1050.0 + D / 2, lockingLaw=law)
    run(m, 0.02)
    assert m.wd < 0
    # reverse the imbalance moderately: relative motion decelerates, stops exactly, then sticks
    m.tau_L, m.tau_R = -1040.0, -1060.0
    h = 1e-3
    for k in range(20, 400):
        m.do_step(k * h, h)
    assert m.wd == 0.0 and m.stuck
    assert m.n_mode_switches <= 2  # break-away and the re-stick, nothing else


def test_torque_drive_power_balance_and_kinematics():
    m = model(drive="torque", tau_c=300.0, tau_L=-100.0, tau_R=-180.0)
    ke0 = m.kinetic_energy
    run(m, 0.5)
    assert m.w_L + m.w_R == pytest.approx(2 * m.wc, rel=1e-12)
    assert m.wc > W0  # net positive torque accelerates
    assert balance(m, ke0) == pytest.approx(0.0, abs=1e-9 * abs(m.work_in))
    assert m.energy_loss > 0.0


def test_state_roundtrip_reproduces_continuation():
    a = model(tau_L=-1110.201, tau_R=-989.799)
    run(a, 0.05)
    s = a.get_state()
    b = model(tau_L=-1110.201, tau_R=-989.799)
    b.set_state(dict(s))
    for k in range(50, 120):
        a.do_step(k * 1e-3, 1e-3)
        b.do_step(k * 1e-3, 1e-3)
    assert (a.wc, a.wd, a.phic, a.phid, a.energy_loss) == (b.wc, b.wd, b.phic, b.phid, b.energy_loss)


@pytest.mark.parametrize("attr,name", [("tau_L", "left.tau"), ("tau_R", "right.tau"), ("w_ref", "carrier.w_ref")])
def test_nan_input_is_refused_and_state_kept(attr, name):
    m = run(model(), 0.01)
    before = m.get_state()
    setattr(m, attr, float("nan"))
    with pytest.raises(ParameterError, match=name.replace(".", r"\.")):
        m.do_step(0.01, 1e-3)
    assert m.get_state()["wc"] == before["wc"]


@pytest.mark.parametrize("kw,name", [({"mu_pin": -0.1}, "mu_pin"), ({"J_sunA": -1.0}, "J_sunA"),
                                     ({"drive": "pedal"}, "carrierDrive"), ({"density": 0.0}, "density")])
def test_bad_parameters_name_the_parameter(kw, name):
    with pytest.raises(ParameterError, match=name):
        model(**kw)


def test_zero_step_is_refused():
    m = model()
    with pytest.raises(ParameterError, match="communicationStepSize"):
        m.do_step(0.0, 0.0)


def test_step_before_initialize():
    with pytest.raises(StepError):
        RigidDifferential().do_step(0.0, 1e-3)


@settings(max_examples=40, deadline=None)
@given(tl=st.floats(-3000, 3000), tr=st.floats(-3000, 3000), tc=st.floats(-3000, 3000),
       h=st.sampled_from([1e-5, 1e-4, 1e-3, 1e-2]), mu=st.floats(0.0, 0.5))
def test_passive_and_kinematic_for_any_loads(tl, tr, tc, h, mu):
    m = model(drive="torque", tau_c=tc, tau_L=tl, tau_R=tr, mu_pin=mu)
    ke0 = m.kinetic_energy
    for k in range(30):
        m.do_step(k * h, h)
    assert all(math.isfinite(v) for v in (m.wc, m.wd, m.tau_mesh_L, m.tau_mesh_R, m.energy_loss))
    assert m.w_L + m.w_R == pytest.approx(2 * m.wc, rel=1e-9, abs=1e-9)
    assert m.energy_loss >= 0.0
    assert abs(m.locking_torque) <= m.locking_capacity * (1 + 1e-9) + 1e-9
    scale = max(abs(m.work_in), m.kinetic_energy, ke0, 1e-9)
    assert abs(balance(m, ke0)) <= 1e-8 * scale


# ------------------------------------------------------------------ the pin-load locking law
def test_pin_law_slips_above_its_capacity_with_the_friction_from_the_pin_loads():
    # difference 1.05 K T0 with K from the pin loads (0.178 in drive): slips,
    # the friction works at n sum |rho_i| mu r_d |F_pin,i| and the energy balances
    m = model()
    D = 1.05 * m.K * 2100.0
    m = model(tau_L=-1050.0 - D / 2, tau_R=-1050.0 + D / 2)
    ke0 = m.kinetic_energy
    run(m, 0.05)
    assert m.wd < 0.0 and m.locking_torque > 0.0
    assert m.locking_torque == pytest.approx(m.locking_capacity, rel=1e-12)
    f = m.mesh_forces
    pf = m.pf
    cap = 3 * (abs(m.rho1) * 0.26 * 0.012 * pf.layout.pin_force(0, f.F_A1, f.F_12)[0]
               + abs(m.rho2) * 0.26 * 0.012 * pf.layout.pin_force(1, f.F_B2, f.F_12)[0])
    assert m.locking_capacity == pytest.approx(cap, rel=1e-12)
    # while slipping the capacity is close to the quasi-static K |T0| (planet inertia aside)
    assert m.locking_capacity == pytest.approx(m.K * (m.tau_mesh_L + m.tau_mesh_R), rel=0.01)
    assert balance(m, ke0) == pytest.approx(0.0, abs=1e-9 * m.work_in)


def test_pin_law_power_balance_planet_by_planet():
    # (T_B - T_A) dw = n sum_i M_i |w_i,rel|, w_i,rel = (z_sun / z_planet) dw, at every step
    D = 1.05 * model().K * 2100.0
    m = model(tau_L=-1050.0 - D / 2, tau_R=-1050.0 + D / 2)
    for k in range(40):
        m.do_step(k * 1e-3, 1e-3)
        f = m.mesh_forces
        M = [0.26 * 0.012 * m.pf.layout.pin_force(i, Fs, f.F_12)[0] for i, Fs in ((0, f.F_A1), (1, f.F_B2))]
        friction_power = 3 * sum(Mi * abs(36 / 13 * m.wd) for Mi in M)
        assert abs(m.Qf * m.wd) == pytest.approx(friction_power, rel=1e-12)
    assert m.wd < 0.0
    # quasi-statically the sun torques carry it: (T_B - T_A) dw = loss (planet inertia aside)
    assert (m.tau_mesh_R - m.tau_mesh_L) * m.wd == pytest.approx(friction_power, rel=0.02)


def test_pin_law_is_loaded_with_opposite_sun_torques_and_no_net_torque():
    # opposite external loads, tau_L + tau_R = 0: the paper's capacity K |T_A + T_B| only sees what
    # the unequal sun inertias add to T_A + T_B while accelerating; the pins still carry the mesh
    # forces, so the friction brakes the relative motion (it dissipates energy)
    paper = run(model(tau_L=-300.0, tau_R=300.0, lockingLaw="paper"), 0.02)
    m = model(tau_L=-300.0, tau_R=300.0)
    ke0 = m.kinetic_energy
    run(m, 0.02)
    assert m.wd < 0.0 and m.locking_capacity > 0.0 and m.energy_loss > 0.0
    assert m.wd > paper.wd        # braked
    # the paper's law only sees the small T_A + T_B of the unequal sun inertias
    assert paper.energy_loss < 0.2 * m.energy_loss
    assert balance(m, ke0) == pytest.approx(0.0, abs=1e-9 * abs(m.work_in))


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_pin_law_K_does_not_change_with_nPairs(n):
    from spurdiff.gears.geometry import GearTable

    m = model(table=GearTable(nPairs=n))
    ref = model()
    assert m.K == pytest.approx(ref.K, rel=1e-12) and m.K_coast == pytest.approx(ref.K_coast, rel=1e-12)
    # the pins with planet 2's couple (issue 41, pinModel = endReactions; docs/locking-law.md)
    assert m.K == pytest.approx(0.2326, abs=1e-4) and m.K_coast == pytest.approx(0.2182, abs=1e-4)
    planar = model(table=GearTable(nPairs=n), pinModel="planar")
    assert planar.K == pytest.approx(0.1779, abs=1e-4) and planar.K_coast == pytest.approx(0.2106, abs=1e-4)
    # the paper's law falls as 1/n
    assert m.K_paper == pytest.approx(ref.K_paper * 3 / n, rel=1e-12)
    # and the rigid level breaks away at K T0 whatever n
    D = m.K * 2100.0
    held = run(model(tau_L=-1050.0 - 0.499 * D, tau_R=-1050.0 + 0.499 * D, table=GearTable(nPairs=n)), 0.01)
    slips = run(model(tau_L=-1050.0 - 0.501 * D, tau_R=-1050.0 + 0.501 * D, table=GearTable(nPairs=n)), 0.01)
    assert held.stuck and not slips.stuck


@pytest.mark.parametrize("law", ["pinFriction", "paper"])
def test_preload_adds_to_the_capacity(law):
    # clutch-type spring preload: the differential holds T_pre with no load at all
    m = run(model(tau_L=0.0, tau_R=0.0, lockingPreload=50.0, lockingLaw=law), 0.02)
    assert m.stuck and m.locking_capacity == pytest.approx(50.0, rel=1e-12)
    m = run(model(tau_L=-24.0, tau_R=24.0, lockingPreload=50.0, lockingLaw=law), 0.02)
    assert m.stuck and m.locking_torque == pytest.approx(48.0, rel=1e-9)
    # the paper's law: K |T_A + T_B| + T_pre, and T_A + T_B = 0 here; the pin law adds the pin
    # loads of the opposite sun torques, so it holds a little more
    m = run(model(tau_L=-26.0, tau_R=26.0, lockingPreload=50.0, lockingLaw=law), 0.02)
    assert m.stuck == (law == "pinFriction")
    m = run(model(tau_L=-100.0, tau_R=100.0, lockingPreload=50.0, lockingLaw=law), 0.02)
    assert not m.stuck and m.locking_capacity >= 50.0


def test_bad_locking_law_and_preload_are_refused():
    with pytest.raises(ParameterError, match="lockingLaw"):
        model(lockingLaw="adams")
    with pytest.raises(ParameterError, match="lockingPreload"):
        model(lockingPreload=-1.0)


@pytest.mark.parametrize("law,preload", [("pinFriction", 0.0), ("pinFriction", 40.0), ("paper", 25.0)])
def test_stuck_interval_ends_solve_the_planet_balances(law, preload):
    """The closed-form ends of each planet's stuck interval of F_12 are the roots of
    r_b (F - F*) -+ (c |F_pin(F)| + M_0) = 0 (the capacity from the pin loads, as the slipping
    law uses it), agree with a bracketing root finder to 1e-12, and enclose F*."""
    import random

    from scipy.optimize import brentq

    m = model(lockingLaw=law, lockingPreload=preload, mu_pin=0.3)
    pf = m.pf
    rng = random.Random(7)
    for _ in range(300):
        i = rng.randrange(2)
        Fs = rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(-2.0, 4.5)
        ac = rng.uniform(-500.0, 500.0)
        rb, J = (pf.rb[1], m.J_1) if i == 0 else (pf.rb[3], m.J_2)
        Fstar = Fs - J * ac / rb
        lo, hi = m._planet_interval(i, Fs, ac)
        assert lo <= Fstar <= hi
        scale = rb * (abs(Fstar) + abs(Fs) + abs(hi) + abs(lo)) + pf.M0[i]
        assert abs(rb * (hi - Fstar) - pf.capacity(i, Fs, hi)[0]) <= 1e-13 * scale
        assert abs(rb * (lo - Fstar) + pf.capacity(i, Fs, lo)[0]) <= 1e-13 * scale
        span = 2.0 * (hi - lo) + 1.0
        ref_hi = brentq(lambda F: rb * (F - Fstar) - pf.capacity(i, Fs, F)[0], Fstar, Fstar + span, xtol=1e-300,
                        rtol=1e-15)
        ref_lo = brentq(lambda F: rb * (F - Fstar) + pf.capacity(i, Fs, F)[0], Fstar - span, Fstar, xtol=1e-300,
                        rtol=1e-15)
        assert hi == pytest.approx(ref_hi, rel=1e-12, abs=1e-12 * abs(Fstar))
        assert lo == pytest.approx(ref_lo, rel=1e-12, abs=1e-12 * abs(Fstar))


@pytest.mark.parametrize("law,D", [("paper", 120.402), ("pinFriction", 800.0)])
def test_json_state_roundtrip_reproduces_continuation_bit_for_bit(law, D):
    """A state through JSON (tuples become lists) continues exactly as the original, through a
    re-stick after a torque reversal."""
    import json

    a = model(tau_L=-1050.0 - D / 2, tau_R=-1050.0 + D / 2, lockingLaw=law)
    run(a, 0.02)
    b = model(lockingLaw=law)
    b.set_state(json.loads(json.dumps(a.get_state())))
    same = lambda: json.dumps(a.get_state()) == json.dumps(b.get_state())   # floats exactly; NaN equal
    assert same() and a.wd < 0.0
    for m in (a, b):
        m.tau_L, m.tau_R = -1040.0, -1060.0
        for k in range(20, 400):
            m.do_step(k * 1e-3, 1e-3)
    assert same() and a.stuck and a.n_mode_switches >= 1
