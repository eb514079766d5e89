"""The watches on a differential model's run (spurdiff.differential.watches): the step hook of the
outermost model only (the half-shafts' inner model keeps its class), the watches' state in the
model's under their key (a state without it gives a fresh watch), the overspeed limit from the pin
bushings, and bad limits named."""
from __future__ import annotations

import json
import math

import pytest

from spurdiff.differential.bushing import bushing
from spurdiff.differential.params import DifferentialParams
from spurdiff.differential.rigid import RigidDifferential
from spurdiff.differential.shafts import ShaftedDifferential
from spurdiff.differential.watches import CapacityWatch, OverspeedWatch, Watch, attach
from spurdiff.errors import ParameterError
from spurdiff.gears.capacity import CapacityParams

H = 1e-3


class Counting(Watch):
    """Counts the steps it saw; its state is the count; one message at the second step."""

    name, key = "counting", "count"

    def __init__(self):
        self.n = 0

    def after_step(self, model, t, h):
        self.n += 1
        return "second step" if self.n == 2 else None

    def get_state(self):
        return self.n

    def set_state(self, s, model=None):
        self.n = 0 if s is None else s


def _rigid(**kw) -> RigidDifferential:
    m = RigidDifferential(DifferentialParams(carrierDrive="torque", **kw))
    m.tau_c, m.tau_L, m.tau_R = 2000.0, -1500.0, -100.0     # above break-away: the differential slips
    m.initialize(0.0)
    return m


def test_the_watches_look_after_each_step_and_their_messages_are_logged_as_warnings():
    m = _rigid()
    w = Counting()
    attach(m, [w])
    assert m.counting is w and isinstance(m, RigidDifferential)
    logged = []
    m.log_to(lambda msg, level=0: logged.append((level, msg)))
    for i in range(3):
        m.do_step(i * H, H)
    assert w.n == 3
    assert logged == [(1, f"t = {2 * H:g} s: second step")]


def test_only_the_outermost_model_is_watched():
    inner = _rigid()
    m = ShaftedDifferential(inner)
    m.initialize(0.0)
    w = Counting()
    attach(m, [w])
    for i in range(4):
        m.do_step(i * H, H)
    assert w.n == 4                          # once per communication step, not per inner evaluation
    assert type(m.inner) is RigidDifferential and not hasattr(m.inner, "watches")


def test_the_watch_state_travels_with_the_model_state_and_a_state_without_it_starts_fresh():
    m = _rigid()
    w = Counting()
    attach(m, [w])
    m.do_step(0.0, H)
    s = json.loads(json.dumps(m.get_state()))          # as a serialized FMU state
    assert s["count"] == 1
    m.do_step(H, H)
    m.set_state(s)
    assert w.n == 1
    del s["count"]
    m.set_state(s)
    assert w.n == 0


def test_the_overspeed_limit_defaults_to_the_bronze_bushings_sliding_speed():
    m = _rigid()
    t = m.geometry.table
    rho = max(t.sunA.z / t.planet1.z, t.sunB.z / t.planet2.z)
    w = OverspeedWatch(m)
    assert w.limit == bushing("bronze").vMax / (m.params.r_collar * rho)
    assert OverspeedWatch(m, 5.0).limit == 5.0
    for bad in (-1.0, math.inf, math.nan):
        with pytest.raises(ParameterError, match="overspeedLimit"):
            OverspeedWatch(m, bad)


def test_overspeed_indicator_and_one_warning():
    m = _rigid()
    w = OverspeedWatch(m, 1e-3)
    cw = CapacityWatch(m, CapacityParams())
    attach(m, [cw, w])
    logged = []
    m.log_to(lambda msg, level=0: logged.append((level, msg)))
    for i in range(5):
        m.do_step(i * H, H)
    assert abs(m.wd) > 1e-3 and m.overspeed_watch.indicator == 1.0
    over = [msg for level, msg in logged if "overspeed" in msg]
    assert len(over) == 1 and over[0].startswith(f"t = {H:g} s: overspeed, |w_A - w_c| = ")
    assert "capacity" in m.get_state() and "overspeed" not in json.dumps(list(m.get_state()))
