"""Carrier speed in the pin loads (spurdiff.differential.speed_law): the centrifugal preload of
the planets' pins against independent limits."""
from __future__ import annotations

import math
from dataclasses import replace

import pytest

from spurdiff.differential.inertia import mass_properties
from spurdiff.differential.locking import PinFriction, breakaway, pin_friction
from spurdiff.differential.params import DifferentialParams
from spurdiff.differential.speed_law import breakaway_at_speed, locking_torque_at_speed


@pytest.fixture(scope="module")
def case():
    p = DifferentialParams()
    geo = p.validate()
    mp = mass_properties(p, geo)
    return p, geo, pin_friction(geo, p.mu_pin, p.r_collar), (mp.m_planet1, mp.m_planet2)


def test_standstill_is_the_pin_law(case):
    p, geo, pf, ms = case
    for T0 in (100.0, -100.0):
        for s in (1.0, -1.0):
            assert breakaway_at_speed(pf, geo, ms, 0.0, T0, s).K == pytest.approx(breakaway(pf, T0, s).K, rel=1e-9)


def test_zero_torque_locking_grows_with_the_square_of_the_speed(case):
    p, geo, pf, ms = case
    T1 = locking_torque_at_speed(pf, geo, ms, 50.0, 0.0)
    T2 = locking_torque_at_speed(pf, geo, ms, 100.0, 0.0)
    assert T1 > 0.0
    assert T2 / T1 == pytest.approx(4.0, rel=1e-9)


def test_small_lever_limit_is_the_first_order_formula(case):
    """With a vanishing lever the mesh forces the locking causes vanish: n c sum |rho_i| m_i a_i w^2."""
    p, geo, pf, ms = case
    c = pf.c * 1e-4
    small = PinFriction(pf.layout, c, pf.M0, pf.rho, pf.rb, pf.n)
    w = 85.0
    first = pf.n * c * (abs(pf.rho[0]) * ms[0] * geo.meshA1.a + abs(pf.rho[1]) * ms[1] * geo.meshB2.a) * w * w
    assert locking_torque_at_speed(small, geo, ms, w, 0.0) == pytest.approx(first, rel=1e-3)


def test_more_pairs_more_speed_locking(case):
    p, geo, pf, ms = case
    p4 = replace(p, table=replace(p.table, nPairs=4))
    geo4 = p4.validate()
    pf4 = pin_friction(geo4, p4.mu_pin, p4.r_collar)
    assert locking_torque_at_speed(pf4, geo4, ms, 85.0, 0.0) > 1.3 * locking_torque_at_speed(pf, geo, ms, 85.0, 0.0)


# ------------------------------------------------------------------ the rigid level with speed loads
def _rigid(kernel: str, wc: float, tau_L: float, tau_R: float, drive: str = "speed"):
    from spurdiff.differential.rigid import RigidDifferential

    m = RigidDifferential(DifferentialParams(carrierDrive=drive))
    m.kernel = kernel
    m.w_ref = m.w_start_carrier = wc
    m.tau_L, m.tau_R = tau_L, tau_R
    m.initialize()
    return m


def _centrifugal(m, wc):
    """m_i a_i w^2 e_r,i written from the layout's angle (independent of the model's constants)."""
    geo, mp = m.geometry, m.mass
    th = m.pf.layout.theta
    return ((mp.m_planet1 * geo.meshA1.a * wc * wc, 0.0),
            (mp.m_planet2 * geo.meshB2.a * wc * wc * math.cos(th), mp.m_planet2 * geo.meshB2.a * wc * wc * math.sin(th)))


@pytest.mark.parametrize("T0", [0.0, 100.0])
def test_rigid_level_breaks_away_where_the_theory_says(case, T0):
    """Carrier held at 100 km/h (85 rad/s): the rigid level holds 0.995 of the quasi-static
    locking torque of speed_law and slips at 1.005 (sun A the more loaded: it falls behind)."""
    p, geo, pf, ms = case
    wc = 85.0
    D = breakaway_at_speed(pf, geo, ms, wc, T0, -1.0).locking_torque
    for frac, stuck in ((0.995, True), (1.005, False)):
        m = _rigid("python", wc, -T0 / 2 - frac * D / 2, -T0 / 2 + frac * D / 2)
        for k in range(20):
            m.do_step(k * 1e-3, 1e-3)
        assert m.stuck == stuck


def test_rigid_slip_capacity_is_the_pin_load_with_the_centrifugal_force(case):
    p, geo, pf, ms = case
    wc = 120.0
    m = _rigid("python", wc, -30.0, 30.0)
    for k in range(10):
        m.do_step(k * 1e-3, 1e-3)
    assert m.wd < 0.0
    f = m.mesh_forces
    g = _centrifugal(m, wc)
    cap = 0.0
    for i, Fs, rho in ((0, f.F_A1, m.rho1), (1, f.F_B2, m.rho2)):
        # the journal's end reactions (the loads at their axial positions, the centrifugal force at
        # the planet's middle): friction load |R_0| + |R_L|
        R0x, R0y, RLx, RLy = pf.layout.end_reactions(i, Fs, f.F_12, g[i])
        cap += 3 * abs(rho) * pf.c * (math.hypot(R0x, R0y) + math.hypot(RLx, RLy))
    assert m.locking_capacity == pytest.approx(cap, rel=1e-12)
    assert m.locking_torque == pytest.approx(m.locking_capacity, rel=1e-12)


def test_rigid_energy_balance_and_kernel_agree_at_speed(case):
    """Torque-driven carrier spinning up to 150 rad/s while slipping: the compiled kernel and the
    Python reference give the same run bit for bit, and work = kinetic energy + loss."""
    from spurdiff.differential import rigid_kernel

    if rigid_kernel.load()[0] is None:
        pytest.skip("no compiled rigid kernel here")
    runs = {}
    for kernel in ("compiled", "python"):
        m = _rigid(kernel, 60.0, -150.0, 50.0, drive="torque")
        m.tau_c = 150.0
        assert m.kernel_note.startswith(kernel)
        ke0 = m.kinetic_energy
        out = []
        for k in range(400):
            m.do_step(k * 1e-3, 1e-3)
            out.append((m.wc, m.wd, m.locking_torque, m.F12))
        runs[kernel] = out
        assert m.wc > 100.0 and m.wd < 0.0
        assert m.work_in - (m.kinetic_energy - ke0) - m.energy_loss == pytest.approx(0.0, abs=1e-9 * m.work_in)
    assert runs["compiled"] == runs["python"]


# ------------------------------------------------------------------ the mesh levels with speed loads
def _mesh(kernel: str, level: str, wc: float, D: float):
    from spurdiff.differential.mesh import MeshDifferential, MeshParams

    m = MeshDifferential(DifferentialParams(), MeshParams(level=level, kernel=kernel))
    m.w_ref = m.w_start_carrier = wc
    m.tau_L, m.tau_R = -D / 2, D / 2
    m.initialize()
    return m


@pytest.mark.parametrize("level", ["compliant", "contact"])
def test_mesh_levels_break_away_where_the_theory_says(case, level):
    """No input torque, carrier held at 100 km/h: the mesh levels hold 0.99 of speed_law's
    locking torque and slip at 1.01 of it."""
    p, geo, pf, ms = case
    D = breakaway_at_speed(pf, geo, ms, 85.0, 0.0, -1.0).locking_torque
    for frac, stuck in ((0.99, True), (1.01, False)):
        m = _mesh("python", level, 85.0, frac * D)
        for k in range(30):
            m.do_step(k * 1e-3, 1e-3)
        assert m.stuck == stuck, (frac, m.planet_modes)


def test_mesh_kernel_agrees_with_the_reference_at_speed(case):
    from spurdiff.differential.mesh import kernel as mk

    if mk.load()[0] is None:
        pytest.skip("no compiled mesh kernel here")
    runs = {}
    for kernel in ("compiled", "python"):
        m = _mesh(kernel, "compliant", 85.0, 8.2)
        assert m.kernel_in_use.startswith(kernel)
        out = []
        for k in range(30):
            m.do_step(k * 1e-3, 1e-3)
            out.append((m.wd, m.locking_torque, m.locking_capacity, m.mesh_forces.F_12))
        runs[kernel] = out
    assert runs["compiled"] == runs["python"]
    assert runs["python"][-1][0] < 0.0


# ------------------------------------------------------------------ the carrier's acceleration in the pin loads
@pytest.mark.parametrize("alpha", [2.0e4, -2.0e4])
def test_rigid_level_breaks_away_where_the_theory_says_with_carrier_acceleration(alpha):
    """Carrier speed-driven from 20 rad/s at +-2e4 rad/s^2 over the step (a hard tip-in: the planets'
    tangential loads m_i a_i alpha_c of several hundred N), no input torque: the rigid level holds
    0.995 of speed_law's locking torque at (w_c, alpha_c) and slips at 1.005 (sun and planet spin
    inertias negligible, so the quasi-static theory is the model's law); the theory without the
    tangential term is far off (the term is measured, not a rounding matter)."""
    from spurdiff.differential.rigid import RigidDifferential

    p = DifferentialParams(carrierDrive="speed", J_sunA=1e-12, J_sunB=1e-12, J_planet1=1e-15, J_planet2=1e-15)
    w0, h = 20.0, 1e-3
    probe = RigidDifferential(p)
    probe.w_ref = w0
    probe.initialize()
    geo, ms = probe.geometry, (probe.mass.m_planet1, probe.mass.m_planet2)
    D = breakaway_at_speed(probe.pf, geo, ms, w0, 0.0, -1.0, alpha).locking_torque
    D0 = breakaway_at_speed(probe.pf, geo, ms, w0, 0.0, -1.0).locking_torque
    assert abs(D / D0 - 1.0) > 0.2
    for frac, stuck in ((0.995, True), (1.005, False)):
        m = RigidDifferential(p)
        m.w_ref = w0
        m.tau_L, m.tau_R = -frac * D / 2, frac * D / 2
        m.initialize()
        m.w_ref = w0 + alpha * h
        m.do_step(0.0, h)
        assert (m.wd == 0.0) == stuck, frac
