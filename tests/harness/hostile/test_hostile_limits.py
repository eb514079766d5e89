"""Issue 30, items 3 to 5: limits said up front (steps and recorded samples estimated before a run,
numeric overflow and deep nesting one line), checks that can fail (an expectation required, a
window inside the run), the expression limit counting what it says, and output hygiene (values
echoed cut with their length, control characters escaped on the terminal)."""
from __future__ import annotations

import pytest

from hostile_harness_util import cli, one_line_error, sandbox, scene, sweep  # noqa: F401

BIG = "1" + "0" * 400          # an integer no float holds
HUGE = "1" + "0" * 5000        # more digits than Python reads from text by default
CHECK = '[[checks]]\nname = "c"\nstat = "mean"\nvar = "diff.carrier.tauDrive"\n'


# ------------------------------------------------------------------------- limits up front
@pytest.mark.parametrize("argv, words", [
    (["--duration", "1e308"], ["duration = 1e+308 s", "communication steps", "allowed: at most"]),
    (["--step", "1e-320"], ["step = 9.99989e-321 s", "communication steps", "allowed: at most"]),
    (["--step", "1e-14", "--duration", "0.01"],
     ["1,000,000,000,000 communication steps", "12 samples", "allowed: at most 1,000,000 steps", "--max-steps"]),
    (["--step", "1e-5", "--duration", "0.02", "--max-steps", "1000"],
     ["2,000 communication steps", "allowed: at most 1,000 steps"]),
    (["--max-steps", "0"], ["--max-steps = 0", "allowed an integer >= 1"]),
])
def test_a_run_too_long_to_make_is_refused_up_front_with_its_estimate(sandbox, capsys, argv, words):
    r = cli(capsys, "run", "paper-cornering", "--no-plots", "--out", sandbox.dir, *argv)
    one_line_error(r, *words)
    assert list(sandbox.dir.iterdir()) == []


def test_the_step_limit_is_raised_by_max_steps(sandbox, capsys, fmu_files):
    r = cli(capsys, "run", "paper-cornering", "--no-plots", "--out", sandbox.dir, "--step", "1e-5",
            "--duration", "0.02", "--max-steps", "2000")
    assert r.rc in (0, 1), r.err
    assert len((sandbox.dir / "paper-cornering.csv").read_text().splitlines()) == 22


def test_a_sweep_too_long_to_make_is_refused_up_front(sandbox, capsys):
    p = sweep(sandbox.dir, '[[metrics]]\nname = "lt"\nvar = "diff.lockingTorque"\nstat = "mean"', duration=2000)
    r = cli(capsys, "sweep", p, "--workers", "0", "--quiet", "--out", sandbox.dir / "o")
    one_line_error(r, "2,000,000 communication steps", "allowed: at most 1,000,000 steps", "--max-steps")


@pytest.mark.parametrize("body, words", [
    ("duration = 1e308", ["duration = 1e+308 s", "communication steps", "allowed: at most"]),
    (f"duration = {BIG}", ["duration = 1000000", "(401 characters", "allowed a finite number > 0"]),
    (f"duration = {HUGE}", ["not valid TOML", "4300 digits"]),
    (CHECK.replace('stat = "mean"', 'stat = ["mean"]'), ["checks 'c'.stat = ['mean']", "allowed: absmax"]),
    (CHECK.replace('stat = "mean"', 'stat = {a = 1}'), ["checks 'c'.stat = {'a': 1}", "allowed: absmax"]),
    (CHECK + f"below = {BIG}", ["checks 'c'.below", "allowed a finite number"]),
    (f'[[table]]\nlabel = "x"\nvar = "diff.carrier.tauDrive"\nscale = {BIG}', ["table 'x'.scale", "allowed a finite number"]),
    (f'[inputs]\n"diff.left.tau" = {{table = [[0, 1], [{BIG}, 1]]}}', ["inputs.'diff.left.tau'", "allowed a"]),
    ("description = " + "[" * 40 + "]" * 40, ["nested 41 levels deep", "allowed: at most 32"]),
    ("x = " + "[" * 5000 + "]" * 5000, ["nested too deep to read", "allowed: at most 32 levels"]),
    ("description" + ".a" * 3000 + " = 1", ["nested 3001 levels deep", "allowed: at most 32"]),   # was a RecursionError in repr
])
def test_a_value_that_overflows_or_nests_too_deep_is_one_line(sandbox, capsys, body, words):
    p = scene(sandbox.dir, "duration = 0.05\n" + body if not body.startswith("duration") else body)
    r = cli(capsys, "run", p, "--no-plots", "--out", sandbox.dir / "out")
    one_line_error(r, *words)


@pytest.mark.parametrize("metric, words", [
    ('var = "diff.lockingTorque"\nstat = ["mean"]', ["stat = ['mean']", "allowed: absmax"]),
    ('theory = ["locking_coefficient"]', ["theory = ['locking_coefficient']", "allowed: "]),
])
def test_a_sweep_metric_given_as_a_list_is_one_line(sandbox, capsys, metric, words):
    p = sweep(sandbox.dir, f'[[metrics]]\nname = "m"\n{metric}')
    r = cli(capsys, "sweep", p, "--workers", "0", "--quiet", "--out", sandbox.dir / "o")
    one_line_error(r, *words)


def test_a_set_value_nested_too_deep_is_one_line(sandbox, capsys):
    r = cli(capsys, "run", "paper-cornering", "--no-plots", "--out", sandbox.dir,
            "--set", "diff.mu_pin=" + "[" * 5000 + "]" * 5000)
    one_line_error(r, "--set value '[[[[", "nested too deep")
    r = cli(capsys, "run", "paper-cornering", "--no-plots", "--out", sandbox.dir, "--set", f"diff.mu_pin={HUGE}")
    one_line_error(r, "--set value", "a number too long to read")


# ------------------------------------------------------------------------- checks that can fail
@pytest.mark.parametrize("body, words", [
    (CHECK, ["checks 'c': no expectation, so it cannot fail", "allowed: one of expect, expect_var, below, above"]),
    (CHECK + "rtol = 0.1\nbelow = 1", ["checks 'c': rtol/atol without expect or expect_var"]),
    (CHECK + "below = 1e9\nwindow = [0.5, 0.6]", ["checks 'c'.window = [0.5, 0.6] s is outside the run",
                                                  "allowed: a window within 0 .. 0.3 s"]),
    ('[[table]]\nlabel = "x"\nvar = "diff.carrier.tauDrive"\nwindow = [1, 2]', ["table 'x'.window = [1, 2] s"]),
])
def test_a_check_that_cannot_fail_is_refused_when_the_scene_is_read(sandbox, capsys, body, words):
    p = scene(sandbox.dir, body)
    r = cli(capsys, "run", p, "--no-plots", "--out", sandbox.dir / "out")
    one_line_error(r, *words)


def test_a_run_shortened_before_a_window_says_not_checked_never_pass_or_fail(sandbox, capsys, fmu_files):
    p = scene(sandbox.dir, CHECK + "below = 1e9\nwindow = [0.2, 0.3]\n" + CHECK.replace('"c"', '"cut"')
              + "below = 1e9\nwindow = [0.01, 0.3]")
    r = cli(capsys, "run", p, "--no-plots", "--duration", "0.05", "--out", sandbox.dir / "out")
    assert r.rc in (0, 1), r.err
    line = next(x for x in r.out.splitlines() if x.endswith("c: not checked: window [0.2, 0.3] s starts after "
                                                            "this run's end (0.05 s)"))
    assert line.startswith("N/A")
    cut = next(x for x in r.out.splitlines() if " cut: " in x)
    assert cut.startswith("PASS") and "over [0.01, 0.05] s: the run ends inside the window" in cut


def test_the_expression_limit_counts_terms():
    from harness.scene.expressions import ExpressionError, compile_expression

    compile_expression("+".join(["1"] * 200), "x")   # 200 terms: allowed (was refused as 599 'terms')
    with pytest.raises(ExpressionError, match=r"201 terms \(numbers and references\); allowed at most 200"):
        compile_expression("+".join(["1"] * 201), "x")


# ------------------------------------------------------------------------- output hygiene
def test_a_long_value_is_echoed_cut_with_its_length(sandbox, capsys):
    key = "k" * 1_000_000
    p = scene(sandbox.dir, f"{key} = 1")
    r = cli(capsys, "run", p, "--no-plots", "--out", sandbox.dir / "out")
    line = one_line_error(r, "unknown key 'kkkk", "(1,000,000 characters)", "allowed: algorithm")
    assert len(line) < 1000
    r = cli(capsys, "run", "paper-cornering", "--no-plots", "--out", sandbox.dir, "--set", f"diff.{'x' * 100_000}=1")
    line = one_line_error(r, "(100,000 characters)", "has no parameter", "allowed: J_carrier")
    assert len(line) < 2000


def test_control_characters_from_a_scene_are_escaped_on_the_terminal(sandbox, capsys, fmu_files):
    fake = "\\u001b[2J\\u001b[H\\u0007ALL CHECKS PASSED\\r"
    p = scene(sandbox.dir, f'duration = 0.05\ndescription = "{fake}"\n[[checks]]\nname = "{fake}"\nstat = "mean"\n'
                           f'var = "diff.carrier.tauDrive"\nbelow = -1e9')
    r = cli(capsys, "run", p, "--no-plots", "--out", sandbox.dir / "out")
    assert r.rc == 1, r.err
    assert not any(c in r.out + r.err for c in "\x1b\x07\r"), repr(r.out[-500:])
    assert "FAIL  \\x1b[2J\\x1b[H\\x07ALL CHECKS PASSED\\x0d:" in r.out
    assert "scene hostile: \\x1b[2J" in r.out
    r = cli(capsys, "run", "paper-cornering", "--no-plots", "--out", sandbox.dir, "--set", "\x1b[2Jdiff.x=1")
    one_line_error(r, "\\x1b[2Jdiff")
    assert "\x1b" not in r.err
