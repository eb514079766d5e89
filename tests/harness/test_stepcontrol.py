"""Variable communication steps from the power-bond energy residual (harness.run.stepcontrol)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from harness.run.master import run_scene
from harness.run.report import series, stat
from harness.run.runner import prepare_scene
from harness.scene.spec import SceneError
from harness.run.stepcontrol import StepControl, bond_error, run_variable


def test_bond_error_is_the_energy_the_hold_misses():
    ctl = StepControl(rtol=1e-3, atol=0.0)
    # constant torque and speed: nothing missed
    assert bond_error({"b": (100.0, 30.0)}, {"b": (100.0, 30.0)}, 1e-2, ctl) == 0.0
    # speed change 1 rad/s under 100 N m over 10 ms: 0.5 J missed of 30 J transferred -> 1.6e-2 / 1e-3
    e = bond_error({"b": (100.0, 30.0)}, {"b": (100.0, 31.0)}, 1e-2, ctl)
    assert e == pytest.approx(0.5 * 1e-2 * 100.0 * 1.0 / (1e-3 * 100.0 * 30.5 * 1e-2))


def test_bad_settings_are_one_line_errors():
    with pytest.raises(SceneError, match="h_start"):
        StepControl(h_start=1.0).validate()
    with pytest.raises(SceneError, match="rtol"):
        StepControl(rtol=float("nan")).validate()


def test_variable_steps_follow_the_transient_and_agree_with_fixed_steps(fmu_files):
    """tip-in-tip-out: steady turn up to 0.5 s, then the tip-in, the drive-coast reversal from
    2.0 s: the controller takes 20 ms steps in the steady turn and goes down to 0.1 ms in the
    reversal; the trajectory agrees with a fixed 1 ms run."""
    scene = replace(prepare_scene("tip-in-tip-out", duration=2.4), output_interval=1e-3)
    ref = run_scene(replace(scene, step=1e-3), fmu_files)
    r, m = run_variable(scene, fmu_files, StepControl(rtol=1e-3, atol=1e-3))
    assert r.ok, r.failure
    assert np.all(np.isfinite(r.data)) and r.time[-1] == pytest.approx(2.4, abs=1e-12)
    h = np.diff(r.time)
    t = r.time[1:]
    assert h[t < 0.5].max() >= 1e-2 and h[(t > 2.0) & (t < 2.2)].min() <= 1e-3
    ratio = np.interp(ref.time, r.time, series(r, "{wheelR.wheel.w} / {wheelL.wheel.w}"))
    assert np.max(np.abs(ratio - series(ref, "{wheelR.wheel.w} / {wheelL.wheel.w}"))) < 2e-3
    assert stat(r, "diff.lockingTorque", "mean", [1.0, 2.4]) == pytest.approx(
        stat(ref, "diff.lockingTorque", "mean", [1.0, 2.4]), rel=1e-2)
    assert m.rejected >= 1          # a step was redone through fmi2SetFMUstate


def test_without_redo_no_state_is_taken_and_every_step_is_accepted(fmu_files, monkeypatch):
    """reject = False (the non-iterative form): no FMU state saved or restored, no step redone;
    the error of each step still sets the next (small steps at the tip-in, larger before it)."""
    from harness.run.stepcontrol import VariableStepMaster

    def refuse(self, *a):
        raise AssertionError("an FMU state was saved or restored")

    monkeypatch.setattr(VariableStepMaster, "_save", refuse)
    monkeypatch.setattr(VariableStepMaster, "_restore", refuse)
    scene = prepare_scene("tip-in-tip-out", duration=0.8)
    r, m = run_variable(scene, fmu_files, StepControl(rtol=1e-2, atol=1e-2, reject=False))
    assert r.ok, r.failure
    assert m.rejected == 0 and len(m.steps_taken) == r.steps
    assert sum(m.steps_taken) == pytest.approx(0.8, abs=1e-12)
    before = [h for h, t in zip(m.steps_taken, np.cumsum(m.steps_taken)) if t < 0.5]
    after = [h for h, t in zip(m.steps_taken, np.cumsum(m.steps_taken)) if 0.5 < t < 0.65]
    assert min(after) < 0.5 * max(before)
