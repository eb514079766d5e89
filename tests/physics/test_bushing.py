"""Pin bushing data sets (spurdiff/data/pin_bushing.toml) and their design findings, each beside
an independent hand calculation."""
from __future__ import annotations

import math

import pytest

from spurdiff.differential.bushing import PIN_SETS, backup_ratio, bushing, check
from spurdiff.differential.locking import breakaway, locking_coefficients, pin_friction
from spurdiff.differential.params import DifferentialParams
from spurdiff.gears.layout import kinematics


@pytest.fixture(scope="module")
def geo():
    return DifferentialParams().validate()


def test_sets_and_the_paper_set_is_the_default_data():
    assert set(PIN_SETS) == {"paper", "bronze"}
    p, d = bushing("paper"), DifferentialParams()
    assert (p.mu_effective, p.journalRadius) == (d.mu_pin, d.r_collar)    # the paper scenes unchanged
    with pytest.raises(ValueError, match="pin data set 'steel'"):
        bushing("steel")


def test_friction_circle():
    """mu' = sin(atan(mu)): the friction circle r sin(phi), tan(phi) = mu; 3.2 % below mu at 0.26."""
    b = bushing("bronze")
    assert b.mu_effective == pytest.approx(math.sin(math.atan(0.16)), rel=1e-14)
    assert 1.0 - math.sin(math.atan(0.26)) / 0.26 == pytest.approx(0.0322, abs=5e-5)


def test_backup_ratios_by_hand(geo):
    """Planet 2: d_f = m (z - 2 h_f + 2 x) = 3 (13 - 2.5 - 0.6) = 29.7 mm, h_t = (42.662 - 29.7) / 2;
    a 24 mm journal (the paper's) leaves a 2.85 mm rim: 0.44 (the review's number); planet 1
    d_f = 3 (13 - 2.5 + 0.6) = 33.3 mm: 0.73."""
    paper, bronze = bushing("paper"), bushing("bronze")
    h2, h1 = (42.662 - 29.7) / 2, (46.059 - 33.3) / 2
    assert backup_ratio(geo, "planet2", paper) == pytest.approx((29.7 - 24.0) / 2 / h2, rel=1e-9)
    assert backup_ratio(geo, "planet1", paper) == pytest.approx((33.3 - 24.0) / 2 / h1, rel=1e-9)
    assert round(backup_ratio(geo, "planet2", paper), 2) == 0.44
    assert round(backup_ratio(geo, "planet1", paper), 2) == 0.73
    assert backup_ratio(geo, "planet2", bronze) == pytest.approx((29.7 - 14.0) / 2 / h2, rel=1e-9)
    assert backup_ratio(geo, "planet2", bronze) >= 1.2


def test_K_scales_with_the_lever(geo):
    """Without preload the pin law is homogeneous in the lever: K(bronze) / K(paper) to first
    order = lever ratio (the exact break-away differs a little: the lever also shifts F_12)."""
    Ks = {}
    for name in PIN_SETS:
        b = bushing(name)
        Ks[name] = locking_coefficients(pin_friction(geo, b.mu_effective, b.journalRadius))
    ratio = bushing("bronze").lever / bushing("paper").lever
    for k in (0, 1):
        assert Ks["bronze"][k] / Ks["paper"][k] == pytest.approx(ratio, rel=0.03)


def test_p_and_pv_by_hand(geo):
    b = bushing("bronze")
    pf = pin_friction(geo, b.mu_effective, b.journalRadius)
    ba = breakaway(pf, 2100.0, -1.0)
    kin = kinematics(geo)
    c1, c2 = check(geo, b, ba.F_pin, 1.0, (kin.planet1_per_sunA, kin.planet2_per_sunA))
    assert c1.p == pytest.approx(ba.F_pin[0] / (0.011 * 0.022), rel=1e-12)
    assert c2.v == pytest.approx(1.0 * 36 / 13 * 0.0055, rel=1e-12)
    assert c1.pv == pytest.approx(c1.p * c1.v, rel=1e-12)
    assert any("bushing pressure" in f for f in c1.findings(b))      # 2100 N m on an 11 mm x 22 mm bushing


def test_sliding_coefficients_and_info_prints_the_sliding_K(geo):
    """The sliding coefficient with the friction circle, sin(atan(0.08)) for the bronze set, and
    `spurdiff info` prints the sliding K (the pin law at mu_d') beside the break-away K of both sets."""
    from harness.measure.info import bushing_rows

    b = bushing("bronze")
    assert b.mu_effective_dynamic == pytest.approx(math.sin(math.atan(0.08)), rel=1e-14)
    assert bushing("paper").mu_effective_dynamic == bushing("paper").mu_effective == 0.26
    text = "\n".join(bushing_rows(geo, 0.05))
    for name in PIN_SETS:
        bs = bushing(name)
        Ks = locking_coefficients(pin_friction(geo, bs.muStatic / math.sqrt(1 + bs.muStatic ** 2)
                                               if bs.frictionCircle else bs.muStatic, bs.journalRadius))
        Kd = locking_coefficients(pin_friction(geo, bs.muDynamic / math.sqrt(1 + bs.muDynamic ** 2)
                                               if bs.frictionCircle else bs.muDynamic, bs.journalRadius))
        row = next(line for line in text.splitlines() if line.startswith(name))
        assert f"{Ks[0]:.4f} / {Ks[1]:.4f}  {Kd[0]:.4f} / {Kd[1]:.4f}" in row, row
    assert "K sliding" in text
