"""Carrier speed in the pin loads (spurdiff.differential.speed_law): the centrifugal preload of
the planets' pins against independent limits."""
from __future__ import annotations

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
