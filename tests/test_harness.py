"""Scenes, the master and the CLI on the paper's straight-line scene (rigid model)."""
import csv

import pytest

from harness.cli import main
from harness.scene import SceneError, available, load_scene, parse_scene


BASE = {"name": "t", "duration": 0.01, "step": 1e-3, "fmus": {"diff": {"fmu": "SpurDifferential"}}}


def test_shipped_scenes_parse():
    assert "paper-straight" in available()
    for name in available():
        load_scene(name)


@pytest.mark.parametrize("patch,match", [
    ({"durration": 1.0}, "unknown key 'durration'"),
    ({"step": 0.0}, "step"),
    ({"step": float("nan")}, "step"),
    ({"algorithm": "newton"}, "algorithm"),
    ({"fmus": {"diff": {"fmu": "SpurDifferential", "params": {}}}}, "unknown key 'params'"),
    ({"inputs": {"nodiff.left.tau": 1.0}}, "unknown FMU instance 'nodiff'"),
    ({"inputs": {"diff.left.tau": {"tabel": []}}}, "unknown key 'tabel'"),
    ({"checks": [{"stat": "median", "var": "diff.left.w"}]}, "median"),
])
def test_bad_scene_keys_are_named(patch, match):
    with pytest.raises(SceneError, match=match):
        parse_scene({**BASE, **patch})


def test_run_paper_straight_cli(tmp_path, capsys):
    rc = main(["run", "paper-straight", "--out", str(tmp_path), "--no-plots"])
    out = capsys.readouterr().out
    assert rc == 0
    assert "Input (carrier) torque" in out and "2,092,899" in out and "PASS" in out and "FAIL" not in out
    rows = list(csv.reader(open(tmp_path / "paper-straight.csv")))
    assert rows[0][0] == "time" and len(rows) == 302  # header + t = 0 .. 0.3 s every 1 ms


def test_unknown_scene_is_one_line_and_nonzero(capsys):
    assert main(["run", "no-such-scene"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown scene 'no-such-scene'" in err[0] and "paper-straight" in err[0]


def test_bad_parameter_stops_run_with_fmu_message_and_keeps_results(tmp_path, capsys):
    rc = main(["run", "paper-straight", "--set", "diff.mu_pin=-1", "--out", str(tmp_path), "--no-plots"])
    err = capsys.readouterr().err
    assert rc != 0 and "diff" in err and "mu_pin" in err
    assert (tmp_path / "paper-straight.csv").exists()


def test_unknown_parameter_is_named(tmp_path, capsys):
    rc = main(["run", "paper-straight", "--set", "diff.mu_pni=0.1", "--out", str(tmp_path), "--no-plots"])
    assert rc == 2 and "mu_pni" in capsys.readouterr().err


def test_info_prints_theory_beside_paper(capsys):
    assert main(["info"]) == 0
    out = capsys.readouterr().out
    for s in ("59,497", "60,201", "0.028332", "13.3987", "undercut"):
        assert s in out


def test_direct_physics_run_equals_fmi_run(fmu_files):
    """The FMI layer adds cost, not differences: same scene, bit-identical trajectories."""
    from dataclasses import replace

    import numpy as np

    from harness.direct import run_direct
    from harness.master import run_scene
    from harness.runner import prepare_scene

    for algorithm in ("gauss-seidel", "jacobi"):
        s = replace(prepare_scene("paper-cornering", algorithm=algorithm), duration=0.05)
        a, b = run_direct(s), run_scene(s, fmu_files)
        assert a.ok and b.ok
        assert a.data.shape == b.data.shape
        assert np.array_equal(a.data, b.data)


def test_table_and_checks_accept_expressions(fmu_files):
    from harness.master import run_scene
    from harness.report import evaluate_checks, stat

    scene = parse_scene({**BASE, "duration": 0.05, "inputs": {"diff.carrier.w_ref": 1.389, "diff.left.tau": -1110.201,
                                                             "diff.right.tau": -989.799},
                         "checks": [{"name": "kinematics", "stat": "absmax",
                                     "var": "{diff.left.w} + {diff.right.w} - 2 * {diff.carrier.w}", "below": 1e-9}]})
    r = run_scene(scene, fmu_files)
    assert [o.passed for o in evaluate_checks(r)] == [True]
    assert stat(r, "{diff.right.w} - {diff.left.w}", "final") > 0.0


def test_integer_outputs_can_be_recorded(fmu_files):
    from harness.master import run_scene
    from harness.runner import prepare_scene

    s = prepare_scene("paper-cornering", duration=0.02)
    s.record += ["diff.modeSwitches", "diff.internalSteps"]
    r = run_scene(s, fmu_files)
    assert r.ok and r["diff.internalSteps"][-1] == 20 and r["diff.modeSwitches"][-1] >= 0
