"""Tyre force laws (spurdiff.vehicle.tyre): Magic Formula sign, bounds, saturation, slope, inverse."""
from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from spurdiff.errors import ParameterError
from spurdiff.vehicle.tyre import (
    TyreParams, magic_formula, magic_formula_slope, peak_slip, slip_for_force_ratio, tyre_force,
)

B, C, E = 10.0, 1.9, 0.97  # the textbook dry-asphalt set (defaults)


def test_force_has_the_sign_of_the_slip():
    for k in (1e-6, 0.01, 0.1, 0.5, 1.0, 5.0):
        assert tyre_force(k, 3000.0, 1.0, B, C, E) > 0.0
        assert tyre_force(-k, 3000.0, 1.0, B, C, E) < 0.0
    assert tyre_force(0.0, 3000.0, 1.0, B, C, E) == 0.0


def test_peak_is_mu_fz_and_force_saturates_beyond_it():
    Fz, mu = 4000.0, 0.8
    kp = peak_slip(B, C, E)
    assert 0.05 < kp < 0.3  # a passenger-car peak slip
    assert tyre_force(kp, Fz, mu, B, C, E) == pytest.approx(mu * Fz, rel=1e-12)
    # past the peak the force falls but stays a large fraction of mu Fz (sliding) up to k = 1
    f1 = tyre_force(1.0, Fz, mu, B, C, E)
    assert 0.8 * mu * Fz < f1 < mu * Fz
    grid = [i * 1e-3 for i in range(-2000, 2001)]
    assert max(abs(tyre_force(k, Fz, mu, B, C, E)) for k in grid) <= mu * Fz


def test_no_force_without_load_or_friction():
    for k in (-1.0, -0.05, 0.0, 0.05, 1.0):
        assert tyre_force(k, 0.0, 1.0, B, C, E) == 0.0
        assert tyre_force(k, -500.0, 1.0, B, C, E) == 0.0   # a lifted wheel: negative load is no load
        assert tyre_force(k, 3000.0, 0.0, B, C, E) == 0.0


def test_slope_at_zero_is_BCD_and_matches_finite_difference():
    assert magic_formula_slope(0.0, B, C, E) == pytest.approx(B * C, rel=1e-14)
    for k in (-0.3, -0.05, 0.02, 0.1, 0.7):
        dk = 1e-7
        fd = (magic_formula(k + dk, B, C, E) - magic_formula(k - dk, B, C, E)) / (2 * dk)
        assert magic_formula_slope(k, B, C, E) == pytest.approx(fd, rel=1e-6, abs=1e-8)


def test_inverse_on_the_stable_branch_round_trips():
    kp = peak_slip(B, C, E)
    for r in (-0.99, -0.5, -0.1, 1e-4, 0.3, 0.7, 0.95, 1.0):
        k = slip_for_force_ratio(r, B, C, E)
        assert abs(k) <= kp * (1 + 1e-12)
        assert magic_formula(k, B, C, E) == pytest.approx(r, rel=1e-12, abs=1e-15)
    with pytest.raises(ParameterError) as e:
        slip_for_force_ratio(1.01, B, C, E)
    assert e.value.name == "ratio"


def test_inverse_without_a_peak_when_C_below_one():
    assert math.isinf(peak_slip(5.0, 0.8, 0.5))
    top = math.sin(0.4 * math.pi)
    k = slip_for_force_ratio(0.9 * top, 5.0, 0.8, 0.5)
    assert magic_formula(k, 5.0, 0.8, 0.5) == pytest.approx(0.9 * top, rel=1e-12)


@given(
    b=st.floats(0.1, 50.0), c=st.floats(0.05, 2.0), e=st.floats(-10.0, 1.0),
    k=st.floats(-1e3, 1e3, allow_nan=False), fz=st.floats(0.0, 2e4), mu=st.floats(0.0, 1.5),
)
def test_property_bounded_by_mu_fz_odd_and_signed(b, c, e, k, fz, mu):
    f = tyre_force(k, fz, mu, b, c, e)
    assert abs(f) <= mu * fz
    assert tyre_force(-k, fz, mu, b, c, e) == -f          # exactly odd
    if fz > 0.0 and mu > 0.0 and k != 0.0:
        assert f * k >= 0.0                               # never opposes its slip


@pytest.mark.parametrize("field,value", [
    ("B", 0.0), ("B", -1.0), ("C", 0.0), ("C", 2.5), ("E", 1.2), ("E", math.nan),
    ("sigma", 0.0), ("f_rr", -0.01), ("w_eps", 0.0), ("k_max", -1.0), ("k_start", math.inf),
])
def test_bad_tyre_parameters_name_the_field(field, value):
    p = TyreParams(**{field: value})
    with pytest.raises(ParameterError) as e:
        p.validate()
    assert e.value.name == f"tyre.{field}"
    assert "allowed" in str(e.value)
