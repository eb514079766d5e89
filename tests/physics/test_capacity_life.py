"""The rating load at break-away and the limited life over the duty cycle (spurdiff.gears.capacity.life,
spurdiff.differential.watches.rating_forces), against hand calculations."""
import math

import pytest

from spurdiff.differential.locking import breakaway, pin_friction
from spurdiff.differential.watches import rating_forces
from spurdiff.errors import ParameterError
from spurdiff.gears import capacity as cap
from spurdiff.gears.design import derive
from spurdiff.gears.design_sets import gear_set


@pytest.fixture(scope="module")
def geo():
    return derive(gear_set("designed"))


def test_rating_forces_are_the_locked_split(geo):
    """The sun meshes at T_A / (n r_bA) of the break-away with the larger K: (1 + K) T0 / 2 on sun A;
    above the equal split by K; mesh 12 from planet 1's moment balance, above it too."""
    pf = pin_friction(geo, 0.26, 0.012)
    F = rating_forces(geo, 0.26, 0.012, 1000.0)
    cases = [breakaway(pf, T, s) for T in (1000.0, -1000.0) for s in (1.0, -1.0)]
    n, rbA = geo.table.nPairs, geo.meshA1.rb1
    K = max(abs(b.T_A) for b in cases) * 2 / 1000.0 - 1.0
    assert F["A1"] == pytest.approx((1 + K) * 1000.0 / (2 * n * rbA), rel=1e-12)
    nominal = cap.nominal_mesh_forces(geo, 1000.0)
    assert F["A1"] / nominal["A1"] == pytest.approx(1 + K, rel=1e-12) and 0.15 < K < 0.3
    assert F["12"] == max(abs(b.F_12) for b in cases) > nominal["12"]
    assert rating_forces(geo, 0.0, 0.012, 1000.0) == nominal          # no pin friction: the equal split


def test_bundled_duty_cycle_and_bad_bins():
    bins = cap.duty_cycle()
    assert len(bins) == 6 and sum(b.hours for b in bins) == pytest.approx(2760.0)
    # the w_rel of each bin is u (track / 2) / (r_wheel R) as its comment says
    assert bins[2].w_rel == pytest.approx(10 * 0.8 / (0.3266 * 20), abs=1e-4)
    with pytest.raises(ParameterError, match=r"duty_cycle.bin\[0\].hours"):
        cap.duty_cycle({"bin": [{"name": "x", "T0": 1.0, "w_rel": 1.0, "hours": -1.0}]})
    with pytest.raises(ParameterError, match=r"duty_cycle.bin\[0\]"):
        cap.duty_cycle({"bin": [{"name": "x", "T0": "a lot", "w_rel": 1.0, "hours": 1.0}]})
    with pytest.raises(ParameterError, match="duty_cycle.bin"):
        cap.duty_cycle({})


def test_cycles_damage_and_safety_of_one_bin_by_hand(geo):
    """One bin: planet 1 turns (36/13) w t / 2 pi times, sun A n w t / 2 pi; its contact damage is
    n / N(sigma) on the log-log line from (1e5, sigma_Hlim 1.6) to (5e7, sigma_Hlim 0.92), and the
    safety the stress factor k with k^(-q) D = 1, q the line's exponent."""
    F = cap.scaled(rating_forces(geo, 0.26, 0.012, 2100.0), 1 / 2100.0)
    b = cap.DutyBin("one", 2100.0, 0.7, 10.0)
    rep = cap.life_report(geo, F, (b,), bores={"planet1": 0.024, "planet2": 0.024})
    e = next(x for x in rep.entries if x.mesh == "A1" and x.gear == "planet1" and x.mode == "contact")
    n = 36 / 13 * 0.7 * 10 * 3600 / (2 * math.pi)
    assert e.cycles == pytest.approx(n, rel=1e-12)
    s = next(x for x in rep.entries if x.gear == "sunA" and x.mode == "contact")
    assert s.cycles == pytest.approx(3 * 0.7 * 10 * 3600 / (2 * math.pi), rel=1e-12)
    G_s, G_e = 1500e6 * 1.6, 1500e6 * 0.92
    assert G_e < e.sigma_max < G_s
    q = math.log(5e7 / 1e5) / math.log(G_s / G_e)
    N = 1e5 * (G_s / e.sigma_max) ** q
    assert e.damage == pytest.approx(n / N, rel=1e-9)
    k = (n / N) ** (-1 / q)                  # D(k) = n / N(k sigma) = (n / N) k^q = 1
    assert e.S == pytest.approx(min(k, G_s / e.sigma_max), rel=1e-9)


def test_designed_set_lives_through_the_duty_cycle_the_paper_set_does_not(geo):
    for name, ok in (("designed", True), ("paper", False)):
        g = derive(gear_set(name))
        F = cap.scaled(rating_forces(g, 0.26, 0.012, 2100.0), 1 / 2100.0)
        rep = cap.life_report(g, F, bores={"planet1": 0.024, "planet2": 0.024})
        assert (rep.S >= 1.0) is ok and (not rep.findings) is ok
