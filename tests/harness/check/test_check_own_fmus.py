"""0 errors on a correct FMU (issue 46 item 5): the role the Reference FMUs had in the kit's tests passes to test
FMUs of our own, FMI 2.0 and 3.0, co-simulation and model exchange (ChkC: tests/broken_fmus/chkc.c, Chk3C:
tests/broken_fmus/chk3c.c), through every rule the command line runs (static, load, call sequences), and to the
Test-FMUs 0.0.1 of the cross-check suite (../shared/xcheck/), where every error is one the standard makes an
error for the FMU (a step past the defined stop time accepted, a continuous Integer), nothing else.
"""
from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "broken_fmus"))
import chk_build  # noqa: E402

from harness.check import LifecycleOptions  # noqa: E402
from harness.check.runner import run_checks  # noqa: E402

XCHECK = Path(__file__).resolve().parents[4] / "shared" / "xcheck" / "fmus" / "2.0" / "cs" / "linux64" / "Test-FMUs"
TEST_FMUS = sorted(XCHECK.glob("0.0.1/*/*.fmu")) if XCHECK.is_dir() else []
needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler (gcc) to build ChkC / Chk3C")


@needs_gcc
@pytest.mark.parametrize("version", ["2.0", "3.0"])
def test_our_test_fmu_gives_no_error_in_any_rule(version):
    fmu = str(chk_build.chkc_fmu("ChkC") if version == "2.0" else chk_build.chk3c_fmu("Chk3C"))
    results = run_checks([fmu], LifecycleOptions(timeout=60.0, jobs=2))
    assert [(r.check_id, r.reason) for r in results if r.failed] == []
    ran = {r.check_id.split(".")[0] for r in results if r.status == "PASS"}
    suffix = "" if version == "2.0" else "3"
    assert {f"static{suffix}", f"cs{suffix}", f"me{suffix}"} <= ran, ran   # both interfaces exercised


@pytest.mark.skipif(not TEST_FMUS, reason=f"{XCHECK} is absent")
def test_test_fmus_give_only_the_errors_the_standard_makes():
    results = run_checks([str(p) for p in TEST_FMUS], LifecycleOptions(timeout=60.0, jobs=2))
    errors = {(Path(r.subject).stem, r.check_id) for r in results if r.is_error}
    real = {(name, "cs.stop-time") for name in ("Dahlquist", "Feedthrough", "Stair", "VanDerPol")}
    real.add(("Stair", "static.fmpy-validate"))   # counter: an Integer with variability continuous (2.2.7)
    assert errors == real, sorted(errors ^ real)
    passed = {(Path(r.subject).stem, r.check_id.split(".")[0]) for r in results if r.status == "PASS"}
    assert {(p.stem, k) for p in TEST_FMUS for k in ("static", "cs", "me")} <= passed
