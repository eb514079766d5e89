"""Tests of the FMU compliance kit (``spurdiff check``, harness/check/): the rules as data, the static
rules, hostile archives and names (issue 14), the report (severities, exit code, JUnit), the command
line, reference results and comparison. The call-sequence rules on broken FMUs are in
test_check_fmus.py; the Reference FMUs and the FMU Compliance Checker in test_check_reference_fmus.py.

Test FMUs are built once and cached under build/test-fmus/ (tests/broken_fmus/chk_build.py).
"""
from __future__ import annotations

import csv
import sys
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "broken_fmus"))
import chk_build  # noqa: E402
from chk_build import add_units_and_structure, rewrite_description  # noqa: E402

from harness.check import (CheckResult, compare_results, is_structured_name,  # noqa: E402
                           lifecycle_rules, read_cross_check_csv, read_ref_opt, run_static_checks,
                           safe_model_name, write_junit)
from harness.check.rules import rules  # noqa: E402
from harness.check.archive import ArchiveError, extract, member_name_problem  # noqa: E402
from harness.check.crosscheck.formats import write_cross_check_csv  # noqa: E402
from harness.check.crosscheck.reference import ReferenceUsageError  # noqa: E402
from harness.check.report import exit_code, format_report  # noqa: E402
from harness.cli.check import main as _main  # noqa: E402


def main(argv):
    """The command without the repository's [tool.spurdiff.check] (these tests set what they need)."""
    return _main(["--isolated", *argv])

STATIC = [r.id for r in rules("static")]
STATIC_SPURDIFF = [r.id for r in rules("static", ("spurdiff",))]
CS = lifecycle_rules(["cs"])


@pytest.fixture(scope="session")
def fmus(tmp_path_factory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("fmus")
    good = chk_build.pythonfmu_fmu("ChkGood", ["--handle-state", "--serialize-state"])
    plain = chk_build.pythonfmu_fmu("ChkGood", ["--handle-state", "--serialize-state"], complete=False)
    paths = {"ChkGood": good, "plain": plain,
             "ChkRaiseInStep": chk_build.pythonfmu_fmu("ChkRaiseInStep", ["--handle-state", "--serialize-state"])}
    paths["no-unit"] = rewrite_description(plain, out / "ChkGoodNoUnit.fmu",
                                           lambda root: add_units_and_structure(root, drop_unit="k"))
    return paths


def failed(results) -> set[str]:
    return {r.check_id for r in results if r.status == "FAIL"}


def by_id(results) -> dict[str, CheckResult]:
    return {r.check_id: r for r in results}


# ------------------------------------------------------------------ rules as data

def test_every_rule_cites_a_section_and_has_a_severity():
    from harness.check.rules import RULES, SEVERITIES
    for r in RULES:
        assert r.section and all(part.strip()[0].isdigit() for part in r.section.split(",")), r
        assert r.severity in SEVERITIES and r.calls and r.summary, r
        assert r.profile is None or r.severity == "info", "profile rules are conventions, not the standard's"
    assert len({r.id for r in RULES}) == len(RULES)


def test_the_docs_rule_table_is_the_rules_data():
    from harness.check.rules import rule_table_markdown
    doc = (Path(__file__).resolve().parents[3] / "docs" / "compliance.md").read_text(encoding="utf-8")
    assert rule_table_markdown() in doc


# ------------------------------------------------------------------ static checks

def test_good_fmu_passes_every_static_check_also_with_the_profile(fmus):
    results = run_static_checks(fmus["ChkGood"], profiles=("spurdiff",))
    assert [r.check_id for r in results] == STATIC_SPURDIFF
    assert all(r.status in ("PASS", "SKIP") for r in results), [r for r in results if r.failed]


def test_missing_unit_is_an_error_only_in_the_profile(fmus):
    plain = run_static_checks(fmus["no-unit"])
    assert failed(plain) == set() and "static.units" not in by_id(plain)
    strict = by_id(run_static_checks(fmus["no-unit"], profiles=("spurdiff",)))
    assert failed(strict.values()) == {"static.units"}
    assert strict["static.units"].severity == "error"
    assert "1 of 5 Real variables have no unit: k" in strict["static.units"].reason


def test_plain_pythonfmu_fmu(fmus):
    results = by_id(run_static_checks(fmus["plain"], profiles=("spurdiff",)))
    assert failed(results.values()) == {"static.fmpy-validate", "static.units", "static.output-dependencies",
                                        "static.all-output-dependencies"}
    assert "InitialUnknowns" in results["static.fmpy-validate"].reason
    assert results["static.output-dependencies"].severity == "info"  # a hint outside the profile...
    assert exit_code(results.values()) == 1  # ...but fmpy's validation is an error


def _archive_with(tmp_path: Path, variables: str, types: str = "", convention: str = "structured",
                  extra: dict[str, bytes] | None = None, name: str = "M.fmu", model_name: str = "M") -> Path:
    xml = f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="{model_name}" guid="{{1}}" variableNamingConvention="{convention}">
  <CoSimulation modelIdentifier="M"/>
  <UnitDefinitions><Unit name="m"><BaseUnit m="1"/></Unit><Unit name="1"/></UnitDefinitions>
  <TypeDefinitions>{types}</TypeDefinitions>
  <ModelVariables>{variables}</ModelVariables>
  <ModelStructure/>
</fmiModelDescription>"""
    path = tmp_path / name
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("modelDescription.xml", xml)
        for member, data in (extra or {}).items():
            z.writestr(member, data)
    return path


def _var(name: str, real_attrs: str = 'unit="m"', description: str = "d") -> str:
    return (f'<ScalarVariable name="{name}" valueReference="0" description="{description}" causality="local" '
            f'variability="continuous" initial="calculated"><Real {real_attrs}/></ScalarVariable>')


def test_unit_rule_accepts_unit_one_and_declared_types_with_units(tmp_path):
    types = ('<SimpleType name="Length"><Real unit="m"/></SimpleType>'
             '<SimpleType name="Bare"><Real/></SimpleType>')
    ok = by_id(run_static_checks(_archive_with(tmp_path, _var("a", 'unit="1"') + _var("b", 'declaredType="Length"'), types),
                                 profiles=("spurdiff",)))
    assert ok["static.units"].status == "PASS"
    bad = by_id(run_static_checks(_archive_with(tmp_path, _var("a", 'declaredType="Bare"') + _var("b", 'unit=""'), types),
                                  profiles=("spurdiff",)))
    assert bad["static.units"].status == "FAIL"
    assert "a (declaredType Bare has no unit), b" in bad["static.units"].reason


def test_archive_without_binary_is_a_warning_and_call_rules_are_skipped(tmp_path, capsys):
    """FMI 2.0 lets an FMU ship other platforms' binaries or sources only: no sentence makes a missing
    binary for this platform an error (issue 29), but nothing can run here."""
    path = _archive_with(tmp_path, _var("a"))
    rc = main([str(path)])
    out = capsys.readouterr().out
    assert rc == (1 if "\nERROR " in "\n" + out else 0)
    assert f"WARN   {path}  static.binary  [FMI 2.0 2.3] no binaries/" in out
    skipped = [ln for ln in out.splitlines() if ln.startswith("SKIP ") and "  cs." in ln]
    assert len(skipped) == len(CS)
    assert all(ln.endswith("static.binary did not pass") for ln in skipped)


def test_descriptions_and_names(tmp_path):
    results = by_id(run_static_checks(_archive_with(tmp_path, _var("a.b[1]") + _var("1x", description=" ")),
                                      profiles=("spurdiff",)))
    assert results["static.descriptions"].status == "FAIL" and "1x" in results["static.descriptions"].reason
    assert results["static.names"].status == "FAIL" and "'1x' is not a legal structured name" in results["static.names"].reason
    assert results["static.names"].severity == "error"


@pytest.mark.parametrize("name, legal", [
    ("x", True), ("tyre.B", True), ("halfShaft.c", True), ("a[1,2].b[3]", True), ("der(x)", True),
    ("der(a.b,2)", True), ("'quoted name!'", True), ("_x1", True),
    ("1x", False), ("a..b", False), ("a[]", False), ("a b", False), ("der(x", False), ("a.", False), ("", False),
])
def test_structured_name_grammar(name, legal):
    assert is_structured_name(name) is legal


def test_not_a_zip_fails_the_archive_rule_and_skips_the_rest(tmp_path):
    path = tmp_path / "junk.fmu"
    path.write_text("not a zip")
    results = run_static_checks(path)
    assert results[0].check_id == "static.archive" and results[0].status == "FAIL"
    assert "not a readable zip" in results[0].reason
    assert all(r.status == "SKIP" for r in results[1:])


def test_model_exchange_static_rule(tmp_path):
    xml_vars = (_var("x") .replace('causality="local" variability="continuous" initial="calculated"',
                                   'causality="output" variability="continuous" initial="exact"').replace('<Real unit="m"/>', '<Real unit="m" start="0"/>')
                + _var("der(x)", 'unit="m" derivative="1"'))
    path = _archive_with(tmp_path, xml_vars)
    with zipfile.ZipFile(path) as z:
        xml = z.read("modelDescription.xml").decode()
    good = xml.replace('<CoSimulation modelIdentifier="M"/>', '<ModelExchange modelIdentifier="M"/>').replace(
        "<ModelStructure/>", '<ModelStructure><Outputs><Unknown index="1"/></Outputs><Derivatives><Unknown index="2"/></Derivatives></ModelStructure>')
    bad = good.replace('<Derivatives><Unknown index="2"/>', '<Derivatives><Unknown index="1"/>')
    for text, status in ((good, "PASS"), (bad, "FAIL")):
        p = tmp_path / f"me_{status}.fmu"
        with zipfile.ZipFile(p, "w") as z:
            z.writestr("modelDescription.xml", text)
        r = by_id(run_static_checks(p))["static.model-exchange"]
        assert r.status == status, r.reason
    assert "Derivatives lists x, which has no derivative attribute" in r.reason


# ------------------------------------------------------------------ hostile archives (issue 14: 4, 15)

@pytest.mark.parametrize("member, words", [
    ("resources\\evil.txt", "contains '\\'"), ("C:/evil.txt", "contains ':'"), ("../evil.txt", "'..'"),
    ("/etc/evil", "is absolute"), ("res/a\x07b", "control characters"),
])
def test_unsafe_member_names_fail_that_fmu_only(tmp_path, member, words, capsys):
    bad = _archive_with(tmp_path, _var("a"), extra={member: b"x"}, name="Bad.fmu")
    good = _archive_with(tmp_path, _var("a"), name="Fine.fmu")
    junit = tmp_path / "check.xml"
    assert main([str(bad), str(good), "--static-only", "--junit", str(junit)]) == 1
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if "static.archive" in ln and "Bad.fmu" in ln)
    assert line.startswith("ERROR") and words in line
    assert f"PASS   {good}  static.archive" in out  # the batch goes on
    root = ET.parse(junit).getroot()  # and its JUnit file is written and parses
    assert {s.get("name") for s in root.findall("testsuite")} == {str(bad), str(good)}
    assert member_name_problem(member) is not None


def test_zip_bomb_and_member_count_and_large_description_are_refused(tmp_path):
    bomb = _archive_with(tmp_path, _var("a"), extra={"resources/zeros.bin": b"\0" * (8 * 1024 ** 2)}, name="Bomb.fmu")
    assert bomb.stat().st_size < 100_000
    with pytest.raises(ArchiveError, match="more than 4194304 bytes unpacked"):
        extract(bomb, tmp_path / "out", max_bytes=4 * 1024 ** 2)
    assert not any((tmp_path / "out").rglob("zeros.bin")) or (tmp_path / "out" / "resources" / "zeros.bin").stat().st_size <= 4 * 1024 ** 2
    many = _archive_with(tmp_path, _var("a"), extra={f"resources/f{i}": b"" for i in range(30)}, name="Many.fmu")
    with pytest.raises(ArchiveError, match="31 members, more than the limit of 20"):
        extract(many, max_members=20)
    from harness.check.archive import read_model_description_bytes
    with pytest.raises(ArchiveError, match="modelDescription.xml: more than 100 bytes"):
        read_model_description_bytes(bomb, max_bytes=100)


def test_control_characters_in_reasons_keep_junit_parseable(tmp_path):
    evil = "FMU says \x00\x01\x1b[31m red \x7f\ud800 end"
    results = [CheckResult("a\x02.fmu", "cs.basic", "FAIL", evil), CheckResult("a\x02.fmu", "cs.reset", "PASS", evil)]
    path = write_junit(tmp_path / "j.xml", results)
    root = ET.parse(path).getroot()
    failure = root.find("testsuite/testcase/failure")
    assert "\\x00" in failure.get("message") and "\\x1b" in failure.text
    assert "\x00" not in format_report(results)


def test_model_name_cannot_write_outside_the_folder(tmp_path, fmus):
    for name in ("../escape", "a/b", "..", ".hidden", "", "x" * 200, "a\\b", "C:x", "a..b", " lead"):
        with pytest.raises(ReferenceUsageError, match="cannot be used as a file name"):
            safe_model_name(name)
    assert safe_model_name("ChkGood") == "ChkGood"
    assert safe_model_name("Van der Pol oscillator") == "Van der Pol oscillator"
    hostile = rewrite_description(fmus["ChkGood"], tmp_path / "Hostile.fmu",
                                  lambda root: root.set("modelName", "../../escaped"))
    out = tmp_path / "refs"
    assert main(["--reference-results", str(out), str(hostile)]) == 1
    assert not (tmp_path / "escaped").exists() and not any(tmp_path.parent.glob("escaped*"))


# ------------------------------------------------------------------ report, JUnit, exit codes

def _mixed() -> list[CheckResult]:
    return [CheckResult("f.fmu", "cs.basic", "PASS", "ok"),
            CheckResult("f.fmu", "cs.guid", "FAIL", "accepted", severity="error"),
            CheckResult("f.fmu", "cs.zero-step-size", "FAIL", "accepted", severity="warning"),
            CheckResult("f.fmu", "static.output-dependencies", "FAIL", "none", severity="info"),
            CheckResult("f.fmu", "cs.nan-inputs", "SKIP", "no inputs")]


def test_exit_code_counts_errors_and_with_strict_warnings():
    results = _mixed()
    assert exit_code(results) == 1 and exit_code(results[2:]) == 0 and exit_code(results[2:], strict=True) == 1
    assert exit_code(results[3:], strict=True) == 0  # info never fails
    text = format_report(results)
    assert text.splitlines()[-1] == "5 checks: 1 passed, 1 errors, 1 warnings, 1 info, 1 skipped"
    assert "ERROR  f.fmu  cs.guid  [FMI 2.0 2.1.5] accepted" in text
    assert "WARN   f.fmu  cs.zero-step-size  [FMI 2.0 4.2.2] accepted" in text


@pytest.mark.parametrize("strict", [False, True])
def test_junit_errors_are_failures_warnings_skipped_with_reason(tmp_path, strict):
    root = ET.parse(write_junit(tmp_path / "j.xml", _mixed(), strict)).getroot()
    cases = {c.get("name"): c for c in root.iter("testcase")}
    assert cases["cs.guid"].find("failure").get("message") == "error [FMI 2.0 2.1.5]: accepted"
    warn = cases["cs.zero-step-size"]
    if strict:
        assert warn.find("failure") is not None and root.get("failures") == "2"
    else:
        assert warn.find("skipped").get("message") == "warning [FMI 2.0 4.2.2]: accepted"
        assert root.get("failures") == "1" and root.get("skipped") == "2"
    info = cases["static.output-dependencies"]
    assert info.find("failure") is None and info.find("skipped") is None
    props = {p.get("name"): p.get("value") for p in info.find("properties")}
    assert props["severity"] == "info" and props["note"].startswith("info [FMI 2.0 2.2.8]")


def test_cli_usage_errors(fmus, tmp_path, capsys):
    assert main([str(fmus["ChkGood"]), "--static-only"]) == 0
    assert main([str(fmus["no-unit"]), "--static-only"]) == 0
    assert main([str(fmus["no-unit"]), "--static-only", "--profile", "spurdiff"]) == 1
    assert main([str(tmp_path / "missing.fmu")]) == 2
    assert main([]) == 2
    assert main(["--no-such-option", str(fmus["ChkGood"])]) == 2
    assert main(["--profile", "nope", str(fmus["ChkGood"])]) == 2
    assert main(["--compare", str(tmp_path / "r.csv")]) == 2
    err = capsys.readouterr().err
    assert "FMU not found: " + str(tmp_path / "missing.fmu") in err


# ------------------------------------------------------------------ reference results and comparison

def _header(path: Path) -> list[str]:
    with path.open(newline="") as f:
        return next(csv.reader(f))


@pytest.fixture(scope="session")
def reference_dir(fmus, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("refs")
    assert main(["--reference-results", str(out), str(fmus["ChkGood"])]) == 0
    return out / "ChkGood"


def test_reference_results_write_the_three_cross_check_files(reference_dir):
    ref, opt, inp = (reference_dir / f"ChkGood_{s}" for s in ("ref.csv", "ref.opt", "in.csv"))
    assert ref.read_text().splitlines()[0] == '"time","x","y"'
    assert _header(inp) == ["time", "u"]
    opts = read_ref_opt(opt)
    assert (opts["StartTime"], opts["StopTime"], opts["StepSize"]) == (0.0, 0.1, 0.01)
    assert opts["RelTol"] > 0
    names, rows = read_cross_check_csv(ref)
    assert rows[0][0] == 0.0 and rows[-1][0] == pytest.approx(0.1)
    assert len(rows) == 11
    # x' = k u with k = 2, u = 1 (start values): x(0.1) = 0.2, y = 2
    assert rows[-1][1] == pytest.approx(0.2, rel=1e-12) and rows[-1][2] == 2.0
    _, in_rows = read_cross_check_csv(inp)
    assert in_rows == [[0.0, 1.0], [0.1, 1.0]]


def test_reference_results_follow_an_input_table(fmus, tmp_path):
    table = write_cross_check_csv(tmp_path / "u.csv", ["time", "u"], [[0.0, 3.0], [0.1, 3.0]])
    assert main(["--reference-results", str(tmp_path / "refs"), "--input", str(table), str(fmus["ChkGood"])]) == 0
    _, rows = read_cross_check_csv(tmp_path / "refs" / "ChkGood" / "ChkGood_ref.csv")
    assert rows[-1][1] == pytest.approx(0.6, rel=1e-12) and rows[-1][2] == 6.0
    bad = write_cross_check_csv(tmp_path / "bad.csv", ["time", "k"], [[0.0, 3.0]])
    assert main(["--reference-results", str(tmp_path / "refs"), "--input", str(bad), str(fmus["ChkGood"])]) == 2


def test_compare_passes_identical_and_finer_sampled_results(reference_dir, tmp_path, capsys):
    ref = reference_dir / "ChkGood_ref.csv"
    assert main(["--compare", str(ref), "--reference", str(ref)]) == 0
    # an importer sampling twice as often: x = 2 t exactly, interpolated back onto the reference grid
    finer = write_cross_check_csv(tmp_path / "finer.csv", ["time", "y", "x"],
                                  [[i * 0.005, 2.0, 2.0 * i * 0.005] for i in range(21)])
    assert all(c.passed for c in compare_results(finer, ref))
    assert main(["--compare", str(finer), "--reference", str(ref)]) == 0
    out = capsys.readouterr().out
    assert f"PASS   {finer}  compare.x  " in out and f"PASS   {finer}  compare.y  " in out


def test_compare_detects_a_perturbed_column(reference_dir, tmp_path, capsys):
    ref = reference_dir / "ChkGood_ref.csv"
    names, rows = read_cross_check_csv(ref)
    rows[5][1] *= 1.01  # x off by 1 % at one sample (x = 0.1 there: error 1e-3, allowed 2e-4 + 1e-4)
    bad = write_cross_check_csv(tmp_path / "bad.csv", names, rows)
    result = {c.name: c for c in compare_results(bad, ref)}
    assert not result["x"].passed and result["x"].samples_outside == 1
    assert result["y"].passed
    assert main(["--compare", str(bad), "--reference", str(ref), "--rule", "tube", "--junit", str(tmp_path / "cmp.xml")]) == 1
    out = capsys.readouterr().out
    assert f"ERROR  {bad}  compare.x  1 of 11 samples outside" in out and "t = 0.05 s" in out
    assert ET.parse(tmp_path / "cmp.xml").getroot().get("failures") == "1"
    # a wider tolerance for that column accepts it; a missing column fails
    assert main(["--compare", str(bad), "--reference", str(ref), "--tolerance", "x=0.02"]) == 0
    no_y = write_cross_check_csv(tmp_path / "no_y.csv", ["time", "x"], [[r[0], r[1]] for r in rows])
    assert {c.name: c.passed for c in compare_results(no_y, ref)} == {"x": False, "y": False}
