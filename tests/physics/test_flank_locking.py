"""Flank friction in the locking law (spurdiff.differential.flank_law): the Coulomb break-away
against the contact level's own simulation, the arms against the mesh level's friction code,
the reported K with and without, and the stated creep bound of the regularised flank friction."""
from __future__ import annotations

import math

import pytest

from spurdiff.differential.flank_law import (_GEARS, _speeds, breakaway_flank, flank_arms, locking_coefficient_flank,
                                             mesh_paths, start_phases)
from spurdiff.differential.locking import locking_coefficients, pin_friction
from spurdiff.differential.mesh import MeshDifferential, MeshParams
from spurdiff.differential.mesh.forces import FlankFriction
from spurdiff.differential.params import DifferentialParams

MU_S = 0.05


@pytest.fixture(scope="module")
def setup():
    p = DifferentialParams()
    geo = p.validate()
    return p, geo, pin_friction(geo, p.mu_pin, p.r_collar)


def _contact(p, flank: bool, loads, vs: float = 1e-4) -> MeshDifferential:
    m = MeshDifferential(p, MeshParams(level="contact", flankFriction=flank, vStiction=vs))
    m.w_ref = m.w_start_carrier = 1.389
    m.tau_L, m.tau_R = loads
    m.initialize()
    return m


def _loads(sign: float, D: float):
    """Sun loads with total 2100 N m (drive: sign +1) and sun A the more loaded by D."""
    return -1050.0 * sign - D / 2, -1050.0 * sign + D / 2


def test_no_flank_friction_is_the_pin_law(setup):
    p, geo, pf = setup
    Kd, Kc = locking_coefficients(pf)
    assert locking_coefficient_flank(geo, pf, 0.0, 1.0) == pytest.approx(Kd, rel=1e-10)
    assert locking_coefficient_flank(geo, pf, 0.0, -1.0) == pytest.approx(Kc, rel=1e-10)


def test_arms_are_the_mesh_levels_coulomb_limit(setup):
    """The arms written from the gear geometry equal the mesh model's FlankFriction moments with
    a vanishing stiction speed (its Coulomb limit), at phases over the cycle, both directions."""
    p, geo, pf = setup
    m = _contact(p, True, _loads(1.0, 0.0))
    coulomb = FlankFriction(1.0, 1.0, 1e-15, 2e-15)
    for s in (1.0, -1.0):
        W = _speeds(geo, s)
        for xi in (0.03, 0.21, 0.47, 0.66, 0.91):
            arms = flank_arms(geo, s, 1.0, (xi, xi, xi))
            for k, md in enumerate(m.md):
                fm = coulomb.moments(md, 1.0, xi, W[md.g1], W[md.g2])
                assert (fm.M1, fm.M2) == pytest.approx(arms[k], abs=1e-12)


def test_cycle_mean_dissipates_the_mean_sliding_power(setup):
    """Power of the averaged moments = -mean |v| per unit mu |F|, the sliding speed integrated
    independently over the usable path (single and double contact by the path length)."""
    p, geo, pf = setup
    W = _speeds(geo, 1.0)
    arms = flank_arms(geo, 1.0, 1.0, samples=4000)
    for k, pth in enumerate(mesh_paths(geo)):
        g1, g2 = _GEARS[k]
        N = 20000
        total = 0.0
        for j in range(N):               # sum over the contact positions of one pitch, shared by n_c
            x = (j + 0.5) / N * pth.pb
            nc = 2 if x + pth.pb <= pth.galpha else 1
            for q in range(nc):
                l1 = pth.l1min + x + q * pth.pb
                total += abs(W[g1] * l1 + W[g2] * (pth.L - l1)) / nc
        power = arms[k][0] * W[g1] + arms[k][1] * W[g2]
        assert power == pytest.approx(-total / N, rel=2e-3)


@pytest.mark.parametrize("sign, tol", [(1.0, 0.005), (-1.0, 0.01)])
def test_breakaway_matches_the_contact_level(setup, sign, tol):
    """A slow ramp of the load difference from rest breaks the contact level with flank friction
    away where the Coulomb law at the start phases says (sun A the more loaded: it falls behind,
    s = -1); measured: drive 0.2079 against 0.2076, coast 0.2197 against 0.2211."""
    p, geo, pf = setup
    K = breakaway_flank(pf, MU_S, flank_arms(geo, -1.0, sign, start_phases(geo, sign)), sign * 1000.0, -1.0).K
    K_pins = locking_coefficients(pf)[0 if sign > 0 else 1]
    assert K > K_pins * 1.04                      # flank friction raises the break-away
    D0 = 0.97 * K * 2100.0
    m = _contact(p, True, _loads(sign, D0))
    broke = None
    for k in range(200):
        D = D0 + 5e-4 * K * 2100.0 * k
        m.tau_L, m.tau_R = _loads(sign, D)
        m.do_step(k * 1e-3, 1e-3)
        if abs(m.wd) > 0.05:
            broke = D / 2100.0
            break
    assert broke is not None
    assert broke == pytest.approx(K, rel=tol)


def test_reported_K_with_and_without(setup):
    p, geo, pf = setup
    off = _contact(p, False, _loads(1.0, 0.0))
    on = _contact(p, True, _loads(1.0, 0.0))
    Kd, Kc = locking_coefficients(pf)
    assert (off.K, off.K_coast) == (Kd, Kc)
    assert (on.K_pins, on.K_pins_coast) == (Kd, Kc)
    assert on.K == pytest.approx(locking_coefficient_flank(geo, pf, MU_S, 1.0), rel=1e-12)
    assert on.K_coast == pytest.approx(locking_coefficient_flank(geo, pf, MU_S, -1.0), rel=1e-12)
    assert on.K > Kd * 1.05 and on.K_coast > Kc * 1.05


def creep_bound(geo, vs: float) -> float:
    """v_s / lambda_min: lambda_min the smallest sliding speed per unit differential speed at the
    ends of the three usable paths (docs/locking-law.md)."""
    W = _speeds(geo, 1.0)
    lam = math.inf
    for k, pth in enumerate(mesh_paths(geo)):
        g1, g2 = _GEARS[k]
        for l1 in (pth.l1min, pth.l1min + pth.galpha):
            lam = min(lam, abs(W[g1] * l1 + W[g2] * (pth.L - l1)))
    return vs / lam


@pytest.mark.parametrize("sign, frac", [(1.0, 1.02), (1.0, 1.10), (-1.0, 1.02)])
def test_creep_below_breakaway_is_bounded_and_scales_with_the_stiction_speed(setup, sign, frac):
    """Between the pins' break-away and the pins-and-flanks one the regularised flank friction
    lets the loaded differential creep: slower than v_s / lambda_min, and in proportion to v_s."""
    p, geo, pf = setup
    K_pins = locking_coefficients(pf)[0 if sign > 0 else 1]
    loads = _loads(sign, frac * K_pins * 2100.0)
    creep = []
    for vs in (1e-4, 5e-5):
        m = _contact(p, True, loads, vs)
        ws = []
        for k in range(150):
            m.do_step(k * 1e-3, 1e-3)
            ws.append(abs(m.wd))
        creep.append(max(ws[75:]))
        assert 0.0 < creep[-1] <= creep_bound(geo, vs)
    assert creep[1] == pytest.approx(0.5 * creep[0], rel=0.02)
