"""The compliance kit's call-sequence rules on deliberately broken FMUs (tests/broken_fmus/).

Test FMUs are built once and cached under build/test-fmus/ (tests/broken_fmus/chk_build.py).
Each broken FMU runs only the rules it is about (plus the gate cs.basic), so the file stays fast;
the well-behaved ChkC runs every rule. Each broken FMU must fail exactly the rule it was built to
break, with the severity the rule has.
"""
from __future__ import annotations

import os
import shutil
import signal
import sys
import threading
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "broken_fmus"))
import chk_build  # noqa: E402

from harness.check import LifecycleOptions, lifecycle_rules, run_lifecycle_checks_many  # noqa: E402

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler (gcc) to build ChkC")
STATE_FLAGS = ["--handle-state", "--serialize-state"]

# broken FMU -> (how it is built, the rules it runs, {rule: severity of the expected failure})
CATCH_TABLE = {
    "ChkCVersion": ("c", ["cs.version"], {"cs.version": "error"}),
    "ChkCTypes": ("c", ["cs.version"], {"cs.version": "warning"}),   # "default" is recommended (2.1.2)
    "ChkCLogger": ("c", ["cs.logger"], {"cs.logger": "error"}),
    "ChkCDebugLogging": ("c", ["cs.debug-logging"], {"cs.debug-logging": "error"}),
    "ChkCInitGet": ("c", ["cs.initial-unknowns"], {"cs.initial-unknowns": "error"}),
    "ChkCStopTime": ("c", ["cs.stop-time"], {"cs.stop-time": "error"}),
    "ChkCDiscardAtStop": ("c", ["cs.stop-time", "cs.status-after-discard"], {"cs.stop-time": "warning"}),
    "ChkCStatus": ("c", ["cs.status-after-discard"], {"cs.status-after-discard": "error"}),
    "ChkCTerminatedGet": ("c", ["cs.get-after-terminate"], {"cs.get-after-terminate": "error"}),
    "ChkCFreeState": ("c", ["cs.free-state", "cs.get-set-state"], {"cs.free-state": "error"}),
    "ChkCGuid": ("c", ["cs.guid", "me.guid"], {"cs.guid": "warning", "me.guid": "warning"}),   # 2.1.5: no must on the FMU
    "ChkCLateStep": ("c", ["cs.default-experiment"], {"cs.default-experiment": "warning"}),
    "ChkCInterpolate": ("c", ["cs.interpolate-inputs"], {"cs.interpolate-inputs": "error"}),
    "ChkCDirDer": ("c", ["cs.directional-derivative", "me.directional-derivative"],
                   {"cs.directional-derivative": "error", "me.directional-derivative": "error"}),
    "ChkCJacobian": ("c", ["cs.directional-derivative", "me.directional-derivative"],
                     {"me.directional-derivative": "error"}),
    "ChkCModelExchange": ("c", ["me.basic"], {"me.basic": "error"}),
    # 4.2.4 forbids get after set in co-simulation (info); in model exchange it is how an integrator works (error)
    "ChkCStaleOutput": ("c", ["cs.feedthrough", "me.stale-outputs"],
                        {"cs.feedthrough": "info", "me.stale-outputs": "error"}),
    "ChkCOwnClock": ("c", ["cs.clock"], {"cs.clock": "error"}),
    # lost integrator history: one finding (a warning), the restore-vs-restore rules pass
    "ChkCLostHistory": ("c", ["cs.get-set-state", "cs.free-state", "cs.serialize-state"],
                        {"cs.get-set-state": "warning"}),
    "ChkIgnoresStopTime": ("py", ["cs.stop-time"], {"cs.stop-time": "error"}),
    "ChkConsumesState": ("py", ["cs.get-set-state", "cs.free-state"], {"cs.free-state": "error"}),
    "ChkRaiseInStep": ("py", ["cs.reset"], {"cs.basic": "error"}),
    "ChkResetKeepsState": ("py", ["cs.reset"], {"cs.reset": "error"}),
    "ChkStateRestoreNoop": ("py", ["cs.get-set-state"], {"cs.get-set-state": "error"}),
    "ChkSharedGlobal": ("py", ["cs.reset", "cs.two-instances"], {"cs.reset": "error", "cs.two-instances": "error"}),
    "ChkCrashInStep": ("py", [], {"cs.basic": "error"}),
}
PY_FLAGS = {"ChkStateRestoreNoop": ["--handle-state"], "ChkCrashInStep": []}


def fmu_path(name: str) -> Path:
    how = CATCH_TABLE[name][0] if name in CATCH_TABLE else ("c" if name.startswith("ChkC") else "py")
    if how == "c":
        return chk_build.chkc_fmu(name)
    return chk_build.pythonfmu_fmu(name, PY_FLAGS.get(name, STATE_FLAGS))


@pytest.fixture(scope="session")
def caught():
    """Every broken FMU of CATCH_TABLE through its own rules and the gates, once, in parallel."""
    names = [n for n, (how, _, _) in CATCH_TABLE.items() if how == "py" or shutil.which("gcc")]
    jobs = []
    for n in names:
        _, rules, expected = CATCH_TABLE[n]
        ids = set(rules) | set(expected)
        kinds = sorted({r.split(".")[0] for r in ids} | {"cs"})
        ids |= {f"{k}.basic" for k in kinds}
        jobs.append((fmu_path(n), n, kinds, ids))
    return run_lifecycle_checks_many(jobs, LifecycleOptions(timeout=60.0))


@pytest.mark.parametrize("name", list(CATCH_TABLE))
def test_broken_fmu_fails_exactly_its_rule(caught, name):
    if name not in caught:
        pytest.skip("no C compiler (gcc) to build ChkC")
    results = caught[name]
    failed = {r.check_id: r.severity for r in results if r.status == "FAIL"}
    assert failed == CATCH_TABLE[name][2], [(r.check_id, r.label, r.reason) for r in results]


@needs_gcc
def test_well_behaved_c_fmu_passes_every_rule_of_both_interfaces():
    path = chk_build.chkc_fmu("ChkC")
    profiles = ("spurdiff",)
    results = run_lifecycle_checks_many([(path, "ChkC", ["cs", "me"])], LifecycleOptions(profiles=profiles))["ChkC"]
    assert [r.check_id for r in results] == lifecycle_rules(["cs", "me"], profiles)
    not_passed = {r.check_id: r.reason for r in results if r.status != "PASS"}
    # nothing to observe: ChkC declares no output derivatives (it discards a step only with NaN
    # inputs, which is how cs.status-after-discard reaches it)
    assert set(not_passed) == {"cs.output-derivatives"}, not_passed
    assert all(r.status == "SKIP" for r in results if r.check_id in not_passed)
    me = {r.check_id: r for r in results}["me.basic"]
    assert "100 explicit Euler steps of 0.01 s from 0 to 1 s, 1 states" in me.reason


def test_broken_fmu_reasons(caught):
    def reason(name, rule):
        if name not in caught:
            pytest.skip("no C compiler (gcc) to build ChkC")
        return {r.check_id: r for r in caught[name]}[rule].reason
    assert "fmi2GetVersion returned b'1.0', not \"2.0\"" in reason("ChkCVersion", "cs.version")
    assert "componentEnvironment 0x0 is not one given to fmi2Instantiate (instance name 'someoneElse'" in reason("ChkCLogger", "cs.logger")
    assert "returned fmi2OK: the FMU has to return fmi2Error" in reason("ChkIgnoresStopTime", "cs.stop-time")
    assert "fmi2GetRealStatus(fmi2LastSuccessfulTime) returned fmi2Error" in reason("ChkCStatus", "cs.status-after-discard")
    assert ("set for the second time, continues differently: the outputs right after fmi2SetFMUstate are not the "
            "saved ones: x 0.2 vs 0.1") in reason("ChkConsumesState", "cs.free-state")
    assert "not NULL" in reason("ChkCFreeState", "cs.free-state")
    assert reason("ChkCrashInStep", "cs.basic").startswith("crashed (SIGSEGV) in fmi2DoStep(t=0.02, h=0.01)")
    assert "fmi2Fatal" in reason("ChkRaiseInStep", "cs.basic") and "ZeroDivisionError" in reason("ChkRaiseInStep", "cs.basic")
    assert "x after initialization: 0.2" in reason("ChkResetKeepsState", "cs.reset")
    assert "the first instance (start values) changed when a second one ran beside it" in reason("ChkSharedGlobal", "cs.two-instances")
    assert "fmi2CompletedIntegratorStep [instance me] returned fmi2Error" in reason("ChkCModelExchange", "me.basic")
    assert "d der(x)/d x: 1.0 vs central difference 0.0" in reason("ChkCJacobian", "me.directional-derivative")
    assert "y (on u); y stayed 2.0, and only after the next doStep it is 2.2" in reason("ChkCStaleOutput", "cs.feedthrough")
    assert ("x changes with steps of 0.01 s but not at all with steps of 0.005 s (it stays 0.0 to t = 0.1 s)"
            in reason("ChkCOwnClock", "cs.clock"))
    lost = reason("ChkCLostHistory", "cs.get-set-state")
    assert "the outputs are the saved ones, but the continuation differs by up to 2e-07" in lost
    assert "tolerance 0.0001; a second restore continues within 0 of the first" in lost
    assert "integrator history: cs.get-set-state" in reason("ChkCLostHistory", "cs.serialize-state")
    assert "restores nothing" not in reason("ChkStateRestoreNoop", "cs.get-set-state")
    assert "the outputs right after fmi2SetFMUstate are not the saved ones: x" in reason("ChkStateRestoreNoop",
                                                                                     "cs.get-set-state")


def test_pythonfmu_limits_are_reported_not_hidden(tmp_path, capsys):
    """The whole command on ChkGood (pythonfmu): pythonfmu 0.7's C++ layer does not compare the GUID
    and leaves fmi2FreeFMUstate's pointer set, so every pythonfmu FMU is warned by cs.guid (a warning:
    no sentence of FMI 2.0 makes the FMU refuse another GUID, docs/compliance.md) and fails cs.free-state;
    it answers fmi2GetStatus with fmi2Error and refuses past the stop time with fmi2Discard (warnings).
    Its binary needs libpython's symbols without declaring libpython (it loads only into a Python process:
    the load rules warn), and ChkGood computes y = k u in do_step only (cs.feedthrough: info)."""
    from harness.check.rules import rules
    from harness.cli.check import main as _main

    def main(argv):
        return _main(["--isolated", *argv])
    import xml.etree.ElementTree as ET
    path = chk_build.pythonfmu_fmu("ChkGood", STATE_FLAGS)
    junit = tmp_path / "good.xml"
    assert main([str(path), "--junit", str(junit), "--jobs", "2"]) == 1
    lines = [ln for ln in capsys.readouterr().out.splitlines()
             if ln.split(" ")[0] in ("PASS", "ERROR", "WARN", "INFO", "SKIP")]
    assert len(lines) == len(rules("static")) + len(rules("load")) + len(rules("cs"))
    labels = {ln.split("  ")[2]: ln.split(" ")[0] for ln in lines if not ln.startswith(("PASS", "SKIP"))}
    assert labels == {"cs.guid": "WARN", "cs.free-state": "ERROR", "cs.stop-time": "WARN",
                      "cs.status-after-discard": "WARN", "cs.feedthrough": "INFO", "load.needed-libraries": "WARN",
                      "load.bare-process": "WARN"}, labels
    root = ET.parse(junit).getroot()
    assert root.get("tests") == str(len(lines)) and root.get("failures") == "1"


def test_timeout_kills_a_daemon_left_behind(tmp_path, monkeypatch):
    """Issue 14 item 3: an FMU that forks a daemon (setsid, pipes kept) and hangs ends at the timeout."""
    pidfile = tmp_path / "daemon.pid"
    monkeypatch.setenv("CHK_DAEMON_PIDFILE", str(pidfile))
    path = chk_build.pythonfmu_fmu("ChkDaemonInStep", [])
    box = {}
    worker = threading.Thread(target=lambda: box.update(r=run_lifecycle_checks_many(
        [(path, "daemon", ["cs"])], LifecycleOptions(timeout=3.0), checks=["cs.basic"])["daemon"][0]), daemon=True)
    worker.start()
    worker.join(120.0)  # a hang guard, not a speed target: the old code never returned
    assert not worker.is_alive(), "spurdiff check hung on an FMU that left a daemon behind"
    r = box["r"]
    assert r.status == "FAIL" and r.reason.startswith("timed out after 3 s in fmi2DoStep(t=0, h=0.01)")
    pid = int(pidfile.read_text())
    for _ in range(50):  # the kill is asynchronous: give the kernel a moment to reap
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            break
        if Path(f"/proc/{pid}/stat").exists() and Path(f"/proc/{pid}/stat").read_text().split()[2] == "Z":
            break  # a zombie: dead, waiting for its parent (init) to reap it
        time.sleep(0.1)
    else:
        os.kill(pid, signal.SIGKILL)
        pytest.fail(f"the daemon {pid} survived the timeout")
