"""spurdiff bench: the measuring functions on short runs, and the report's arithmetic on given
numbers (the bench's ratios are printed, never asserted against wall-clock targets)."""
import argparse
import math

import pytest

import harness.measure.bench.core as bench
import harness.measure.bench.report as report
from harness.measure.accuracy import load_grid


def test_effect_settings_are_the_accuracy_grids_paper_straight_fidelities():
    grid = [f["name"] for f in load_grid()["paper-straight"]["fidelities"]]
    assert list(bench.EFFECT_SETS) == grid
    assert all("mesh.preload" not in v and "name" not in v for v in bench.EFFECT_SETS.values())
    assert bench.EFFECT_SETS["contact, no pin friction"] == {"meshModel": "contact", "pinFriction": False}


def test_fidelity_cost_and_fmi_overhead_measure_real_runs():
    rows = bench.fidelity_cost("paper-straight", {"rigid": {"meshModel": "rigid"},
                                                   "contact": {"meshModel": "contact"}}, repeats=1)
    assert [r["level"] for r in rows] == ["rigid", "contact"] and all(r["ok"] for r in rows)
    assert rows[0]["relative"] == 1.0 and rows[1]["wall_s"] > 0 and math.isfinite(rows[1]["realtime_factor"])
    o = bench.fmi_overhead("paper-cornering", duration=0.05, repeats=1)
    assert o["fmi_s"] > 0 and o["direct_s"] > 0 and o["ratio"] == o["fmi_s"] / o["direct_s"]
    assert o["step"] == 1e-3 and o["instances"] == 1


def test_fmi_call_cost_measures_each_fmu_through_the_c_path():
    c = bench.fmi_call_cost("paper-cornering", calls=50)
    row = c["per_fmu"]["SpurDifferential"]
    assert set(row) == {"fmi2GetReal", "fmi2SetReal", "refused"}
    assert all(us > 0.0 and math.isfinite(us) for us, _ in row.values())
    assert row["fmi2GetReal"][1] == 4 and 1 <= row["fmi2SetReal"][1] <= 4


def test_fmi_path_cost_runs_both_loops_without_the_physics_and_restores_the_models():
    from spurdiff.vehicle.car import Vehicle

    step = Vehicle.do_step
    c = bench.fmi_path_cost("vehicle-cornering", repeats=1)
    assert Vehicle.do_step is step                      # the models step again afterwards
    # (no order asserted between the two measured times: a wall-clock comparison; the bench prints it)
    assert 0.0 < c["direct_us"] < 1000.0 and 0.0 < c["fmi_us"] < 1000.0 and c["instances"] == 4
    assert c["per_instance_us"] == pytest.approx((c["fmi_us"] - c["direct_us"]) / 4)
    assert 1.0 <= c["setreal_calls_per_step"] <= 8.0   # the connections' inputs change every step


def test_recording_cost_compares_runs_recording_every_step_and_once():
    r = bench.recording_cost("paper-cornering", repeats=1)
    assert r["recorded"] > 0 and r["every"] >= 1
    assert math.isfinite(r["fmi_us"]) and math.isfinite(r["direct_us"])


def test_step_control_comparison_measures_real_runs(monkeypatch):
    """The fixed and variable runs of section 5, on a 0.3 s tip-in-tip-out, and the comparison at equal error."""
    from dataclasses import replace

    real = bench.prepare_scene
    monkeypatch.setattr(bench, "prepare_scene", lambda name, **k: replace(real(name, **k), duration=0.3))
    rows = bench.step_control_comparison("tip-in-tip-out", repeats=1)
    nf = 1 + len(bench.FIXED_STEPS)
    assert [r["run"][:5] for r in rows] == ["fixed"] * nf + ["varia"] * 3 and all(r["ok"] for r in rows)
    assert [r["steps"] for r in rows[:nf]] == [60, 75, 120, 150, 240, 300]
    assert all(math.isfinite(r["err_ratio"]) and r["err_lock"] >= 0.0 for r in rows)
    assert rows[-1]["run"].endswith("no redo)") and rows[-1]["rejected"] == 0
    for r in rows[nf:]:   # each variable run against the cheapest fixed run at its error, if any
        ok = [f for f in rows[:nf] if f["err_ratio"] <= r["err_ratio"] and f["err_lock"] <= r["err_lock"]]
        if r["fixed_over"] is None:
            assert not ok
        else:
            f = next(f for f in rows[:nf] if f["run"] == r["fixed_over"])
            assert f["wall_s"] == min(g["wall_s"] for g in ok)
            assert f["err_ratio"] <= r["err_ratio"] and f["err_lock"] <= r["err_lock"]
            assert r["cost_ratio"] == r["wall_s"] / f["wall_s"]


def test_report_derives_per_step_costs_and_targets_from_the_measurements(monkeypatch, capsys):
    monkeypatch.setattr(report, "fmi_overhead", lambda *a, **k: {
        "scene": "vehicle-cornering", "simulated_s": 3.0, "fmi_s": 3.0, "direct_s": 1.5, "ratio": 2.0,
        "step": 2e-4, "instances": 4})
    seen = {}
    monkeypatch.setattr(report, "fidelity_cost", lambda scene, sets, *a, **k: seen.setdefault("sets", sets) and [
        {"level": "rigid", "wall_s": 0.01, "relative": 1.0, "realtime_factor": 30.0, "ok": True},
        {"level": "contact", "wall_s": 0.1, "relative": 10.0, "realtime_factor": 3.0, "ok": True}])
    monkeypatch.setattr(report, "realtime_factors", lambda *a, **k: [
        {"scene": "vehicle-cornering", "simulated_s": 3.0, "wall_s": 1.5, "realtime_factor": 2.0,
         "fidelity": "meshModel=rigid", "ok": True}])
    monkeypatch.setattr(report, "fmi_call_cost", lambda *a, **k: {"per_fmu": {
        "Vehicle": {"fmi2GetReal": (2.0, 4), "fmi2SetReal": (3.0, 2), "refused": (1.0, 4)},
        "WheelLoad": {"fmi2GetReal": (4.0, 4), "fmi2SetReal": (5.0, 4), "refused": (1.0, 4)}}})
    monkeypatch.setattr(report, "fmi_path_cost", lambda *a, **k: {
        "fmi_us": 50.0, "direct_us": 30.0, "instances": 4, "per_instance_us": 5.0, "setreal_calls_per_step": 4.0})
    monkeypatch.setattr(report, "recording_cost", lambda *a, **k: {"fmi_us": 30.0, "direct_us": 2.0, "recorded": 22,
                                                                    "every": 1})
    monkeypatch.setattr(report, "step_control_comparison", lambda *a, **k: [
        {"run": "fixed 5 ms (scene default)", "wall_s": 0.5, "steps": 700, "rejected": 0, "ok": True,
         "err_ratio": 1e-3, "err_lock": 7.0},
        {"run": "variable (rtol 0.001, atol 0.001 J)", "wall_s": 4.0, "steps": 3900, "rejected": 99, "ok": True,
         "err_ratio": 6e-4, "err_lock": 2.9, "fixed_over": None, "cost_ratio": None},
        {"run": "variable (rtol 0.01, atol 0.01 J, no redo)", "wall_s": 1.0, "steps": 600, "rejected": 0, "ok": True,
         "err_ratio": 2e-3, "err_lock": 8.0, "fixed_over": "fixed 5 ms (scene default)", "cost_ratio": 2.0}])
    monkeypatch.setattr(report, "process_report", lambda *a, **k: ["   one round trip (getReal's difference): 1.5 us"])
    assert report._report(argparse.Namespace(levels=None, repeats=1)) == 0
    out = capsys.readouterr().out
    assert "7. The model in its own process" in out and "one round trip (getReal's difference): 1.5 us" in out
    assert set(seen["sets"]) == set(bench.EFFECT_SETS)   # the fidelity settings reach section 2
    # 15000 steps: 200 us (FMI) and 100 us (direct) per step, 25 us per instance and step
    assert "FMI 200 us, direct 100 us." in out and "leaves 2 us per step" in out   # 100x at 0.2 ms
    # the same runs with the native steps off (the mock answers alike): the ratio of the two FMI runs
    assert "(solver.nativeStep = false on car, diff, wheelL, wheelR), wall medians: FMI 200 us, direct 100 us" in out
    assert "the native steps make the FMI run 1.00x as fast" in out
    assert "Vehicle getReal(4) 2.0, setReal(2) 3.0, refused 1.0" in out
    # without the physics 5 us per instance and step, the mean get call 3 us (1 us of it ctypes); the real
    # run's 4 set calls per step at 4 us add 4 us per instance: 9 us, against the 25 us of the whole runs
    assert "FMI 50.0 us, direct 30.0 us per step, so 5.0 us per instance and step" in out
    assert "the step's getReal (3.0 us, 1.0 us of it the host's ctypes call)" in out
    assert "4.0 setReal calls per step (4.0 us each" in out
    assert ("add 4.0 us per instance: 9.0 us per instance and step for a model stepped in Python, against 25.0 us "
            "measured above in wall time with every step in Python.") in out
    assert "Recording the scene's 22 variables every 1 step(s) costs the FMI run 30 us per step" in out
    # 1.25 allows a quarter of the direct run's 100 us per step over 4 instances
    assert "the FMI path at most 6 us per instance and step" in out
    lines = {ln.split("  ")[0]: ln for ln in out.splitlines()}
    assert lines["coupled / direct run, vehicle-cornering (step 0.2 ms)"].rstrip().endswith("NO")
    assert "variable (rtol 0.001, atol 0.001 J)" in lines and lines["variable (rtol 0.001, atol 0.001 J)"].split()[-6] == "3900"
    assert lines["variable (rtol 0.01, atol 0.01 J, no redo)"].split()[-5:] == ["5", "ms", "(scene", "default)", "2.00"]
    assert "the variable step wins (no fixed run reaches its error for less): variable (rtol 0.001, atol 0.001 J)" in out
    assert lines["real-time factor, paper-straight at contact (unloaded start)"].rstrip().endswith("yes")


def test_step_cost_breakdown_splits_each_instance_and_the_differentials_inner_model(monkeypatch):
    from spurdiff.differential import shaft_kernel

    from harness.measure.bench.core import python_step_sets

    names = {"car", "diff", "wheelL", "wheelR"}
    sets = python_step_sets("vehicle-cornering")
    assert sets == [f"{n}.solver.nativeStep=false" for n in ("car", "diff", "wheelL", "wheelR")]
    native = bench.step_cost_breakdown("vehicle-cornering", repeats=1)
    assert set(native["us_per_step"]) == names and not native["model_us"]   # every instance steps in C
    b = bench.step_cost_breakdown("vehicle-cornering", repeats=1, sets=sets)
    assert set(b["us_per_step"]) == names and set(b["model_us"]) == names
    for name in names:   # the model's do_step is a part of the instance's step
        assert 0.0 < b["model_us"][name] <= b["us_per_step"][name]
    assert "diff" not in b["inner_us"]           # the compiled step with the shafts steps its inner model in C
    evals, substeps, _ = b["evals_per_step"]["diff"]
    assert substeps >= 1.0 and evals >= 2.0 * substeps   # at least a first evaluation and one correction
    # the half-shaft step in Python: its inner model's steps and state copies are measured
    monkeypatch.setattr(shaft_kernel, "choose", lambda model: (None, "python (test)"))
    b = bench.step_cost_breakdown("vehicle-cornering", repeats=1)
    step_us, state_us = b["inner_us"]["diff"]
    assert step_us > 0.0 and state_us > 0.0 and step_us + state_us < b["model_us"]["diff"]
    assert b["evals_per_step"]["diff"][:2] == (evals, substeps)      # the same solve either way


def test_write_keeps_the_sections_after_the_generated_block(monkeypatch, tmp_path):
    page = tmp_path / "performance.md"
    page.write_text("# Performance\n\n```\nold numbers\n```\n\n## Kept section\n\ntext by hand\n")
    monkeypatch.setattr(report, "_report", lambda args: print("new numbers") or 0)
    from harness.cli.bench import main as bench_main
    assert bench_main(["--write", str(page)]) == 0
    text = page.read_text()
    assert "new numbers" in text and "old numbers" not in text
    assert text.endswith("```\n\n## Kept section\n\ntext by hand\n")


def test_round_trips_measure_the_same_fmu_in_this_process_and_in_its_own(fmu_files):
    from harness.measure.bench.process import MODES, round_trips

    r = round_trips(n=50)
    for mode in MODES:
        assert r[mode]["getReal"] > 0 and r[mode]["set+doStep+get"] > 0
    # (no order between the times asserted: a wall-clock comparison is the machine's noise, and with every step
    # in the model's process set + doStep + get is one round trip, as a get is; the bench prints the ratios)
    assert r["overhead"]["getReal"] == r["out"]["getReal"] - r["in"]["getReal"]
    assert r["overhead_model"]["set+doStep+get"] == r["out-model"]["set+doStep+get"] - r["in"]["set+doStep+get"]


def test_an_unknown_process_mode_is_refused_naming_the_allowed_ones():
    from harness.measure.bench.process import model_process

    with pytest.raises(ValueError, match="mode 'own'; allowed: in, out, out-model"):
        model_process("own")


def test_the_out_mode_really_starts_the_models_own_process(fmu_files):
    import os
    from pathlib import Path

    from harness.measure.bench.process import model_process
    from harness.fmi.instance import Instance

    def children():
        return {int(x) for t in Path(f"/proc/{os.getpid()}/task").iterdir() for x in (t / "children").read_text().split()}

    before = children()
    with model_process("out"):
        inst = Instance("probe", fmu_files["SpurDifferential"])
    try:
        inst.slave.setupExperiment(startTime=0.0)
        inst.slave.enterInitializationMode()
        inst.slave.exitInitializationMode()
        new = children() - before
        assert len(new) == 1 and "spurdiff_fmu_server" in Path(f"/proc/{new.pop()}/cmdline").read_text()
    finally:
        inst.close()
    assert os.environ.get("SPURDIFF_FMU_PROCESS") != "out"   # the block restored the environment


def test_vehicle_kernel_bench_measures_both_implementations_of_car_and_wheels(monkeypatch):
    """harness.measure.bench.vehicle_kernel: the per-part breakdown with the car, the wheels and the
    differential in Python, with all but the differential's half-shaft step compiled, and all
    compiled (the scene's solver.kernel overrides reach step_cost_breakdown)."""
    import harness.measure.bench.vehicle_kernel as vk
    from spurdiff.differential import shaft_kernel

    seen, orig = [], bench.step_cost_breakdown

    def once(name, repeats, sets=None):
        seen.append((sets, shaft_kernel.choose.__name__))
        return orig(name, 1, sets=sets)

    monkeypatch.setattr(vk, "step_cost_breakdown", once)
    best = vk.part_costs(1)
    assert seen == [(vk.sets_for("python"), "choose"), (vk.sets_for("compiled"), "<lambda>"),
                    (vk.sets_for("compiled"), "choose"), (vk.sets_for("native"), "choose")]
    assert shaft_kernel.choose.__name__ == "choose"
    assert vk.sets_for("python") == ["car.solver.kernel=python", "wheelL.solver.kernel=python",
                                     "wheelR.solver.kernel=python", "diff.solver.kernel=python",
                                     "car.solver.nativeStep=false", "wheelL.solver.nativeStep=false",
                                     "wheelR.solver.nativeStep=false", "diff.solver.nativeStep=false"]
    assert vk.sets_for("native")[-4:] == ["car.solver.nativeStep=true", "wheelL.solver.nativeStep=true",
                                          "wheelR.solver.nativeStep=true", "diff.solver.nativeStep=true"]
    for k in vk.CONFIGS:
        assert {"car", "diff", "wheelL", "wheelR"} <= set(best[k])
        assert ("car do_step" in best[k]) == ("diff do_step" in best[k]) == (k != "native")   # natively: none
        assert all(v > 0.0 for v in best[k].values())
    # the differential's inner model is stepped from Python unless its step with the shafts is compiled
    assert "diff inner steps" in best["shafts python"] and "diff inner steps" not in best["compiled"]
    with pytest.raises(Exception, match="solver.kernel"):
        orig("vehicle-cornering", 1, sets=["car.solver.kernel=fortran"])


def test_solver_timings_take_the_fastest_of_many_short_runs_and_one_slow_run():
    from harness.measure.bench.mesh_ivp import best_of, more_runs

    assert more_runs([])                                  # at least five
    assert more_runs([0.001] * 4)
    assert more_runs([0.001] * 249) and not more_runs([0.001] * 250)   # a millisecond: 250 runs (0.25 s)
    assert not more_runs([0.05] * 5)                      # 50 ms: five (0.25 s spent)
    assert not more_runs([0.6])                           # over 0.5 s: one
    assert not more_runs([1e-6] * 1000)                   # at most 1000
    calls = []
    res, t = best_of(lambda: calls.append(1) or len(calls))
    assert res == len(calls) == 1000 and 0.0 <= t < 0.01  # CPU time of this thread, the fastest
