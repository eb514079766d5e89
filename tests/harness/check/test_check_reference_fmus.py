"""The compliance kit on the FMI 2.0 Reference FMUs, beside the FMU Compliance Checker, and on ours.

* the six Reference FMUs of the Modelica Association (../shared/hosts/reference-fmus/) give 0
  errors (skipped, with that reason, where the folder is absent);
* the kit's reference run and the Compliance Checker's output CSV agree to 1e-9 (co-simulation,
  the DefaultExperiment step, output at every step), on the Reference FMUs and on ours where the
  checker can run them; so do the kit's model-exchange run (me.basic) and the checker's (-k me);
* whatever the checker flags, the kit flags too (on the Reference FMUs and the ChkC variants of
  tests/broken_fmus/); where only the kit flags, docs/compliance.md says why (section of FMI 2.0);
* our three FMUs under ``--profile spurdiff`` (the project's own conventions as errors).
"""
from __future__ import annotations

import csv
import math
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "broken_fmus"))
import chk_build  # noqa: E402

from harness.check import LifecycleOptions, read_cross_check_csv, write_reference_results  # noqa: E402
from harness.check.crosscheck.reference import default_experiment  # noqa: E402
from harness.check.runner import run_checks  # noqa: E402

HOSTS = Path(__file__).resolve().parents[4] / "shared" / "hosts"
REFERENCE_DIR = HOSTS / "reference-fmus"
FMUCHECK = HOSTS / "fmuCheck.linux64"
REFERENCE_FMUS = sorted(REFERENCE_DIR.glob("*.fmu")) if REFERENCE_DIR.is_dir() else []
needs_reference = pytest.mark.skipif(not REFERENCE_FMUS, reason=f"{REFERENCE_DIR} is absent")
needs_fmucheck = pytest.mark.skipif(not FMUCHECK.is_file(), reason=f"{FMUCHECK} is absent")


@pytest.fixture(scope="session")
def reference_results():
    fmus = [str(p) for p in REFERENCE_FMUS]
    results = run_checks(fmus, LifecycleOptions(timeout=120.0))
    return {f: [r for r in results if r.subject == f] for f in fmus}


@needs_reference
def test_reference_fmus_give_no_error(reference_results):
    assert len(reference_results) == 6
    for fmu, results in reference_results.items():
        errors = [(r.check_id, r.reason) for r in results if r.is_error]
        assert errors == [], fmu
        kinds = {r.check_id.split(".")[0] for r in results if r.status == "PASS"}
        # both interfaces were exercised, and the binary in a bare C process (where there is a compiler)
        assert kinds == {"static", "cs", "me"} | ({"load"} if shutil.which("cc") else set()), fmu
        new = {r.check_id: r.status for r in results if r.check_id in ("cs.clock", "cs.feedthrough")}
        assert all(st in ("PASS", "SKIP") for st in new.values()), (fmu, new)


def fmucheck(fmu: Path, out: Path, kind: str = "cs") -> tuple[int, str, Path]:
    """Run the Compliance Checker with the FMU's DefaultExperiment step and stop time, output at
    every step. Returns (exit code, its log, the CSV)."""
    from fmpy import read_model_description
    exp = default_experiment(read_model_description(str(fmu), validate=False))
    csv_path, log = out / f"{fmu.stem}_{kind}.csv", out / f"{fmu.stem}_{kind}.log"
    r = subprocess.run([str(FMUCHECK), "-k", kind, "-h", repr(exp.step_size), "-s", repr(exp.stop_time), "-n", "0",
                        "-l", "3", "-o", str(csv_path), "-e", str(log), "-t", str(out), str(fmu)],
                       env={"PATH": "/usr/bin:/bin"}, capture_output=True, text=True, timeout=300)
    return r.returncode, log.read_text(errors="replace") if log.exists() else r.stderr, csv_path


def checker_flags(rc: int, log: str) -> bool:
    """The Compliance Checker flagged the FMU: a non-zero exit or errors it reported."""
    import re
    m = re.search(r"Checker reported:\s*\n\s*(\d+) Warning\(s\)\s*\n\s*(\d+) Error\(s\)", log)
    return rc != 0 or (m is not None and int(m.group(2)) > 0)


def read_checker_csv(path: Path) -> tuple[list[str], list[list[str]]]:
    with path.open(newline="") as f:
        rows = [r for r in csv.reader(f) if r]
    return rows[0], rows[1:]


def max_difference(kit_csv: Path, checker_csv: Path) -> tuple[float, int]:
    """Largest |kit - checker| / max(1, |checker|) over the kit's columns and rows; rows compared."""
    names, rows = read_cross_check_csv(kit_csv)
    c_names, c_rows = read_checker_csv(checker_csv)
    assert len(rows) == len(c_rows), f"{len(rows)} rows vs the checker's {len(c_rows)}"
    worst = 0.0
    for name in names:
        j, k = names.index(name), c_names.index(name)
        for a, b in zip(rows, c_rows):
            x, y = a[j], float(b[k])
            if math.isnan(x) and math.isnan(y):
                continue
            worst = max(worst, abs(x - y) / max(1.0, abs(y)))
    return worst, len(rows)


def _instantiate_failed(log: str) -> bool:
    return "fmi2Instantiate" in log and ("failed" in log.lower() or "Could not" in log)


@needs_reference
@needs_fmucheck
@pytest.mark.parametrize("fmu", REFERENCE_FMUS, ids=lambda p: p.stem)
def test_reference_run_agrees_with_the_compliance_checker(fmu, tmp_path, reference_results):
    rc, log, checker_csv = fmucheck(fmu, tmp_path)
    assert rc == 0 and not checker_flags(rc, log), log[-800:]
    res = write_reference_results(fmu, tmp_path / "kit")
    assert res.status == "PASS", res.reason
    [kit_csv] = (tmp_path / "kit").glob("*/*_ref.csv")
    worst, n = max_difference(kit_csv, checker_csv)
    assert worst <= 1e-9, f"{fmu.stem}: kit and checker differ by {worst:g} (relative, over {n} rows)"
    # the checker passes it, and so does the kit
    assert not any(r.is_error for r in reference_results[str(fmu)])


@needs_reference
@needs_fmucheck
@pytest.mark.parametrize("fmu", REFERENCE_FMUS, ids=lambda p: p.stem)
def test_model_exchange_run_agrees_with_the_compliance_checker(fmu, tmp_path):
    """me.basic's explicit Euler (events included: BouncingBall's bounces, Stair's time events and
    termination) reproduces the checker's forward Euler (-k me) at every row."""
    from harness.check.lifecycle import run_model_exchange
    rc, log, checker_csv = fmucheck(fmu, tmp_path, "me")
    assert rc == 0 and not checker_flags(rc, log), log[-800:]
    res = run_model_exchange(fmu, tmp_path / "kit_me.csv")
    assert res.status == "PASS", res.reason
    worst, n = max_difference(tmp_path / "kit_me.csv", checker_csv)
    assert worst <= 1e-9, f"{fmu.stem}: kit and checker differ by {worst:g} (relative, over {n} rows)"


# ChkC variants: the kit must flag every one the checker flags
CHKC_FOR_AGREEMENT = ["ChkC", "ChkCTypes", "ChkCModelExchange", "ChkCLateStep", "ChkCVersion", "ChkCGuid",
                      "ChkCStopTime", "ChkCInitGet"]


@needs_fmucheck
@pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler (gcc) to build ChkC")
def test_kit_flags_what_the_checker_flags(tmp_path):
    fmus = {v: chk_build.chkc_fmu(v) for v in CHKC_FOR_AGREEMENT}
    by_checker = {v: any(checker_flags(*fmucheck(p, tmp_path, kind)[:2]) for kind in ("cs", "me"))
                  for v, p in fmus.items()}
    # the whole kit on what the checker flags (that the kit passes ChkC, which the checker passes too, is
    # test_check_fmus.py::test_well_behaved_c_fmu_passes_every_rule_of_both_interfaces; the variants
    # only the kit flags are the catch table there)
    run = [v for v in fmus if by_checker[v]]
    kit = run_checks([str(fmus[v]) for v in run], LifecycleOptions(timeout=60.0))
    failed = {v: {r.check_id: r.severity for r in kit if r.subject == str(fmus[v]) and r.status == "FAIL"}
              for v in run}
    print("\nvariant: checker flags, kit flags\n" + "\n".join(f"{v}: {by_checker[v]}, {failed.get(v, '-')}" for v in fmus))
    assert all(failed.values()), failed          # the checker flags => the kit flags
    # where the standard's text has no shall/must the kit's finding is a warning, not the checker's error:
    # a types platform other than "default" (2.1.2 "It is recommended"), a refusal inside the default
    # experiment (2.2.5 "A tool may ignore this information"); every other one is an error
    warn_only = {"ChkCTypes": {"cs.version"}, "ChkCLateStep": {"cs.default-experiment"}}
    for v, found in failed.items():
        if v in warn_only:
            assert set(found) == warn_only[v] and set(found.values()) == {"warning"}, (v, found)
        else:
            assert "error" in found.values(), (v, found)
    assert by_checker["ChkC"] is False           # the checker passes the well-behaved one
    assert len(run) >= 2                         # the comparison is not vacuous


@pytest.fixture(scope="session")
def our_results(fmu_files):
    """Static rules and the profile's call-sequence rule (the full run costs a minute: `spurdiff check
    build/fmus/*.fmu --profile spurdiff`, quoted in docs/compliance.md)."""
    from harness.check import run_lifecycle_checks_many, run_static_checks
    profiles = ("spurdiff",)
    out = {}
    for f in map(str, fmu_files.values()):
        out[f] = run_static_checks(f, profiles=profiles)
    calls = run_lifecycle_checks_many([(f, f, ["cs"], {"cs.basic", "cs.parameter-after-init"}) for f in out],
                                      LifecycleOptions(timeout=300.0, profiles=profiles))
    return {f: out[f] + calls[f] for f in out}


def test_our_fmus_under_the_spurdiff_profile(our_results):
    """Our CI keeps the project's conventions on for our FMUs: every profile rule passes."""
    for fmu, results in our_results.items():
        profile = {r.check_id: r for r in results if r.check_id in (
            "static.units", "static.descriptions", "static.all-output-dependencies", "cs.parameter-after-init")}
        assert len(profile) == 4
        assert all(r.status == "PASS" for r in profile.values()), [(c, r.reason) for c, r in profile.items()]
        static_errors = [(r.check_id, r.reason) for r in results if r.is_error and r.check_id.startswith("static.")]
        assert static_errors == [], fmu


@needs_fmucheck
def test_our_fmus_agree_with_the_compliance_checker(fmu_files, tmp_path):
    for name, fmu in fmu_files.items():
        rc, log, checker_csv = fmucheck(Path(fmu), tmp_path)
        if rc != 0 and _instantiate_failed(log):
            pytest.skip(f"{name}: fmi2Instantiate fails in the Compliance Checker (the pythonfmu binary needs "
                        f"libpython's symbols loaded globally; see ../shared/hosts/README.md): {log.strip()[-160:]}")
        assert rc == 0 and not checker_flags(rc, log), log[-800:]
        res = write_reference_results(fmu, tmp_path / "kit")
        assert res.status == "PASS", res.reason
        worst, n = max_difference(tmp_path / "kit" / name / f"{name}_ref.csv", checker_csv)  # modelName = name
        assert worst <= 1e-9, f"{name}: kit and checker differ by {worst:g} (relative, over {n} rows)"
