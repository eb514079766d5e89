"""Issue 28 item 4: the compliance kit on FMI 3.0 FMUs. The FMI 3.0 Reference FMUs pass (0 errors), and every
FMI 3.0 rule catches a broken FMU of its own, made from a Reference FMU (tests/broken_fmus/chk3_build.py):
an edited modelDescription.xml for the static rules, a shim around the binary (chk3_shim.c) for the call
sequences. The FMUs are built once per module; skipped, with the reason, without the Reference FMUs or gcc.
"""
from __future__ import annotations

import shutil
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "broken_fmus"))
import chk3_build  # noqa: E402

from harness.check import LifecycleOptions, run_lifecycle_checks_many, run_static_checks  # noqa: E402
from harness.check.rules import BY_ID, rules  # noqa: E402
from harness.cli.check import main  # noqa: E402

pytestmark = pytest.mark.skipif(not chk3_build.reference("BouncingBall").is_file(),
                                reason=f"{chk3_build.REF3} is absent")
needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler (gcc) to build the FMI 3.0 shims")
REFERENCE = ["BouncingBall", "Clocks", "Dahlquist", "Feedthrough", "Resource", "Stair", "StateSpace", "VanDerPol"]

# broken FMU -> (base, modelDescription edits, the static rule it breaks, its severity)
STATIC = {
    "Chk3FmiVersion": ("BouncingBall", [('fmiVersion="3.0"', 'fmiVersion="3"')], "static3.fmi3", "error"),
    "Chk3Schema": ("BouncingBall", [('<Float64 name="g" ', '<Float64 name="g" gravity="yes" ')], "static3.schema",
                   "error"),
    "Chk3Variables": ("Feedthrough", [('<Int32 name="Int32_input" valueReference="19" causality="input"',
                                       '<Int32 name="Int32_input" valueReference="19" causality="input" '
                                       'variability="continuous"')], "static3.variables", "error"),
    "Chk3Causality": ("BouncingBall", [('causality="parameter" variability="fixed"',
                                        'causality="parameter" variability="continuous"')],
                      "static3.causality-variability", "error"),
    "Chk3Initial": ("BouncingBall", [('<Float64 name="der(h)" valueReference="2"',
                                      '<Float64 name="der(h)" valueReference="2" start="0"')], "static3.initial",
                    "error"),
    "Chk3Units": ("BouncingBall", [('quantity="Velocity" unit="m/s"', 'quantity="Velocity" unit="km/h"')],
                  "static3.units", "error"),
    "Chk3Outputs": ("BouncingBall", [('<Output valueReference="3" dependencies=""/>', '')], "static3.outputs",
                    "error"),
    "Chk3InitialUnknowns": ("BouncingBall", [('<InitialUnknown valueReference="4" dependencies="5" '
                                              'dependenciesKind="constant"/>', '')], "static3.initial-unknowns",
                            "error"),
    "Chk3Dimensions": ("StateSpace", [('<UInt64 name="r" valueReference="3" description="Number of outputs" '
                                       'causality="structuralParameter" variability="tunable" start="3"',
                                       '<UInt64 name="r" valueReference="3" description="Number of outputs" '
                                       'causality="structuralParameter" variability="tunable" start="0"')],
                       "static3.dimensions", "error"),
    "Chk3StartRange": ("BouncingBall", [('start="0.7" min="0.5"', 'start="0.2" min="0.5"')], "static3.start-range",
                       "warning"),
    "Chk3Binary": ("BouncingBall", [], "static3.binary", "warning"),
    "Chk3Archive": ("BouncingBall", [], "static3.archive", "error"),
}
# broken FMU -> (BREAK_x of chk3_shim.c, {rule: severity of the expected failure})
SHIM = {
    "Chk3CBasic": ("BASIC", {"cs3.basic": "error"}),
    "Chk3CVersion": ("VERSION", {"cs3.version": "error"}),
    "Chk3CToken": ("TOKEN", {"cs3.instantiation-token": "warning", "me3.instantiation-token": "warning"}),
    "Chk3CInitGet": ("INIT_GET", {"cs3.initial-unknowns": "error"}),
    "Chk3CStopTime": ("STOP_TIME", {"cs3.stop-time": "error"}),
    "Chk3CTerminatedGet": ("TERMINATED_GET", {"cs3.get-after-terminate": "error"}),
    "Chk3CReset": ("RESET", {"cs3.reset": "error"}),
    "Chk3CStateNoop": ("STATE_NOOP", {"cs3.get-set-state": "error"}),
    "Chk3CEarlyStep": ("EARLY_STEP", {"cs3.step-before-init": "warning"}),
    "Chk3CZeroStep": ("ZERO_STEP", {"cs3.zero-step-size": "error"}),
    "Chk3CLateStep": ("LATE_STEP", {"cs3.default-experiment": "warning"}),
    "Chk3CModelExchange": ("ME", {"me3.basic": "error"}),
    "Chk3CDerivOrder": ("DERIV_ORDER", {"cs3.output-derivative-orders": "error"}),
    "Chk3CDerivNaN": ("DERIV_NAN", {"cs3.output-derivatives": "warning"}),
    "Chk3CEarlyAnyway": ("EARLY_ANYWAY", {"cs3.early-return-not-allowed": "error"}),
    "Chk3CEarlyTime": ("EARLY_TIME", {"cs3.early-return-time": "error"}),
}
# shims whose modelDescription.xml is edited too: BouncingBall declares output derivatives
SHIM_EDITS = {n: [('mightReturnEarlyFromDoStep="true"', 'mightReturnEarlyFromDoStep="true"\n    '
                   'maxOutputDerivativeOrder="1"')] for n in ("Chk3CDerivOrder", "Chk3CDerivNaN")}


@pytest.fixture(scope="module")
def static_fmus(tmp_path_factory):
    out = tmp_path_factory.mktemp("fmi3-static")
    made = {}
    for name, (base, edits, _, _) in STATIC.items():
        drop = ("binaries/",) if name == "Chk3Binary" else ()
        add = {"../outside.txt": b"x"} if name == "Chk3Archive" else None
        made[name] = chk3_build.static_variant(name, base, edits, out, drop=drop, add=add)
    return made


@pytest.fixture(scope="module")
def shim_results(tmp_path_factory):
    """Every shim FMU through the rules it breaks and the gates, once, two processes at a time."""
    if shutil.which("gcc") is None:
        pytest.skip("no C compiler (gcc) to build the FMI 3.0 shims")
    out = tmp_path_factory.mktemp("fmi3-shim")
    jobs = []
    for name, (breaks, expected) in SHIM.items():
        path = chk3_build.shim_variant(name, "BouncingBall", breaks, out, defines={"LATE_T": "1.5"},
                                       edits=SHIM_EDITS.get(name))
        ids = set(expected) | {"cs3.basic"} | ({"me3.basic"} if any(r.startswith("me3") for r in expected) else set())
        jobs.append((path, name, sorted({r.split(".")[0] for r in ids}), ids))
    return run_lifecycle_checks_many(jobs, LifecycleOptions(timeout=60.0, jobs=2))


@pytest.mark.parametrize("name", REFERENCE)
def test_reference_fmus_pass_every_static_rule(name):
    results = run_static_checks(chk3_build.reference(name))
    assert [r.check_id for r in results] == [r.id for r in rules("static3")]
    assert [(r.check_id, r.reason) for r in results if r.failed] == []


def test_reference_fmus_pass_the_call_sequences():
    """BouncingBall (events, FMU state, model exchange) and StateSpace (arrays sized by structural parameters):
    every cs3 and me3 rule passes or is skipped (all eight Reference FMUs: docs/compliance.md)."""
    fmus = [(chk3_build.reference(n), n, ["cs3", "me3"]) for n in ("BouncingBall", "StateSpace")]
    res = run_lifecycle_checks_many(fmus, LifecycleOptions(timeout=60.0, jobs=2))
    for name, results in res.items():
        assert [r.check_id for r in results] == [r.id for r in rules("cs3") + rules("me3")]
        assert [(r.check_id, r.reason) for r in results if r.failed] == [], name
    assert "1 outputs (3 values) read" in {r.check_id: r for r in res["StateSpace"]}["cs3.basic"].reason  # y[3]


@pytest.mark.parametrize("name", list(STATIC))
def test_broken_static_fmu_fails_exactly_its_rule(static_fmus, name):
    _, _, rule, severity = STATIC[name]
    results = run_static_checks(static_fmus[name])
    failed = {r.check_id: r.severity for r in results if r.failed}
    assert failed == {rule: severity}, [(r.check_id, r.reason) for r in results if r.failed]


@pytest.mark.parametrize("name", list(SHIM))
def test_broken_call_sequence_fails_exactly_its_rule(shim_results, name):
    results = shim_results[name]
    failed = {r.check_id: r.severity for r in results if r.failed}
    assert failed == SHIM[name][1], [(r.check_id, r.label, r.reason) for r in results]


def test_broken_fmu_reasons(static_fmus, shim_results):
    def static(name, rule):
        return {r.check_id: r for r in run_static_checks(static_fmus[name])}[rule].reason

    def calls(name, rule):
        return {r.check_id: r for r in shim_results[name]}[rule].reason
    assert 'g: causality="parameter" with variability="continuous"' in static("Chk3Causality",
                                                                              "static3.causality-variability")
    assert 'der(h): initial="calculated" but a start value (0)' in static("Chk3Initial", "static3.initial")
    assert "unit 'km/h' is not defined under UnitDefinitions" in static("Chk3Units", "static3.units")
    assert "output v is not listed under ModelStructure/Output" in static("Chk3Outputs", "static3.outputs")
    assert "der(v) (state derivative" in static("Chk3InitialUnknowns", "static3.initial-unknowns")
    assert "initial dimension size 0 (must be positive)" in static("Chk3Dimensions", "static3.dimensions")
    assert "e start = 0.2 < min = 0.5" in static("Chk3StartRange", "static3.start-range")
    assert 'a Int32 with variability="continuous"' in static("Chk3Variables", "static3.variables")
    assert "fmi3GetVersion returned b'2.0'" in calls("Chk3CVersion", "cs3.version")
    assert "returned fmi3OK: the FMU has to return fmi3Error" in calls("Chk3CStopTime", "cs3.stop-time")
    assert "the outputs right after fmi3SetFMUState are not the saved ones" in calls("Chk3CStateNoop",
                                                                                    "cs3.get-set-state")
    assert "refused with fmi3Discard" in calls("Chk3CZeroStep", "cs3.zero-step-size")


def test_fmi3_fmu_gets_fmi3_rules_and_junit_cites_fmi3(static_fmus, tmp_path, capsys):
    junit = tmp_path / "out.xml"
    assert main(["--isolated", str(static_fmus["Chk3StartRange"]), "--static-only", "--junit", str(junit)]) == 0
    out = capsys.readouterr().out
    assert "WARN" in out and "[FMI 3.0 2.4.4] 1 of 1 start values outside min/max" in out
    assert "static.fmi2" not in out and "load." not in out
    cases = {c.get("name"): c for c in ET.parse(junit).getroot().iter("testcase")}
    assert set(cases) == {r.id for r in rules("static3")}
    assert cases["static3.start-range"].find("skipped").get("message").startswith("warning [FMI 3.0 2.4.4]")
    assert BY_ID["static3.start-range"].fmi == "3.0"
