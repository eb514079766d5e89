"""harness.measure.bench.coupling (issue 19 item 2): the vehicle scenes against the old coupling at 0.2 ms;
its command line harness/cli/tools/coupling_bench.py (``python -m harness.cli.tools.coupling_bench``)."""
from __future__ import annotations

import json

import pytest

from harness.cli.tools.coupling_bench import main


def test_help_names_the_module(capsys):
    with pytest.raises(SystemExit) as e:
        main(["-h"])
    assert e.value.code == 0 and "python -m harness.cli.tools.coupling_bench" in capsys.readouterr().out


@pytest.mark.parametrize("argv, message", [
    (["no-such-scene"], "scene 'no-such-scene' not one of vehicle-cornering, split-mu-launch"),
    (["wheel-lift", "--steps", "0"], "--steps '0': allowed a comma-separated list of steps in (0, 0.1] s"),
    (["wheel-lift", "--steps", "1e-2,x"], "--steps '1e-2,x': allowed"),
])
def test_bad_arguments_are_one_line_and_exit_2(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_a_step_that_does_not_divide_the_scene_is_refused(fmu_files, tmp_path, capsys):
    cache = tmp_path / "refs.json"
    cache.write_text(json.dumps({"wheel-lift (1.1, 2.2)": {"ratio": 0.65, "lock": -13.8, "lock_absmean": 13.8}}))
    assert main(["wheel-lift", "--steps", "7e-3", "--cache", str(cache)]) == 2
    err = capsys.readouterr().err
    assert "does not divide duration" in err and err.count("\n") == 1


def test_wheel_lift_at_10_ms_meets_the_targets(fmu_files, tmp_path, capsys):
    """The reference run (old coupling, 0.2 ms) is cached in the given file; wheel-lift at 10 ms
    is within 1e-3 on the wheel-speed ratio and 1 % on the locking torque."""
    cache = tmp_path / "refs.json"
    assert main(["wheel-lift", "--steps", "1e-2", "--cache", str(cache)]) == 0
    refs = json.loads(cache.read_text())
    assert set(refs) == {"wheel-lift (1.1, 2.2)"} and refs["wheel-lift (1.1, 2.2)"]["lock"] < -10.0
    row = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("| wheel-lift | 10 |")]
    assert len(row) == 1
    ratio, lock_rel = (float(x) for x in row[0].split("|")[4:6])
    assert ratio < 1e-3 and lock_rel < 1e-2
