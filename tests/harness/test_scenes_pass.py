"""Every shipped scene, run as a user runs it (`spurdiff run NAME`, its default fidelity and step),
passes all of its physical checks: exit 0, no FAIL line. (wheel-lift once started 16 N m off its
slipping torque split after the locking law changed, and failed its inertia check at 5 ms.)"""
from __future__ import annotations

from pathlib import Path

import pytest

from harness.cli import main

SCENES = sorted(p.stem for p in (Path(__file__).resolve().parents[2] / "harness" / "scenes").glob("*.toml"))


@pytest.mark.parametrize("scene", SCENES)
def test_the_scene_passes_its_checks(scene, fmu_files, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    code = main(["run", scene, "--no-plots"])
    out = capsys.readouterr().out
    fails = [line for line in out.splitlines() if line.startswith("FAIL")]
    assert code == 0 and not fails, "\n".join(fails) or out[-2000:]
    assert (tmp_path / "results" / scene / f"{scene}.csv").is_file()
