"""Issue 14, items 4, 9 and 10: values are read by their type (a boolean given as a word is that
boolean, an integer must fit int32), a step must divide the duration, an input profile's times
must be numbers, and a duration whose samples cannot fit in memory is refused before running."""
from __future__ import annotations

import csv
import math

import pytest

from hostile_harness_util import cli, one_line_error, sandbox, scene, sweep  # noqa: F401

CHECK = "friction at full capacity while slipping"


def locking(out: str) -> float:
    line = next(x for x in out.splitlines() if CHECK in x)
    return float(line.split(": ", 1)[1].split()[0])


@pytest.mark.parametrize("word, on", [("off", False), ("false", False), ("No", False), ('"FALSE"', False),
                                      ("0", False), ("on", True), ("yes", True), ("true", True)])
def test_boolean_parameter_given_as_a_word_is_that_boolean(sandbox, capsys, fmu_files, word, on):
    r = cli(capsys, "run", "paper-cornering", "--duration", "0.05", "--no-plots", "--out", sandbox.dir,
            "--set", f"diff.pinFriction={word}")
    assert r.rc in (0, 1), r.err
    assert (locking(r.out) > 1.0) is on   # the locking torque is 0 without pin friction


def test_boolean_word_that_is_no_boolean_is_refused(sandbox, capsys, fmu_files):
    r = cli(capsys, "run", "paper-cornering", "--duration", "0.05", "--no-plots", "--out", sandbox.dir,
            "--set", "diff.pinFriction=maybe")
    one_line_error(r, "diff.pinFriction = 'maybe'", "allowed a boolean")


def test_scene_boolean_effect_given_as_a_string_is_converted(fmu_files):
    from harness.run.runner import typed_parameters
    from harness.scene.spec import load_scene, merge, parse_scene, read_scene_data

    data = merge(read_scene_data("paper-cornering"), {"effects": {"backlash": "false", "pinFriction": "off"}})
    sc = typed_parameters(parse_scene(data), fmu_files)
    assert sc.effects["backlash"] is False and sc.effects["pinFriction"] is False
    assert load_scene("paper-cornering").effects.get("backlash") is None   # the bundled scene is untouched


@pytest.mark.parametrize("value, words", [
    ("true", ["diff.nPairs = True", "allowed an integer"]),
    ("4294967299", ["diff.nPairs = 4294967299", "int32 range"]),
    ("2.5", ["diff.nPairs = 2.5", "allowed an integer"]),
    ('"3"', ["diff.nPairs = '3'", "allowed an integer"]),
])
def test_integer_parameter_refuses_what_is_not_an_int32(sandbox, capsys, fmu_files, value, words):
    r = cli(capsys, "run", "paper-cornering", "--duration", "0.05", "--no-plots", "--out", sandbox.dir,
            "--set", f"diff.nPairs={value}")
    one_line_error(r, *words)
    assert list(sandbox.dir.iterdir()) == []


def test_real_parameter_given_a_word_is_refused(sandbox, capsys, fmu_files):
    r = cli(capsys, "run", "paper-cornering", "--duration", "0.05", "--no-plots", "--out", sandbox.dir,
            "--set", "diff.mu_pin=abc")
    one_line_error(r, "diff.mu_pin = 'abc'", "allowed a number")


def test_sweep_boolean_values_given_as_words_are_converted(sandbox, capsys, fmu_files):
    p = sandbox.dir / "sw.toml"
    p.write_text('name = "sw"\nscene = "paper-cornering"\nduration = 0.05\n[[parameters]]\n'
                 'name = "diff.pinFriction"\nvalues = ["off", "on"]\n'
                 '[[metrics]]\nname = "lt"\nvar = "diff.lockingTorque"\nstat = "max"\n')
    r = cli(capsys, "sweep", p, "--workers", "0", "--quiet", "--out", sandbox.dir / "out")
    assert r.rc == 0, r.err
    rows = list(csv.DictReader(open(sandbox.dir / "out" / "sw.csv")))
    assert [(x["diff.pinFriction"], float(x["lt"]) > 1.0) for x in rows] == [("false", False), ("true", True)]


@pytest.mark.parametrize("param, values, words", [
    ("diff.nPairs", "[3, true]", ["parameters 'diff.nPairs'.values = True", "allowed an integer"]),
    ("diff.nPairs", "[4294967299]", ["int32 range"]),
    ("diff.pinFriction", '["off", "perhaps"]', ["'perhaps'", "allowed a boolean"]),
    ("diff.mu_pin", '["abc"]', ["'abc'", "allowed a number"]),
])
def test_sweep_values_that_do_not_fit_the_type_are_refused(sandbox, capsys, fmu_files, param, values, words):
    p = sandbox.dir / "sw.toml"
    p.write_text(f'name = "sw"\nscene = "paper-cornering"\nduration = 0.05\n[[parameters]]\n'
                 f'name = "{param}"\nvalues = {values}\n'
                 '[[metrics]]\nname = "lt"\nvar = "diff.lockingTorque"\nstat = "max"\n')
    r = cli(capsys, "sweep", p, "--workers", "0", "--quiet", "--out", sandbox.dir / "out")
    one_line_error(r, "sw.toml: ", *words)


def test_step_that_does_not_divide_the_duration_is_refused(sandbox, capsys):
    r = cli(capsys, "run", "paper-cornering", "--step", "0.18", "--duration", "0.3", "--no-plots",
            "--out", sandbox.dir)
    one_line_error(r, "step = 0.18 s does not divide duration = 0.3 s", "e.g. 0.15 s")
    p = scene(sandbox.dir, "duration = 0.3\nstep = 0.18\noutput_interval = 0.18")
    r = cli(capsys, "run", p, "--no-plots", "--out", sandbox.dir)
    one_line_error(r, "hostile.toml", "does not divide")
    assert list(sandbox.dir.glob("*.csv")) == []


@pytest.mark.parametrize("profile", [
    '[inputs."diff.left.tau".step]\ntime = nan\nbefore = 0.0\nafter = -1110.201',
    '[inputs."diff.left.tau"]\ntable = [[0.0, 0.0], [nan, -1110.201]]',
    '[inputs."diff.left.tau".step]\ntime = 0.01\nrise = -0.01\nafter = -1110.201',
])
def test_input_profile_time_that_is_no_number_is_refused(sandbox, capsys, profile):
    p = scene(sandbox.dir, profile)
    r = cli(capsys, "run", p, "--duration", "0.05", "--no-plots", "--out", sandbox.dir)
    one_line_error(r, "hostile.toml: inputs.'diff.left.tau'", "allowed a")


def test_duration_whose_samples_cannot_fit_in_memory_is_refused_before_running(sandbox, capsys):
    p = scene(sandbox.dir, "duration = 1e300")
    r = cli(capsys, "run", p, "--no-plots", "--out", sandbox.dir)
    one_line_error(r, "duration = 1e+300 s", "samples", "allowed: at most")
    r = cli(capsys, "run", "paper-cornering", "--duration", "1e300", "--no-plots", "--out", sandbox.dir)
    one_line_error(r, "duration = 1e+300 s")
    p = sweep(sandbox.dir, '[[metrics]]\nname = "lt"\nvar = "diff.lockingTorque"\nstat = "mean"')
    r = cli(capsys, "sweep", p, "--workers", "0", "--quiet", "--duration", "1e300", "--out", sandbox.dir / "o")
    one_line_error(r, "duration = 1e+300 s")
    assert list(sandbox.dir.glob("*.csv")) == []


def test_recording_budget_counts_the_samples():
    from dataclasses import replace

    from harness.run.master import check_recording, recording_size
    from harness.scene.spec import SceneError, load_scene

    sc = load_scene("paper-cornering")
    assert recording_size(sc) == (300, 302, 1 + len(sc.record))
    check_recording(sc)
    with pytest.raises(SceneError, match="allowed: at most"):
        check_recording(replace(sc, duration=1e15))


def test_parameter_value_reads_each_fmi_type():
    from harness.scene.spec import SceneError, parameter_value as pv

    assert [pv("k", "Boolean", v) for v in ("Off", " NO ", "false", 0, False, "on", "Yes", 1, True)] == \
        [False] * 5 + [True] * 4
    assert pv("k", "Integer", 3.0) == 3 and type(pv("k", "Integer", 3.0)) is int
    assert pv("k", "Integer", -2**31) == -2**31 and pv("k", "Enumeration", 2**31 - 1) == 2**31 - 1
    assert pv("k", "Real", 2) == 2.0 and pv("k", "String", "rigid") == "rigid"
    assert math.isnan(pv("k", "Real", float("nan"), finite=False))   # the master lets the FMU refuse it
    for t, v, words in [("Boolean", 2, "allowed a boolean"), ("Boolean", 0.5, "allowed a boolean"),
                        ("Integer", True, "allowed an integer"), ("Integer", 2**31, "int32 range"),
                        ("Integer", "3", "allowed an integer"), ("Real", "1.5", "allowed a number"),
                        ("Real", True, "allowed a number"), ("Real", 10**400, "allowed a finite number"),
                        ("Real", float("inf"), "allowed a finite number"), ("String", 3, "allowed a string")]:
        with pytest.raises(SceneError) as e:
            pv("diff.x", t, v)
        assert str(e.value).startswith("diff.x = ") and words in str(e.value) and len(str(e.value)) < 200


def test_export_ssp_converts_a_boolean_word_like_run(tmp_path):
    """`spurdiff export-ssp --set diff.pinFriction=off` binds false (it used to be refused)."""
    import zipfile

    from harness.cli.export_ssp import main as export_main

    out = tmp_path / "pc.ssp"
    assert export_main(["paper-cornering", "-o", str(out), "--set", "diff.pinFriction=off"]) == 0
    ssd = zipfile.ZipFile(out).read("SystemStructure.ssd").decode()
    i = ssd.index('<ssv:Parameter name="pinFriction">')
    assert 'value="false"' in ssd[i:i + 200]
