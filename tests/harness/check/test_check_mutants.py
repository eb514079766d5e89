"""Issue 43 item 7: two rules whose mutants no test killed, each now with a broken FMU of its own.

* ``cs.stop-time``: ChkCWarnAtStop (tests/broken_fmus/chkc.c, WARN_AT_STOP) answers a doStep past the
  defined stop time with fmi2Warning, which is no refusal (FMI 2.0 2.1.6: "the FMU has to return fmi2Status
  = fmi2Error"). A rule that took fmi2Warning for a refusal passes it; this test then fails.
* ``cs3.early-return-time``: Chk3CEarlyTime (tests/broken_fmus/chk3c.c, BREAK_EARLY_TIME) returns early
  with lastSuccessfulTime = t - h, before the step started (FMI 3.0 4.2.1: early return between the
  communication point and its end). A rule without the lower bound t <= lastSuccessfulTime passes it.
"""
from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "broken_fmus"))
import chk_build  # noqa: E402

from harness.check import LifecycleOptions, run_lifecycle_checks_many  # noqa: E402

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler (gcc) to build ChkC")


def _results(fmu: Path, kinds: list[str], ids: list[str]) -> dict:
    out = run_lifecycle_checks_many([(fmu, "x", kinds, ids)], LifecycleOptions(jobs=1, timeout=60.0))["x"]
    return {r.check_id: r for r in out}


@needs_gcc
def test_stop_time_takes_a_warning_past_the_stop_time_for_no_refusal():
    r = _results(chk_build.chkc_fmu("ChkCWarnAtStop"), ["cs"], ["cs.basic", "cs.stop-time"])
    assert r["cs.basic"].status == "PASS", r["cs.basic"].reason
    stop = r["cs.stop-time"]
    assert stop.status == "FAIL" and stop.severity == "error", stop.reason
    assert "returned fmi2Warning" in stop.reason and "has to return fmi2Error" in stop.reason


@needs_gcc
def test_stop_time_passes_the_same_fmu_refusing_with_fmi2error():
    r = _results(chk_build.chkc_fmu("ChkC"), ["cs"], ["cs.basic", "cs.stop-time"])
    assert r["cs.stop-time"].status == "PASS" and "refused with fmi2Error" in r["cs.stop-time"].reason


def _chk3c(name: str, breaks: str | None):
    return chk_build.chk3c_fmu(name, breaks)


@needs_gcc
def test_early_return_time_refuses_a_last_successful_time_before_the_step():
    r = _results(_chk3c("Chk3CEarlyTime", "EARLY_TIME"), ["cs3"], ["cs3.basic", "cs3.early-return-time"])
    assert r["cs3.basic"].status == "PASS", r["cs3.basic"].reason
    early = r["cs3.early-return-time"]
    assert early.status == "FAIL" and early.severity == "error", early.reason
    # the step was from t = 0 with h = 0.01: the FMU said it got to -0.01, before the step started
    assert "returned earlyReturn = true with lastSuccessfulTime -0.01" in early.reason
    good = _results(_chk3c("Chk3C", None), ["cs3"], ["cs3.basic", "cs3.early-return-time"])
    assert good["cs3.early-return-time"].status == "PASS", good["cs3.early-return-time"].reason
