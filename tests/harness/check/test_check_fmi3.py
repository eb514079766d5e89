"""The compliance kit on FMI 3.0 FMUs of our own (issue 43 item 5, issue 46 item 5): Chk3C (tests/broken_fmus/chk3c.c,
co-simulation and model exchange) gives 0 errors, and every FMI 3.0 rule catches a broken FMU of its own: Chk3C
with its modelDescription.xml edited for the static rules, built with one BREAK_* macro of chk3c.c for the call
sequences (tests/broken_fmus/chk_build.py). Built once (cached by their sources); skipped, with the reason,
without gcc. No Reference FMU is used.
"""
from __future__ import annotations

import shutil
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "broken_fmus"))

import chk_build  # noqa: E402
from harness.check import LifecycleOptions, run_lifecycle_checks_many, run_static_checks  # noqa: E402
from harness.check.rules import BY_ID, RULES3, rules  # noqa: E402
from harness.cli.check import main  # noqa: E402

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler (gcc) to build Chk3C")

# broken FMU -> (modelDescription edits, the static rule it breaks, its severity)
STATIC = {
    "Chk3FmiVersion": ([('fmiVersion="3.0"', 'fmiVersion="3"')], "static3.fmi3", "error"),
    "Chk3Schema": ([('<Float64 name="k" ', '<Float64 name="k" gravity="yes" ')], "static3.schema", "error"),
    "Chk3Variables": ([('  </ModelVariables>', '    <Int32 name="m" valueReference="7" description="an integer" '
                        'causality="input" variability="continuous" start="0"/>\n  </ModelVariables>')],
                      "static3.variables", "error"),
    "Chk3Causality": ([('causality="parameter" variability="fixed" start="2"',
                        'causality="parameter" variability="continuous" start="2"')],
                      "static3.causality-variability", "error"),
    "Chk3Initial": ([('initial="calculated" derivative="3"', 'initial="calculated" start="0" derivative="3"')],
                    "static3.initial", "error"),
    "Chk3Units": ([('start="1" unit="N.m"', 'start="1" unit="km/h"')], "static3.units", "error"),
    "Chk3Outputs": ([('    <Output valueReference="3"/>\n', '')], "static3.outputs", "error"),
    "Chk3InitialUnknowns": ([('    <InitialUnknown valueReference="5" dependencies="1 2" dependenciesKind="dependent '
                              'dependent"/>\n', '')], "static3.initial-unknowns", "error"),
    "Chk3Dimensions": ([('  </ModelVariables>', '    <Float64 name="a" valueReference="8" description="an array" '
                         'causality="local" variability="continuous" initial="calculated"><Dimension '
                         'valueReference="2"/></Float64>\n  </ModelVariables>')], "static3.dimensions", "error"),
    "Chk3StartRange": ([('start="2" unit="1"', 'start="2" min="2.5" unit="1"')], "static3.start-range", "warning"),
    "Chk3Binary": ([], "static3.binary", "warning"),
    "Chk3Archive": ([], "static3.archive", "error"),
}
# broken FMU -> (BREAK_x of chk3c.c, {rule: severity of the expected failure})
BROKEN = {
    "Chk3CBasic": ("BASIC", {"cs3.basic": "error"}),
    "Chk3CVersion": ("VERSION", {"cs3.version": "error"}),
    "Chk3CToken": ("TOKEN", {"cs3.instantiation-token": "warning", "me3.instantiation-token": "warning"}),
    "Chk3CLogger": ("LOGGER", {"cs3.logger": "error"}),
    "Chk3CDebugLogging": ("DEBUG_LOGGING", {"cs3.debug-logging": "error"}),
    "Chk3CInitGet": ("INIT_GET", {"cs3.initial-unknowns": "error"}),
    "Chk3CStopTime": ("STOP_TIME", {"cs3.stop-time": "error"}),
    "Chk3CTerminatedGet": ("TERMINATED_GET", {"cs3.get-after-terminate": "error"}),
    "Chk3CReset": ("RESET", {"cs3.reset": "error"}),
    "Chk3CSharedGlobal": ("SHARED_GLOBAL", {"cs3.two-instances": "error"}),
    "Chk3CStateNoop": ("STATE_NOOP", {"cs3.get-set-state": "error"}),
    "Chk3CFreeState": ("FREE_STATE", {"cs3.free-state": "error"}),
    "Chk3CSerialize": ("SERIALIZE", {"cs3.serialize-state": "error"}),
    "Chk3CVariableStep": ("VARIABLE_STEP", {"cs3.variable-step": "error"}),
    "Chk3COwnClock": ("CLOCK", {"cs3.clock": "warning"}),   # 4.2.1 allows lastSuccessfulTime to deviate
    "Chk3CDirDer": ("DIRDER", {"cs3.directional-derivative": "error"}),
    "Chk3CJacobian": ("JACOBIAN", {"me3.directional-derivative": "error"}),
    "Chk3CEarlyStep": ("EARLY_STEP", {"cs3.step-before-init": "warning"}),
    "Chk3CZeroStep": ("ZERO_STEP", {"cs3.zero-step-size": "error"}),
    "Chk3CLateStep": ("LATE_STEP", {"cs3.default-experiment": "warning"}),
    "Chk3CModelExchange": ("ME", {"me3.basic": "error"}),
    "Chk3CStaleOutput": ("STALE_Y", {"me3.stale-outputs": "error"}),
    "Chk3CDerivOrder": ("DERIV_ORDER", {"cs3.output-derivative-orders": "warning"}),
    "Chk3CDerivNaN": ("DERIV_NAN", {"cs3.output-derivatives": "warning"}),
    "Chk3CEarlyAnyway": ("EARLY_ANYWAY", {"cs3.early-return-not-allowed": "error"}),
    "Chk3CEarlyTime": ("EARLY_TIME", {"cs3.early-return-time": "error"}),
    "Chk3CEventMode": ("EVENT_MODE", {"cs3.event-mode": "error"}),
    "Chk3CIntermediate": ("INTERMEDIATE", {"cs3.intermediate-update": "error"}),
    "Chk3CConfiguration": ("CONFIGURATION", {"cs3.configuration-mode": "error"}),
}
# broken FMU -> (how chk_build links it, {load rule: severity of the expected failure})
LOAD = {
    "Chk3CNoLibm": ("LIBM", {"load3.needed-libraries": "warning"}),
    # a library found nowhere also leaves the symbols it would define undefined
    "Chk3CMissingLib": ("MISSING_LIB", {"load3.libraries": "warning", "load3.needed-libraries": "warning"}),
}


@pytest.fixture(scope="module")
def static_fmus():
    made = {}
    for name, (edits, _, _) in STATIC.items():
        drop = ("binaries/",) if name == "Chk3Binary" else ()
        add = {"../outside.txt": b"x"} if name == "Chk3Archive" else None
        made[name] = chk_build.static_variant(name, edits, drop=drop, add=add)
    return made


@pytest.fixture(scope="module")
def broken_results():
    """Every broken Chk3C through the rules it breaks and the gates, once, two processes at a time."""
    jobs = []
    for name, (breaks, expected) in BROKEN.items():
        ids = set(expected) | {"cs3.basic"} | ({"me3.basic"} if any(r.startswith("me3") for r in expected) else set())
        jobs.append((chk_build.chk3c_fmu(name, breaks), name, sorted({r.split(".")[0] for r in ids}), ids))
    return run_lifecycle_checks_many(jobs, LifecycleOptions(timeout=60.0, jobs=2))


def test_chk3c_passes_every_rule_with_no_error():
    """The well-behaved Chk3C: every static3, cs3 and me3 rule passes, none is skipped but those whose feature it
    lacks (arrays, min/max)."""
    fmu = chk_build.chk3c_fmu("Chk3C")
    static = run_static_checks(fmu)
    assert [r.check_id for r in static] == [r.id for r in rules("static3")]
    assert [(r.check_id, r.reason) for r in static if r.failed] == []
    res = run_lifecycle_checks_many([(fmu, "Chk3C", ["cs3", "me3"])], LifecycleOptions(timeout=60.0, jobs=2))["Chk3C"]
    assert [r.check_id for r in res] == [r.id for r in rules("cs3") + rules("me3")]
    assert [(r.check_id, r.reason) for r in res if r.failed] == []
    skipped = {r.check_id for r in static + res if r.status == "SKIP"}
    assert skipped == {"static3.dimensions", "static3.start-range"}, skipped


def test_every_fmi3_rule_has_a_broken_fmu():
    caught = {r for _, rule, _ in STATIC.values() for r in [rule]} | {r for _, exp in BROKEN.values() for r in exp}
    caught |= {r for _, exp in LOAD.values() for r in exp}
    assert {r.id for r in RULES3} - caught == set()


@pytest.mark.parametrize("name", list(STATIC))
def test_broken_static_fmu_fails_exactly_its_rule(static_fmus, name):
    _, rule, severity = STATIC[name]
    results = run_static_checks(static_fmus[name])
    failed = {r.check_id: r.severity for r in results if r.failed}
    assert failed == {rule: severity}, [(r.check_id, r.reason) for r in results if r.failed]


@pytest.mark.parametrize("name", list(BROKEN))
def test_broken_call_sequence_fails_exactly_its_rule(broken_results, name):
    results = broken_results[name]
    failed = {r.check_id: r.severity for r in results if r.failed}
    assert failed == BROKEN[name][1], [(r.check_id, r.label, r.reason) for r in results]


@pytest.mark.parametrize("name", list(LOAD))
def test_broken_binary_fails_exactly_its_load_rule(name):
    from harness.check.processes.native import run_load_checks
    breaks, expected = LOAD[name]
    results = run_load_checks(chk_build.chk3c_fmu(name, breaks), name, ["load3.libraries", "load3.needed-libraries"],
                              60.0)
    assert {r.check_id: r.severity for r in results if r.failed} == expected, [(r.check_id, r.reason) for r in results]


def test_broken_fmu_reasons(static_fmus, broken_results):
    def static(name, rule):
        return {r.check_id: r for r in run_static_checks(static_fmus[name])}[rule].reason

    def calls(name, rule):
        return {r.check_id: r for r in broken_results[name]}[rule].reason
    assert 'k: causality="parameter" with variability="continuous"' in static("Chk3Causality",
                                                                              "static3.causality-variability")
    assert 'der(x): initial="calculated" but a start value (0)' in static("Chk3Initial", "static3.initial")
    assert "unit 'km/h' is not defined under UnitDefinitions" in static("Chk3Units", "static3.units")
    assert "output x is not listed under ModelStructure/Output" in static("Chk3Outputs", "static3.outputs")
    assert "der(x) (state derivative" in static("Chk3InitialUnknowns", "static3.initial-unknowns")
    assert "k start = 2 < min = 2.5" in static("Chk3StartRange", "static3.start-range")
    assert 'a Int32 with variability="continuous"' in static("Chk3Variables", "static3.variables")
    assert "fmi3GetVersion returned b'2.0'" in calls("Chk3CVersion", "cs3.version")
    assert "returned fmi3OK: the FMU has to return fmi3Error" in calls("Chk3CStopTime", "cs3.stop-time")
    # the state not restored: the FMU's own time is not the saved one, and it refuses the step from there
    assert 'fmi3DoStep(t=0.05, h=0.01) [instance state] returned fmi3Error: FMU says "communication point 0.05, ' \
        'expected 0.1"' in calls("Chk3CStateNoop", "cs3.get-set-state")
    assert "refused with fmi3Discard" in calls("Chk3CZeroStep", "cs3.zero-step-size")
    assert "instanceEnvironment 0x0 instead of" in calls("Chk3CLogger", "cs3.logger")
    assert "does not integrate to currentCommunicationPoint + communicationStepSize" in calls("Chk3COwnClock",
                                                                                             "cs3.clock")
    assert "fmi3FreeFMUstate left the state pointer at" in calls("Chk3CFreeState", "cs3.free-state")
    assert "intermediateUpdateTime 0.02 outside [0, 0.01]" in calls("Chk3CIntermediate", "cs3.intermediate-update")
    assert "fmi3EnterStepMode [instance eventMode] returned fmi3Error" in calls("Chk3CEventMode", "cs3.event-mode")
    assert "fmi3ExitConfigurationMode [instance configuration] returned fmi3Error" in calls("Chk3CConfiguration",
                                                                                           "cs3.configuration-mode")
    assert "after fmi3SetFloat64(u = 1.1), y is still 2.0, while an instance initialized with u = 1.1 gives 2.2" in \
        calls("Chk3CStaleOutput", "me3.stale-outputs")
    assert "with lastSuccessfulTime -0.01, not in [t, t + h)" in calls("Chk3CEarlyTime", "cs3.early-return-time")


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
