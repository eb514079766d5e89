"""Issue 29: rule selection (command line and [tool.spurdiff.check]), preconditions, one crash or hang
one finding, citations, the bounded default experiment, the binary outside Python, and the kit on
FMUs other tools exported (../shared/hosts/third-party-fmus/; skipped, with that reason, where absent).
"""
from __future__ import annotations

import shutil
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "broken_fmus"))
import chk_build  # noqa: E402

from harness.check import CheckResult, LifecycleOptions, run_lifecycle_checks_many  # noqa: E402
from harness.check.rules import BY_ID, ERROR, RULES  # noqa: E402
from harness.check.selection import Selection, SelectionError, find_config, read_config, resolve  # noqa: E402
from harness.cli.check import main  # noqa: E402

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler (gcc) to build ChkC")
HOSTS = Path(__file__).resolve().parents[4] / "shared" / "hosts"
THIRD_PARTY = HOSTS / "third-party-fmus"
needs_third_party = pytest.mark.skipif(not (THIRD_PARTY / "Wheel.fmu").is_file(), reason=f"{THIRD_PARTY} is absent")


# ------------------------------------------------------------------ selection

def test_select_ignore_specificity_and_per_fmu_ignores():
    s = Selection(select=("cs",), ignore=("state",), extend_select=("static.names",),
                  per_fmu_ignores=(("*Stop*.fmu", ("cs.stop-time",)),))
    ids = s.rule_ids("x/ChkC.fmu")
    assert "cs.basic" in ids and "static.names" in ids and "static.archive" not in ids
    assert not {"cs.get-set-state", "cs.free-state", "cs.serialize-state"} & set(ids)
    assert "cs.stop-time" in ids and "cs.stop-time" not in s.rule_ids("x/ChkCStopTime.fmu")
    # a rule id beats a group: selecting one state rule by id brings it back
    assert "cs.free-state" in Selection(select=("cs", "cs.free-state"), ignore=("state",)).rule_ids()
    # equal specificity: ignore wins
    assert "cs.reset" not in Selection(select=("cs.reset",), ignore=("cs.reset",)).rule_ids()
    why = dict(s.deselected("x/ChkCStopTime.fmu"))
    assert why["cs.stop-time"].startswith("per-fmu-ignores '*Stop*.fmu' = 'cs.stop-time'")
    assert why["cs.free-state"].startswith("ignore 'state'")
    # profile rules are not in ALL, and not reported as deselected while their profile is off
    assert "static.units" not in Selection().rule_ids() and "static.units" in Selection().rule_ids(profiles=("spurdiff",))
    assert all(not w.startswith("profile") for _, w in Selection().deselected("a.fmu"))


def test_config_found_upwards_and_command_line_on_top(tmp_path, monkeypatch):
    (tmp_path / "pyproject.toml").write_text('[project]\nname = "x"\n\n[tool.spurdiff.check]\n'
                                             'ignore = ["cs.stop-time"]\nper-fmu-ignores = {"Wheel*" = ["state"]}\n'
                                             'strict = true\n')
    sub = tmp_path / "a" / "b"
    sub.mkdir(parents=True)
    monkeypatch.chdir(sub)
    found = find_config()
    assert found == tmp_path / "pyproject.toml"
    cfg = read_config(found)
    sel = resolve(cfg, str(found), ["cs"], ["cs.reset"], [], [("fail.fmu", ["cs.guid"])])
    ids = sel.rule_ids("Wheel.fmu")
    assert "cs.stop-time" not in ids and "cs.reset" not in ids and "cs.get-set-state" not in ids
    assert "cs.guid" in ids and "cs.guid" not in sel.rule_ids("fail.fmu")
    assert "static.names" not in ids   # --select replaced the default ALL
    assert f"ignore 'cs.stop-time' ({found} and --ignore)" == dict(sel.deselected("x.fmu"))["cs.stop-time"]


@pytest.mark.parametrize("text, words", [
    ('[tool.spurdiff.check]\nignore = ["cs.nope"]\n', "unknown rule or group 'cs.nope'"),
    ('[tool.spurdiff.check]\nselekt = ["cs"]\n', "unknown key 'selekt'"),
    ('[tool.spurdiff.check]\nper-fmu-ignores = {"*" = "cs.reset"}\n', "per-fmu-ignores must be a table"),
    ('[tool.spurdiff.check]\ntimeout = 0\n', "timeout must be a number > 0"),
])
def test_bad_config_is_one_line_naming_the_setting(tmp_path, text, words, capsys):
    cfg = tmp_path / "pyproject.toml"
    cfg.write_text(text)
    with pytest.raises(SelectionError, match=words.replace("(", r"\(").replace("*", r"\*")):
        read_config(cfg)
    assert main(["--config", str(cfg), str(cfg)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and words in err


def test_unknown_selector_on_the_command_line(capsys):
    assert main(["--isolated", "--select", "cs.basic,cs.bogus", "x.fmu"]) == 2
    assert "--select: unknown rule or group 'cs.bogus'" in capsys.readouterr().err


def test_repo_config_is_valid():
    cfg = Path(__file__).resolve().parents[3] / "pyproject.toml"
    table = read_config(cfg)
    assert table, "pyproject.toml has a [tool.spurdiff.check] table"


@needs_gcc
def test_junit_and_summary_say_what_was_deselected(tmp_path, capsys):
    fmu = chk_build.chkc_fmu("ChkCStopTime")
    cfg = tmp_path / "check.toml"
    cfg.write_text('[tool.spurdiff.check]\nselect = ["cs.basic", "cs.stop-time", "static"]\n'
                   'per-fmu-ignores = {"ChkCStopTime.fmu" = ["cs.stop-time"]}\n')
    junit = tmp_path / "out.xml"
    # the stop-time error is deselected for this FMU: exit 0
    assert main([str(fmu), "--config", str(cfg), "--ignore", "static.fmpy-validate", "--junit", str(junit)]) == 0
    out = capsys.readouterr().out
    summary = [ln for ln in out.splitlines() if ln.startswith(str(fmu) + ":")][0]
    assert "deselected: " in summary and "cs.stop-time (per-fmu-ignores 'ChkCStopTime.fmu' = 'cs.stop-time'" in summary
    assert "static.fmpy-validate (ignore 'static.fmpy-validate' (--ignore))" in summary
    root = ET.parse(junit).getroot()
    cases = {c.get("name"): c for c in root.iter("testcase")}
    sk = cases["cs.stop-time"].find("skipped")
    assert sk is not None and sk.get("type") == "deselected" and "per-fmu-ignores" in sk.get("message")
    assert cases["cs.basic"].find("skipped") is None and cases["cs.basic"].find("failure") is None
    des = {n for n, c in cases.items() if c.find("skipped") is not None and c.find("skipped").get("type") == "deselected"}
    ran = {"cs.basic"} | {r.id for r in RULES if r.kind == "static" and not r.profile} - {"static.fmpy-validate"}
    assert des == {r.id for r in RULES if not r.profile and r.fmi == "2.0"} - ran   # a 2.0 FMU: 2.0 rules only
    assert set(cases) == des | ran
    # without the per-FMU ignore the same run fails on cs.stop-time
    assert main([str(fmu), "--isolated", "--select", "cs.basic,cs.stop-time"]) == 1


# ------------------------------------------------------------------ citations

def test_every_error_rule_has_the_standards_sentence_and_the_others_say_so():
    for r in RULES:
        if r.severity == ERROR:
            assert r.quote and len(r.quote) > 30, r.id
        elif r.quote is None and not r.profile:
            assert "no sentence of FMI 2.0" in r.summary or "good practice" in r.summary or "warning" in r.summary, r.id
    assert BY_ID["cs.nan-inputs"].severity == "info" and BY_ID["cs.nan-inputs"].quote is None
    assert BY_ID["static.binary"].severity == "warning"


# ------------------------------------------------------------------ preconditions, one cause one finding

@needs_gcc
def test_no_discard_no_status_check_and_a_hang_reported_once():
    """The issue's Chassis/Wheel case: no step is ever discarded (past the stop time accepted), a doStep
    with NaN inputs never returns. cs.nan-inputs reports the hang (naming the call), once;
    cs.status-after-discard is SKIPped: precondition not met (it used to time out as an error)."""
    path = chk_build.chkc_fmu("ChkCNanHang")
    res = run_lifecycle_checks_many([(path, "hang", ["cs"], {"cs.basic", "cs.status-after-discard"})],
                                    LifecycleOptions(timeout=4.0, jobs=2))["hang"]
    by = {r.check_id: r for r in res}
    assert set(by) == {"cs.basic", "cs.status-after-discard"}   # the providers ran unreported
    st = by["cs.status-after-discard"]
    assert st.status == "SKIP" and st.reason.startswith("precondition not met: no doStep was discarded")
    assert "cs.nan-inputs: INFO (timed out after 4 s in fmi2DoStep(t=0, h=0.01)" in st.reason
    assert "cs.stop-time: ERROR" in st.reason
    res = run_lifecycle_checks_many([(path, "hang", ["cs"], {"cs.nan-inputs"})], LifecycleOptions(timeout=4.0))["hang"]
    assert [(r.check_id, r.label) for r in res] == [("cs.nan-inputs", "INFO")]
    assert res[0].reason.startswith("timed out after 4 s in fmi2DoStep(t=0, h=0.01) [instance nan]")


def test_same_crash_in_several_rules_is_one_finding():
    from harness.check.lifecycle import _dedupe_aborts
    results = {rid: CheckResult("F", rid, "FAIL", f"crashed (SIGSEGV) in fmi2SetFMUstate [instance {rid}]")
               for rid in ("cs.reset", "cs.get-set-state", "cs.two-instances")}
    aborts = {rid: {"kind": "crash", "call": "fmi2SetFMUstate"} for rid in results}
    _dedupe_aborts(results, aborts)
    assert results["cs.get-set-state"].status == "FAIL"   # the rule whose calls name fmi2SetFMUstate
    for rid in ("cs.reset", "cs.two-instances"):
        assert results[rid].status == "SKIP"
        assert results[rid].reason == "precondition not met: fmi2SetFMUstate crashed, reported by cs.get-set-state"


# ------------------------------------------------------------------ run length

@needs_gcc
def test_default_experiment_says_when_it_checked_only_part(tmp_path):
    """A time budget of 1 ns (half of a 2 ns 'timeout'): ChkCLateStep's refusal after 0.5 s (step 50)
    is not reached, and the rule says how much it checked. The budget is checked after each doStep and
    one doStep takes far more than 1 ns, so the run stops after the first; a budget of 1 ms was a race
    (an idle machine did the 50 steps within it: the rule then failed on the refusal)."""
    from harness.check.archive import extract
    from harness.check.processes.isolation import run_isolated_outcome
    d = extract(chk_build.chkc_fmu("ChkCLateStep"))
    try:
        o = run_isolated_outcome("cs.default-experiment", {"unzipdir": str(d), "timeout": 2e-9}, 60.0)
        full = run_isolated_outcome("cs.default-experiment", {"unzipdir": str(d), "timeout": 60.0}, 60.0)
    finally:
        shutil.rmtree(d, ignore_errors=True)
    import re
    m = re.match(r"checked only part of the experiment: (\d+) of 100 doSteps of 0.01 s \(t = 0 to ([0-9.]+) s of 1 s",
                 o.reason)
    assert o.status == "PASS" and m and int(m.group(1)) < 50, o.reason
    assert "stopped at the time budget of 1e-09 s (half the rule's timeout)" in o.reason
    assert full.status == "FAIL"


# ------------------------------------------------------------------ new rules

@needs_gcc
def test_start_value_outside_min_max():
    from harness.check.static import run_static_checks
    res = {r.check_id: r for r in run_static_checks(chk_build.chkc_fmu("ChkCStartRange"))}
    r = res["static.start-range"]
    assert r.is_warning and r.reason == "1 of 1 start values outside min/max: k start = 2 > max = 1.5"
    assert {c for c, x in res.items() if x.failed} == {"static.start-range"}


@needs_gcc
def test_binary_that_uses_libm_without_declaring_it():
    """ChkCNoLibm runs in the kit's Python processes (Python has libm), not in a bare C process."""
    from harness.check.processes.native import run_load_checks
    ids = ["load.needed-libraries", "load.bare-process"]
    bad = {r.check_id: r for r in run_load_checks(chk_build.chkc_fmu("ChkCNoLibm"), "nolibm", ids, 30.0)}
    good = {r.check_id: r for r in run_load_checks(chk_build.chkc_fmu("ChkC"), "good", ids, 30.0)}
    assert all(r.status == "PASS" for r in good.values()), good
    nl = bad["load.needed-libraries"]
    assert nl.is_warning and "exp, fabs from libm.so.6, which it does not declare" in nl.reason
    bp = bad["load.bare-process"]
    assert bp.is_warning and "env -i" in bp.reason and "undefined symbol: " in bp.reason
    calls = run_lifecycle_checks_many([(chk_build.chkc_fmu("ChkCNoLibm"), "py", ["cs"], {"cs.basic"})],
                                      LifecycleOptions(timeout=60.0))["py"]
    assert calls[0].status == "PASS"   # the kit's Python process has libm: only the load rules see it


def test_bare_process_rule_skips_without_a_compiler(monkeypatch, tmp_path):
    from harness.check.processes import native
    native.host_binary.cache_clear()
    monkeypatch.setattr(native.shutil, "which", lambda name: None)
    try:
        status, reason = native.run_bare_host(tmp_path / "x.so", "cs", "{g}", tmp_path, 0.0, 1e-3, 5.0)
    finally:
        native.host_binary.cache_clear()
    assert status == "SKIP" and reason.startswith("no C compiler (cc, gcc or clang) on PATH")


# ------------------------------------------------------------------ FMUs other tools exported

@needs_third_party
def test_wheel_lost_history_is_one_warning_and_no_false_status_error():
    """OSP's Wheel (libcosim test data): its saved state lacks the integrator's history (a warning giving
    the difference, once); it never discards a step and hangs on NaN inputs: cs.status-after-discard is
    not an error any more."""
    wheel = THIRD_PARTY / "Wheel.fmu"
    ids = {"cs.basic", "cs.get-set-state", "cs.free-state", "cs.status-after-discard"}
    res = {r.check_id: r for r in run_lifecycle_checks_many([(wheel, "wheel", ["cs"], ids)],
                                                           LifecycleOptions(timeout=5.0, jobs=2))["wheel"]}
    gs = res["cs.get-set-state"]
    assert gs.is_warning and "the outputs are the saved ones, but the continuation differs by up to" in gs.reason, gs.reason
    assert res["cs.free-state"].status == "PASS", res["cs.free-state"].reason
    st = res["cs.status-after-discard"]
    assert st.status == "SKIP" and st.reason.startswith("precondition not met: no doStep was discarded"), st.reason


@needs_gcc
def test_a_profile_rule_named_by_id_runs_without_its_profile(capsys):
    """--select static.units,cs.parameter-after-init: profile rules chosen by id run (with their own
    severity, info), though the profile is off."""
    fmu = chk_build.chkc_fmu("ChkC")
    assert main(["--isolated", str(fmu), "--select", "static.units,cs.parameter-after-init,cs.basic"]) == 0
    out = capsys.readouterr().out
    ran = [ln.split("  ")[2] for ln in out.splitlines() if ln.startswith(("PASS", "INFO", "SKIP", "ERROR", "WARN"))]
    assert ran == ["static.units", "cs.basic", "cs.parameter-after-init"], out
