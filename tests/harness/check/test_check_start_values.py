"""Issue 43 item 1: no false error from the kit's own call sequence. FMI 2.0 2.1.6 (fmi2EnterInitializationMode):
"Before calling this function, all variables with attribute <ScalarVariable initial = "exact" or "approx"> can be
set with the fmi2SetXXX functions ... Setting other variables is not allowed." An input has no ``initial``; it is
set in Initialization Mode (3.1, table 1: "Set continuous-time and discrete-time inputs u(t0)" under "Equations
during Initialization Mode"). ChkCStrictInputs refuses an input before it, as Test-FMUs 0.0.1 Feedthrough does:
every rule of both interfaces must pass it exactly as it passes ChkC.
"""
from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "broken_fmus"))
import chk_build  # noqa: E402

from harness.check import LifecycleOptions, lifecycle_rules, run_lifecycle_checks_many  # noqa: E402

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler (gcc) to build ChkC")


@needs_gcc
def test_an_fmu_refusing_inputs_before_initialization_gets_what_chkc_gets():
    jobs = [(chk_build.chkc_fmu(n), n, ["cs", "me"]) for n in ("ChkC", "ChkCStrictInputs")]
    res = run_lifecycle_checks_many(jobs, LifecycleOptions(jobs=2, timeout=60.0))
    plain = {r.check_id: r.status for r in res["ChkC"]}
    strict = {r.check_id: (r.status, r.reason) for r in res["ChkCStrictInputs"]}
    assert list(strict) == lifecycle_rules(["cs", "me"])
    differ = {rid: strict[rid] for rid in strict if strict[rid][0] != plain[rid]}
    assert not differ, differ
    assert strict["me.basic"][0] == "PASS" and strict["cs.basic"][0] == "PASS"
