"""Two gaps `spurdiff mutate` found (tests/mutations.toml: stuck-capacity-sliding-k,
capacity-watch-maxima-on-restore; issue 47 item 5): the paper law's stuck differential holds up to
the static K, not the sliding K_slide (which no test told apart: mu_pinDynamic defaults to mu_pin),
and a restored model state brings the stress watch's maxima back with it."""
from __future__ import annotations

import json

from spurdiff.differential.params import DifferentialParams
from spurdiff.differential.rigid import RigidDifferential
from spurdiff.fmi import differential_fmu as D

W0 = 1.389


def paper_model(r: float) -> RigidDifferential:
    """Speed-driven, stuck at the start, sun loads -1000 (1 + r) and -1000 (1 - r) N m (bias r); the
    sliding pin friction half the static one."""
    p = DifferentialParams(carrierDrive="speed", lockingLaw="paper", pinSpeedLoads=False)
    p = DifferentialParams(carrierDrive="speed", lockingLaw="paper", pinSpeedLoads=False, mu_pinDynamic=0.5 * p.mu_pin)
    m = RigidDifferential(p)
    m.w_ref, m.tau_L, m.tau_R, m.tau_c = W0, -1000.0 * (1.0 + r), -1000.0 * (1.0 - r), 0.0
    m.w_start_carrier = W0
    m.initialize()
    for k in range(20):
        m.do_step(k * 1e-3, 1e-3)
    return m


def test_the_stuck_paper_law_holds_up_to_the_static_k_not_the_sliding_one():
    K, K_slide = paper_model(0.0).K, paper_model(0.0).K_slide
    assert K_slide < 0.6 * K
    for r in (0.5 * K_slide, 0.5 * (K + K_slide), 0.99 * K):    # between K_slide and K: still stuck
        m = paper_model(r)
        assert m.stuck and m.wd == 0.0, r
    m = paper_model(1.01 * K)                                    # past K: it breaks away
    assert not m.stuck and m.wd != 0.0


def test_a_restored_state_brings_the_stress_watchs_maxima_back():
    values = {v.name: v.start for v in D.VARIABLES}
    m = D.build_model(values)
    w = m.capacity_watch
    for k in range(5):
        m.do_step(k * 1e-3, 1e-3)
    saved = json.loads(json.dumps(m.get_state()))       # as a serialized FMU state
    kept = (w.sigma_H_max, w.sigma_F_max)
    assert kept[0] > 0.0 and kept[1] > 0.0
    m.tau_L, m.tau_R = 3.0 * m.tau_L, 3.0 * m.tau_R      # heavier: the maxima grow
    for k in range(5, 10):
        m.do_step(k * 1e-3, 1e-3)
    assert w.sigma_H_max > kept[0] and w.sigma_F_max > kept[1]
    m.set_state(saved)
    assert (w.sigma_H_max, w.sigma_F_max) == kept
