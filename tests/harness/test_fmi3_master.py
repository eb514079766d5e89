"""The harness's FMI 3.0 master (harness/run/master3.py): first-order hold with the differential's output
derivatives and early return at its stick/slip switches, both switches; off, it is the plain master
to the last bit."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from harness.measure.fmi3_features import trajectory_error
from harness.run.master import run_scene
from harness.run.master3 import Master3, run_scene3
from harness.run.runner import fmu_files_for, prepare_scene
from harness.scene.spec import SceneError


@pytest.fixture(scope="module")
def tip():
    sc = prepare_scene("tip-in-tip-out", duration=0.3)
    return sc, fmu_files_for(sc, fmi_version=3)


def test_off_it_is_the_plain_master(tip):
    sc, files = tip
    plain = run_scene(sc, files)
    res, stats = run_scene3(sc, files)
    assert res.ok and np.array_equal(res.data, plain.data)
    assert stats == {"early_returns": 0, "pieces": 60, "rollbacks": 0, "derivative_reads": 0}


def test_first_order_hold(tip):
    sc, files = tip
    zoh, _ = run_scene3(sc, files)
    foh, stats = run_scene3(sc, files, hold="foh")
    # Gauss-Seidel with the differential before the wheels: they take the torques it computed for the
    # same step, nothing to extrapolate; the derivatives are read all the same
    assert np.array_equal(foh.data, zoh.data) and stats["derivative_reads"] == 60
    jac = replace(sc, algorithm="jacobi")
    jz, _ = run_scene3(jac, files)
    jf, stats = run_scene3(jac, files, hold="foh")
    assert jz.ok and jf.ok and stats["derivative_reads"] == 60
    assert not np.array_equal(jf["diff.leftShaft.tau"], jz["diff.leftShaft.tau"])
    # the torques the wheels were given: held plus rate times half a step (their step's middle)
    assert trajectory_error(jf, jz) > 0.0


def test_early_return_stops_the_step_at_the_switch():
    sc = prepare_scene("split-mu-launch", duration=0.6)
    files = fmu_files_for(sc, fmi_version=3)
    zoh, _ = run_scene3(sc, files)
    er, stats = run_scene3(sc, files, early_return=True)
    assert er.ok and stats["early_returns"] >= 1 and stats["rollbacks"] == stats["early_returns"]
    assert stats["pieces"] == 120 + stats["early_returns"]
    assert np.array_equal(er.time, zoh.time)   # recorded on the grid
    first = np.argmax(np.any(er.data != zoh.data, axis=1))
    assert first > 0 and np.array_equal(er.data[:first], zoh.data[:first])   # the same until the first switch


def test_bad_switches_are_refused(tip):
    sc, files = tip
    with pytest.raises(SceneError, match="hold"):
        Master3(sc, files, hold="spline")
    with pytest.raises(SceneError, match="Gauss-Seidel"):
        Master3(replace(sc, algorithm="jacobi"), files, early_return=True)
