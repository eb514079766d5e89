"""Issue 43 items 2 and 3: ``spurdiff check --cross-check DIR`` and ``--compare`` judge by the FMI cross-check
suite's rule (harness/check/crosscheck/band.py), and agree with the suite's own validation (fmpy.cross_check.validate_result,
the code that checks results submitted to modelica/fmi-cross-check) sample for sample.

The shared cross-check FMUs (../shared/xcheck/) are used where that folder exists; the tests skip, naming it,
where it does not.
"""
from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from harness.check.crosscheck.band import judge, printed_rounding
from harness.check.crosscheck.compare import suite_checks
from harness.check.crosscheck.formats import read_cross_check_csv, write_cross_check_csv, write_ref_opt
from harness.cli.check import main

XCHECK = Path(__file__).resolve().parents[4] / "shared" / "xcheck"
FMUS = XCHECK / "fmus" / "2.0" / "cs" / "linux64"
needs_xcheck = pytest.mark.skipif(not FMUS.is_dir(), reason=f"{FMUS} (the shared cross-check FMUs) is absent")


def _suite(names, rows, ref_names, ref_rows, t_start, t_stop):
    """The suite's own verdict (None: passed) on the same data."""
    from fmpy.cross_check import validate_result

    def structured(n, r):
        return np.array([tuple(x) for x in r], dtype=[(c, np.float64) for c in n])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # scipy.ndimage.filters is deprecated
        return validate_result(structured(names, rows), structured(ref_names, ref_rows), t_start, t_stop)


def test_the_band_agrees_with_the_suites_own_validation_on_random_signals():
    rng = np.random.default_rng(43)
    t_ref = np.linspace(0.0, 10.0, 201)
    disagree, passed = [], 0
    for case in range(300):
        kind = case % 3
        y_ref = (np.sin(t_ref * rng.uniform(0.2, 3)) * rng.uniform(0.1, 100) if kind == 0 else
                 np.floor(t_ref * rng.uniform(0.3, 2)) if kind == 1 else np.full_like(t_ref, rng.choice([0.0, 5.0])))
        n = int(rng.integers(50, 400))
        t = np.linspace(0.0, 10.0, n)
        y = np.interp(t, t_ref, y_ref) + rng.normal(0, rng.choice([0.0, 0.01, 0.05, 0.2]), n) * (np.ptp(y_ref) or 1)
        shift = rng.choice([0.0, 0.05, 0.3])           # a signal late by up to 3 % of the span
        y = np.interp(t - shift, t_ref, y_ref) if shift and rng.random() < 0.5 else y
        ours = judge(["time", "y"], np.c_[t, y], ["time", "y"], np.c_[t_ref, y_ref], 0.0, 10.0)
        suite = _suite(["time", "y"], np.c_[t, y], ["time", "y"], np.c_[t_ref, y_ref], 0.0, 10.0)
        passed += ours.passed
        if ours.passed != (suite is None):
            disagree.append((case, ours.reason, suite))
    assert not disagree, disagree[:3]
    assert 50 < passed < 250   # both verdicts are exercised


def test_stop_time_columns_and_sample_count_as_the_suite_says():
    ref = (["time", "x"], [[0.0, 0.0], [1.0, 1.0]])
    ok = judge(["time", "x"], [[0.0, 0.0], [0.5, 0.5], [1.0, 1.0]], *ref, 0.0, 1.0)
    assert ok.passed
    short = judge(["time", "x"], [[0.0, 0.0], [0.5, 0.5]], *ref, 0.0, 1.0)
    assert not short.passed and "before the stop time 1 s" in short.reason
    assert "at least 2" in judge(["time", "x"], [[0.0, 0.0]], *ref, 0.0, 1.0).reason
    missing = judge(["time", "z"], [[0.0, 0.0], [1.0, 1.0]], *ref, 0.0, 1.0)
    assert not missing.passed and "missing from the result: x" in missing.reason
    assert _suite(["time", "x"], [[0.0, 0.0], [0.5, 0.5]], *ref, 0.0, 1.0) is not None


def test_the_references_rounded_last_time_is_reached(tmp_path):
    """TorsionBar: StopTime 12.5663706143592 s in _ref.opt, the reference's last row printed as 12.5664."""
    ref = write_cross_check_csv(tmp_path / "M_ref.csv", ["time", "x"], [[0.0, 0.0], [12.5664, 1.0]])
    res = write_cross_check_csv(tmp_path / "res.csv", ["time", "x"],
                                [[0.0, 0.0], [6.28, 0.5], [12.5663706143592, 1.0]])
    checks = {c.check_id: c for c in suite_checks(res, ref)}          # no _ref.opt: the printed rounding
    assert checks["compare.run"].status == "PASS" and checks["compare.x"].status == "PASS"
    assert printed_rounding("12.5664") == pytest.approx(5e-5) and printed_rounding("20") == 0.5
    write_ref_opt(tmp_path / "M_ref.opt", 0.0, 12.5663706143592, 0.1, 1e-4)   # with it: StopTime itself
    assert all(c.status == "PASS" for c in suite_checks(res, ref))
    early = write_cross_check_csv(tmp_path / "early.csv", ["time", "x"], [[0.0, 0.0], [12.5, 1.0]])
    run = suite_checks(early, ref)[0]
    assert run.check_id == "compare.run" and run.status == "FAIL" and "before the stop time" in run.reason


def test_a_counter_one_sample_early_at_an_event_passes_and_true_false_cells_are_read(tmp_path):
    """Stair: the reference repeats the event time (value before, then after); a result that counts one
    sample early lies in the band (10 points either side); Boolean cells written True/False read as 1/0."""
    ref_rows = [[0.0, 1, 0]]
    for k in range(1, 11):   # the counter steps at every second, the flag once, at 5 s
        ref_rows += [[float(k), k, int(k > 5)], [float(k), k + 1, int(k >= 5)]]
    ref = write_cross_check_csv(tmp_path / "S_ref.csv", ["time", "counter", "flag"], ref_rows)
    write_ref_opt(tmp_path / "S_ref.opt", 0.0, 10.0, 0.0, 1e-5)
    lines = ['"time","counter","flag"']
    for i in range(101):
        t = i * 0.1
        k = int(np.floor(t + 0.1 + 1e-9))            # one sample early
        lines.append(f"{t!r},{min(k, 11)},{'True' if k >= 5 else 'False'}")
    res = tmp_path / "S_out.csv"
    res.write_text("\n".join(lines) + "\n")
    names, rows = read_cross_check_csv(res)
    assert rows[1][2] in (0.0, 1.0)
    checks = suite_checks(res, ref)
    assert [c.status for c in checks] == ["PASS"] * 3, [c.reason for c in checks]
    assert main(["--compare", str(res), "--reference", str(ref)]) == 0


def _layout(root: Path, models: list[str]) -> Path:
    for m in models:
        src = next(FMUS.glob(f"*/*/{m}"))
        dest = root / "fmus" / "2.0" / "cs" / "linux64" / src.parent.parent.name / src.parent.name / m
        shutil.copytree(src, dest)
    return root


@needs_xcheck
def test_cross_check_files_verdicts_in_the_suites_layout(tmp_path, capsys):
    root = _layout(tmp_path / "xc", ["Dahlquist", "Stair", "fuelrail_cs"])
    # a model whose result cannot pass: Dahlquist's reference scaled by 3
    dq = next(root.rglob("Dahlquist_ref.csv"))
    names, rows = read_cross_check_csv(dq)
    write_cross_check_csv(dq, names, [[r[0], 3 * r[1]] for r in rows])
    out = tmp_path / "results"
    code = main(["--cross-check", str(root), "--results", str(out), "--jobs", "2", "--isolated"])
    text = capsys.readouterr().out
    assert code == 1                                             # a verdict "failed"
    assert "| Test-FMUs 0.0.1 | Stair | passed | passed |" in text
    assert "| Test-FMUs 0.0.1 | Dahlquist | failed | failed |" in text
    assert "| AMESim 15 | fuelrail_cs | rejected | rejected | fmpy: no fuelrail_cs_ref.opt" in text
    import fmpy
    for importer, version in (("FMPy", fmpy.__version__), ("spurdiff", None)):
        base = out / "2.0" / "cs" / "linux64" / importer
        version = version or next(base.iterdir()).name
        stair = base / version / "Test-FMUs" / "0.0.1" / "Stair"
        assert sorted(p.name for p in stair.iterdir()) == ["README.txt", "Stair_out.csv", "passed"]
        assert "Reason:" in (stair / "README.txt").read_text()
        rejected = base / version / "AMESim" / "15" / "fuelrail_cs"
        assert sorted(p.name for p in rejected.iterdir()) == ["README.txt", "rejected"]
        # the suite's own validation gives the same verdicts on the filed result CSVs
        for model, verdict in (("Stair", "passed"), ("Dahlquist", "failed")):
            folder = base / version / "Test-FMUs" / "0.0.1" / model
            res_names, res_rows = read_cross_check_csv(folder / f"{model}_out.csv")
            ref_names, ref_rows = read_cross_check_csv(next(root.rglob(f"{model}_ref.csv")))
            assert (folder / verdict).is_file()
            assert (_suite(res_names, res_rows, ref_names, ref_rows, 0.0, 10.0) is None) == (verdict == "passed")
    # a second run into the same folder replaces the verdicts (no stale "failed" beside a "passed")
    write_cross_check_csv(dq, names, rows)
    main(["--cross-check", str(root), "--results", str(out), "--hosts", "spurdiff", "--isolated"])
    folder = next(out.rglob("spurdiff/*/Test-FMUs/0.0.1/Dahlquist"))
    assert (folder / "passed").is_file() and not (folder / "failed").exists()


def test_cross_check_usage_errors(tmp_path, capsys):
    assert main(["--cross-check", str(tmp_path / "nowhere")]) == 2
    assert main(["--cross-check", str(tmp_path)]) == 2                     # no FMU in the layout
    assert main(["--cross-check", str(tmp_path), "--hosts", "dymola"]) == 2
    err = capsys.readouterr().err
    assert "not a folder" in err and "no <Model>/<Model>.fmu" in err and "allowed fmpy, spurdiff" in err


# the verdicts on the whole shared folder; where the two hosts differ, or a verdict is not "passed", why
SHARED_VERDICTS = {
    "ControlledTemperature@20sim": ("rejected", "rejected"),      # no _ref.csv
    "Threetank": ("rejected", "rejected"),                        # reference columns are not FMU variables
    "TorsionBar": ("passed", "passed"),
    "fuelrail_cs": ("rejected", "rejected"),                      # no _ref.opt, no _ref.csv
    "uart": ("rejected", "rejected"),                             # no _ref.csv
    "CauerLowPassAnalog": ("rejected", "rejected"),               # libgfortran.so.3 (FMI 2.0 2.3)
    "ControlledTemperature@JModelica.org": ("rejected", "rejected"),
    "CoupledClutches": ("rejected", "rejected"),
    "PID_Controller": ("rejected", "rejected"),
    "FmuExportCrossCompile": ("passed", "passed"),
    "RoomHeating_OM_RH": ("passed", "passed"),
    "WaterTank_Control": ("passed", "passed"),
    "WaterTank_TestSingleWaterTank": ("passed", "passed"),
    "Dahlquist": ("passed", "passed"),
    "Feedthrough": ("failed", "failed"),   # the reference is real_continuous_out = u + 1 and bool_out = bool_in
    "Stair": ("passed", "passed"),
    "VanDerPol": ("failed", "passed"),     # fmpy's own step for "StepSize, 0" is 0.04 s; ours 0.01 s (2000 steps)
}


@needs_xcheck
def test_the_shared_cross_check_folder_gets_the_suites_verdicts(tmp_path, capsys):
    out = tmp_path / "results"
    main(["--cross-check", str(XCHECK), "--results", str(out), "--jobs", "2", "--isolated"])
    capsys.readouterr()
    got, judged = {}, 0
    for verdict_file in out.rglob("*"):
        if verdict_file.name not in ("passed", "failed", "rejected"):
            continue
        folder = verdict_file.parent
        model, tool, importer = folder.name, folder.parent.parent.name, folder.parents[3].name
        key = model if model != "ControlledTemperature" else f"{model}@{tool}"
        got.setdefault(key, {})[importer] = verdict_file.name
        if verdict_file.name != "rejected":   # the suite's own code on the very same files
            src = next(FMUS.glob(f"{tool}/*/{model}"))
            from harness.check.crosscheck.formats import read_ref_opt
            opt = read_ref_opt(src / f"{model}_ref.opt")
            res = read_cross_check_csv(folder / f"{model}_out.csv")
            ref = read_cross_check_csv(src / f"{model}_ref.csv")
            suite = _suite(*res, *ref, opt["StartTime"], opt["StopTime"])
            assert (suite is None) == (verdict_file.name == "passed"), (key, importer, suite)
            judged += 1
    assert {k: (v.get("FMPy"), v.get("spurdiff")) for k, v in got.items()} == SHARED_VERDICTS
    assert judged == 18


@needs_xcheck
def test_reference_results_follow_the_ref_opt_beside_the_fmu_and_stand_beside_its_reference(tmp_path, capsys):
    from harness.check.crosscheck.formats import read_ref_opt
    src = next(FMUS.glob("*/*/TorsionBar"))
    folder = tmp_path / "TorsionBar"
    shutil.copytree(src, folder)
    fmu = folder / "TorsionBar.fmu"
    assert main(["--reference-results", str(tmp_path / "refs"), str(fmu), "--isolated"]) == 0
    ours = tmp_path / "refs" / "TorsionBar"
    opt, theirs = read_ref_opt(ours / "TorsionBar_ref.opt"), read_ref_opt(folder / "TorsionBar_ref.opt")
    assert opt == theirs                                          # StopTime 12.5663706143592, StepSize 0.1
    assert read_cross_check_csv(ours / "TorsionBar_ref.csv")[0] == read_cross_check_csv(folder / "TorsionBar_ref.csv")[0]
    capsys.readouterr()
    assert main(["--compare", str(ours / "TorsionBar_ref.csv"), "--reference", str(folder / "TorsionBar_ref.csv")]) == 0
    assert "from TorsionBar_ref.opt" in capsys.readouterr().out
    # it will not write over the files it reads
    assert main(["--reference-results", str(tmp_path), str(fmu), "--isolated"]) == 2
    assert (folder / "TorsionBar_ref.csv").read_bytes() == (src / "TorsionBar_ref.csv").read_bytes()
