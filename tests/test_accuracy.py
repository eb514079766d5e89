"""spurdiff accuracy: grid measurement, stored data and fidelity = auto."""
import math
from dataclasses import replace

import pytest

from harness.accuracy import Point, apply_choice, choose, load_grid, measure_scene, read_csv, write_csv
from harness.runner import prepare_scene
from harness.scene import SceneError


def test_quick_grid_measures_errors_against_a_converged_reference():
    grid = load_grid()
    points, facts = measure_scene("paper-cornering", grid["paper-cornering"], quick=True, log=lambda *a: None)
    assert points and all(p.ok for p in points)
    assert facts["convergence"] < 1e-9  # the rigid model is exact for constant inputs
    for p in points:
        assert math.isfinite(p.wall) and p.wall > 0
        assert p.error < 1e-9


def _pts():
    # two settings of one scene: cheap but inaccurate on one metric, costly and accurate
    return [
        Point("paper-cornering", "cheap", {"meshModel": "rigid"}, 1e-2, None, 0.01, 0.5,
              {"mean(diff.left.w)": 1e-4, "max(diff.left.w)": 1e-4, "min(diff.left.w)": 1e-4,
               "mean(diff.mesh.F_A1)": 0.3, "max(diff.mesh.F_A1)": 0.5, "min(diff.mesh.F_A1)": 0.2}),
        Point("paper-cornering", "costly", {"meshModel": "rigid"}, 1e-4, None, 1.0, 1e-3,
              {"mean(diff.left.w)": 1e-6, "max(diff.left.w)": 1e-6, "min(diff.left.w)": 1e-6,
               "mean(diff.mesh.F_A1)": 1e-3, "max(diff.mesh.F_A1)": 1e-3, "min(diff.mesh.F_A1)": 1e-3}),
    ]


def test_auto_picks_the_cheapest_setting_meeting_the_tolerance_on_the_requested_outputs(tmp_path):
    write_csv(_pts(), tmp_path / "data.csv")
    data = read_csv(tmp_path / "data.csv")
    base = prepare_scene("paper-cornering")
    speeds = replace(base, fidelity={"mode": "auto", "outputs": ["diff.left.w"], "tolerance": 1e-3})
    forces = replace(base, fidelity={"mode": "auto", "outputs": ["diff.mesh.F_A1"], "tolerance": 1e-2})
    p1, why1 = choose(speeds, data)
    p2, why2 = choose(forces, data)
    assert p1.fidelity == "cheap" and "100x cheaper" in why1
    assert p2.fidelity == "costly"
    assert apply_choice(base, p1).step == 1e-2
    with pytest.raises(SceneError, match="no stored fidelity meets"):
        choose(replace(base, fidelity={"mode": "auto", "outputs": ["diff.mesh.F_A1"], "tolerance": 1e-5}), data)
