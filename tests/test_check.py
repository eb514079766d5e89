"""Tests of the FMU compliance kit (``spurdiff check``, harness/check/).

Small pythonfmu FMUs are built once per session from tests/broken_fmus/: a well-behaved one
(ChkGood) and deliberately broken ones. Their modelDescription.xml is post-processed here (units,
UnitDefinitions, output dependencies, InitialUnknowns) so that the static checks pass and each
broken FMU fails exactly the check it was built to fail.
"""
from __future__ import annotations

import csv
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest

from harness.check import (LIFECYCLE_CHECKS, STATIC_CHECKS, CheckResult, LifecycleOptions, compare_results,
                           is_structured_name, read_cross_check_csv, read_ref_opt, run_lifecycle_checks_many,
                           run_static_checks, write_junit)
from harness.check.reference import write_cross_check_csv
from harness.check.runner import main

SOURCES = Path(__file__).parent / "broken_fmus"

# unit of every Real in the test FMUs, and (SI base-unit exponents) of each unit
UNITS = {"u": "N.m", "k": "1", "x": "N.m.s", "y": "N.m", "phase": "1"}
BASE_UNITS = {"N.m": {"kg": "1", "m": "2", "s": "-2"}, "N.m.s": {"kg": "1", "m": "2", "s": "-1"}, "1": {}}
# outputs with direct feedthrough from the inputs (y = k u); the others (x, a state) depend on none
FEEDTHROUGH = {"y"}

# FMU name -> (pythonfmu build flags, the checks it must fail)
BUILDS = {
    "ChkGood": (["--handle-state", "--serialize-state"], set()),
    "ChkRaiseInStep": (["--handle-state", "--serialize-state"], {"lifecycle.basic"}),
    "ChkResetKeepsState": (["--handle-state", "--serialize-state"], {"lifecycle.reset"}),
    "ChkStateRestoreNoop": (["--handle-state"], {"lifecycle.get-set-state"}),
    "ChkSharedGlobal": (["--handle-state", "--serialize-state"], {"lifecycle.reset", "lifecycle.two-instances"}),
    "ChkCrashInStep": ([], {"lifecycle.basic"}),
}


def build_fmu(name: str, dest: Path, flags: list[str]) -> Path:
    subprocess.run([sys.executable, "-m", "pythonfmu", "build", "-f", str(SOURCES / f"{name}.py"),
                    "--dest", str(dest), *flags], check=True, capture_output=True)
    return dest / f"{name}.fmu"


def rewrite_description(src: Path, dst: Path, edit) -> Path:
    """Copy the FMU ``src`` to ``dst`` with ``edit(root)`` applied to its modelDescription.xml."""
    with zipfile.ZipFile(src) as zin:
        root = ET.fromstring(zin.read("modelDescription.xml"))
        edit(root)
        with zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
            for item in zin.infolist():
                data = zin.read(item.filename)
                if item.filename == "modelDescription.xml":
                    data = ET.tostring(root, encoding="utf-8", xml_declaration=True)
                zout.writestr(item, data)
    return dst


def add_units_and_structure(root: ET.Element, drop_unit: str | None = None) -> None:
    """What pythonfmu leaves out: units with UnitDefinitions, output dependencies, InitialUnknowns."""
    variables = root.findall("ModelVariables/ScalarVariable")
    used = set()
    for sv in variables:
        real = sv.find("Real")
        if real is not None and sv.get("name") != drop_unit:
            real.set("unit", UNITS[sv.get("name")])
            used.add(UNITS[sv.get("name")])
    ud = ET.Element("UnitDefinitions")
    for name in sorted(used):
        ET.SubElement(ET.SubElement(ud, "Unit", name=name), "BaseUnit", BASE_UNITS[name])
    root.insert(list(root).index(root.find("CoSimulation")) + 1, ud)
    inputs = [str(i) for i, sv in enumerate(variables, 1) if sv.get("causality") == "input"]
    structure = root.find("ModelStructure")
    initial = ET.SubElement(structure, "InitialUnknowns")
    for u in structure.findall("Outputs/Unknown"):
        deps = inputs if variables[int(u.get("index")) - 1].get("name") in FEEDTHROUGH else []
        u.set("dependencies", " ".join(deps))
        if deps:
            u.set("dependenciesKind", " ".join("dependent" for _ in deps))
        ET.SubElement(initial, "Unknown", index=u.get("index"))


@pytest.fixture(scope="session")
def fmus(tmp_path_factory) -> dict[str, Path]:
    raw = tmp_path_factory.mktemp("raw_fmus")
    out = tmp_path_factory.mktemp("fmus")
    paths = {}
    for name, (flags, _) in BUILDS.items():
        built = build_fmu(name, raw, flags)
        paths[name] = rewrite_description(built, out / f"{name}.fmu", add_units_and_structure)
    good_raw = raw / "ChkGood.fmu"
    paths["plain"] = good_raw  # as pythonfmu writes it: no units, no dependencies, no InitialUnknowns
    paths["no-unit"] = rewrite_description(good_raw, out / "ChkGoodNoUnit.fmu",
                                           lambda root: add_units_and_structure(root, drop_unit="k"))
    paths["hang"] = build_fmu("ChkHangInStep", raw, [])
    return paths


@pytest.fixture(scope="session")
def lifecycle(fmus) -> dict[str, list[CheckResult]]:
    """Lifecycle results of every FMU in BUILDS, run once, in parallel."""
    return run_lifecycle_checks_many([(fmus[n], n) for n in BUILDS], LifecycleOptions(timeout=60.0))


def failed(results) -> set[str]:
    return {r.check_id for r in results if r.status == "FAIL"}


def by_id(results) -> dict[str, CheckResult]:
    return {r.check_id: r for r in results}


# ------------------------------------------------------------------ static checks

def test_good_fmu_passes_every_static_check(fmus):
    results = run_static_checks(fmus["ChkGood"])
    assert [r.check_id for r in results] == list(STATIC_CHECKS)
    assert all(r.status == "PASS" for r in results), [r for r in results if r.status != "PASS"]


def test_missing_unit_is_flagged_by_the_unit_check_only(fmus):
    results = run_static_checks(fmus["no-unit"])
    assert failed(results) == {"static.units"}
    assert "1 of 5 Real variables have no unit: k" in by_id(results)["static.units"].reason


def test_plain_pythonfmu_fmu_lacks_units_dependencies_and_initial_unknowns(fmus):
    results = by_id(run_static_checks(fmus["plain"]))
    assert failed(results.values()) == {"static.fmpy-validate", "static.units", "static.output-dependencies"}
    assert "InitialUnknowns" in results["static.fmpy-validate"].reason
    assert "5 of 5 Real variables have no unit" in results["static.units"].reason
    assert "x, y" in results["static.output-dependencies"].reason


def _archive_with(tmp_path: Path, variables: str, types: str = "", convention: str = "structured") -> Path:
    xml = f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="M" guid="{{1}}" variableNamingConvention="{convention}">
  <CoSimulation modelIdentifier="M"/>
  <UnitDefinitions><Unit name="m"><BaseUnit m="1"/></Unit><Unit name="1"/></UnitDefinitions>
  <TypeDefinitions>{types}</TypeDefinitions>
  <ModelVariables>{variables}</ModelVariables>
  <ModelStructure/>
</fmiModelDescription>"""
    path = tmp_path / "M.fmu"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("modelDescription.xml", xml)
    return path


def _var(name: str, real_attrs: str = 'unit="m"', description: str = "d") -> str:
    return (f'<ScalarVariable name="{name}" valueReference="0" description="{description}" causality="local" '
            f'variability="continuous" initial="calculated"><Real {real_attrs}/></ScalarVariable>')


def test_unit_rule_accepts_unit_one_and_declared_types_with_units(tmp_path):
    types = ('<SimpleType name="Length"><Real unit="m"/></SimpleType>'
             '<SimpleType name="Bare"><Real/></SimpleType>')
    ok = by_id(run_static_checks(_archive_with(tmp_path, _var("a", 'unit="1"') + _var("b", 'declaredType="Length"'), types)))
    assert ok["static.units"].status == "PASS"
    bad = by_id(run_static_checks(_archive_with(tmp_path, _var("a", 'declaredType="Bare"') + _var("b", 'unit=""'), types)))
    assert bad["static.units"].status == "FAIL"
    assert "a (declaredType Bare has no unit), b" in bad["static.units"].reason


def test_archive_without_binary_fails_binary_check_and_lifecycle_is_skipped(tmp_path, capsys):
    path = _archive_with(tmp_path, _var("a"))
    assert main([str(path)]) == 1
    out = capsys.readouterr().out
    assert "FAIL  " + str(path) + " static.binary  no binaries/" in out
    skipped = [ln for ln in out.splitlines() if ln.startswith("SKIP  ") and " lifecycle." in ln]
    assert len(skipped) == len(LIFECYCLE_CHECKS)
    assert all(ln.endswith("static.binary failed") for ln in skipped)


def test_descriptions_and_names(tmp_path):
    results = by_id(run_static_checks(_archive_with(tmp_path, _var("a.b[1]") + _var("1x", description=" "))))
    assert results["static.descriptions"].status == "FAIL" and "1x" in results["static.descriptions"].reason
    assert results["static.names"].status == "FAIL" and "'1x' is not a legal structured name" in results["static.names"].reason


@pytest.mark.parametrize("name, legal", [
    ("x", True), ("tyre.B", True), ("halfShaft.c", True), ("a[1,2].b[3]", True), ("der(x)", True),
    ("der(a.b,2)", True), ("'quoted name!'", True), ("_x1", True),
    ("1x", False), ("a..b", False), ("a[]", False), ("a b", False), ("der(x", False), ("a.", False), ("", False),
])
def test_structured_name_grammar(name, legal):
    assert is_structured_name(name) is legal


def test_not_a_zip_fails_first_check_and_skips_the_rest(tmp_path):
    path = tmp_path / "junk.fmu"
    path.write_text("not a zip")
    results = run_static_checks(path)
    assert results[0].status == "FAIL" and "not a readable zip" in results[0].reason
    assert all(r.status == "SKIP" for r in results[1:])


# ------------------------------------------------------------------ lifecycle checks

def test_good_fmu_passes_every_lifecycle_check(lifecycle):
    results = lifecycle["ChkGood"]
    assert [r.check_id for r in results] == list(LIFECYCLE_CHECKS)
    assert all(r.status == "PASS" for r in results), [r for r in results if r.status != "PASS"]


@pytest.mark.parametrize("name", [n for n in BUILDS if n != "ChkGood"])
def test_broken_fmu_fails_exactly_its_check(fmus, lifecycle, name):
    expected = BUILDS[name][1]
    static = run_static_checks(fmus[name])
    assert failed(static) == set()
    assert failed(lifecycle[name]) == expected


def test_raising_do_step_is_reported_as_fatal_and_other_checks_skip(lifecycle):
    results = by_id(lifecycle["ChkRaiseInStep"])
    assert "fmi2DoStep(t=0, h=0.01)" in results["lifecycle.basic"].reason
    assert "fmi2Fatal" in results["lifecycle.basic"].reason
    assert "ZeroDivisionError" in results["lifecycle.basic"].reason  # the FMU's own log message
    assert all(r.status == "SKIP" for c, r in results.items() if c != "lifecycle.basic")


def test_segfault_is_a_fail_naming_the_call_not_a_checker_crash(lifecycle):
    reason = by_id(lifecycle["ChkCrashInStep"])["lifecycle.basic"].reason
    assert reason.startswith("crashed (SIGSEGV) in fmi2DoStep(t=0.02, h=0.01)")


def test_reset_and_restore_failures_say_where(lifecycle):
    reset = by_id(lifecycle["ChkResetKeepsState"])["lifecycle.reset"].reason
    assert "after fmi2Reset" in reset and "x after initialization: 0.2" in reset
    restore = by_id(lifecycle["ChkStateRestoreNoop"])
    assert "x right after the state call: 0.2 vs 0.1" in restore["lifecycle.get-set-state"].reason
    assert restore["lifecycle.serialize-state"].status == "SKIP"


def test_shared_state_between_instances_is_caught(lifecycle):
    reason = by_id(lifecycle["ChkSharedGlobal"])["lifecycle.two-instances"].reason
    assert reason.startswith("the first instance (start values) changed when a second one ran beside it: x ")
    assert "the second instance (inputs u changed) differs from running alone" in reason


def test_hanging_fmu_times_out(fmus):
    options = LifecycleOptions(timeout=3.0)
    [result] = run_lifecycle_checks_many([(fmus["hang"], "hang")], options, checks=["lifecycle.basic"])["hang"]
    assert result.status == "FAIL"
    assert result.reason.startswith("timed out after 3 s in fmi2DoStep(t=0, h=0.01)")


# ------------------------------------------------------------------ report, JUnit, exit codes

def test_junit_file_is_well_formed_with_the_right_counts(fmus, lifecycle, tmp_path):
    results = (run_static_checks(fmus["ChkGood"], "good") + lifecycle["ChkGood"]
               + run_static_checks(fmus["ChkRaiseInStep"], "ChkRaiseInStep") + lifecycle["ChkRaiseInStep"])
    results = [r if r.subject != "ChkGood" else CheckResult("good", r.check_id, r.status, r.reason) for r in results]
    path = write_junit(tmp_path / "out" / "check.xml", results)
    root = ET.parse(path).getroot()
    assert root.tag == "testsuites"
    n = len(STATIC_CHECKS) + len(LIFECYCLE_CHECKS)
    assert root.get("tests") == str(2 * n) and root.get("failures") == "1"
    assert root.get("skipped") == str(len(LIFECYCLE_CHECKS) - 1)
    suites = {s.get("name"): s for s in root.findall("testsuite")}
    assert set(suites) == {"good", "ChkRaiseInStep"}
    assert suites["good"].get("failures") == "0" and len(suites["good"].findall("testcase")) == n
    bad = suites["ChkRaiseInStep"]
    [failure_case] = [c for c in bad.findall("testcase") if c.find("failure") is not None]
    assert failure_case.get("name") == "lifecycle.basic"
    assert "fmi2Fatal" in failure_case.find("failure").get("message")
    assert len([c for c in bad.findall("testcase") if c.find("skipped") is not None]) == len(LIFECYCLE_CHECKS) - 1


def test_cli_full_run_on_good_fmu_exits_0_and_prints_one_line_per_check(fmus, tmp_path, capsys):
    junit = tmp_path / "good.xml"
    assert main([str(fmus["ChkGood"]), "--junit", str(junit)]) == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith(("PASS", "FAIL", "SKIP"))]
    assert len(lines) == len(STATIC_CHECKS) + len(LIFECYCLE_CHECKS)
    assert all(ln.startswith(f"PASS  {fmus['ChkGood']} ") for ln in lines)
    assert ET.parse(junit).getroot().get("tests") == str(len(lines))


def test_cli_exit_codes(fmus, tmp_path, capsys):
    assert main([str(fmus["no-unit"]), "--static-only"]) == 1
    assert main([str(fmus["ChkGood"]), "--static-only"]) == 0
    assert main([str(tmp_path / "missing.fmu")]) == 2
    assert main([]) == 2
    assert main(["--no-such-option", str(fmus["ChkGood"])]) == 2
    assert main(["--compare", str(tmp_path / "r.csv")]) == 2
    assert main([str(fmus["ChkGood"]), str(fmus["ChkRaiseInStep"]), "--reference-results", str(tmp_path),
                 "--input", str(fmus["ChkGood"])]) == 2
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
    assert f"PASS  {finer} compare.x  " in out and f"PASS  {finer} compare.y  " in out


def test_compare_detects_a_perturbed_column(reference_dir, tmp_path, capsys):
    ref = reference_dir / "ChkGood_ref.csv"
    names, rows = read_cross_check_csv(ref)
    rows[5][1] *= 1.01  # x off by 1 % at one sample (x = 0.1 there: error 1e-3, allowed 2e-4 + 1e-4)
    bad = write_cross_check_csv(tmp_path / "bad.csv", names, rows)
    result = {c.name: c for c in compare_results(bad, ref)}
    assert not result["x"].passed and result["x"].samples_outside == 1
    assert result["y"].passed
    assert main(["--compare", str(bad), "--reference", str(ref), "--junit", str(tmp_path / "cmp.xml")]) == 1
    out = capsys.readouterr().out
    assert f"FAIL  {bad} compare.x  1 of 11 samples outside" in out and "t = 0.05 s" in out
    assert ET.parse(tmp_path / "cmp.xml").getroot().get("failures") == "1"
    # a wider tolerance for that column accepts it; a missing column fails
    assert main(["--compare", str(bad), "--reference", str(ref), "--tolerance", "x=0.02"]) == 0
    no_y = write_cross_check_csv(tmp_path / "no_y.csv", ["time", "x"], [[r[0], r[1]] for r in rows])
    assert {c.name: c.passed for c in compare_results(no_y, ref)} == {"x": False, "y": False}
