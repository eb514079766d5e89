"""Measuring one scene over its accuracy grid: every point run through the FMUs and compared with
the reference run (the finest step and tolerance at the highest fidelity) on the scene's own
metrics; the reference's convergence from its run one refinement coarser."""
from __future__ import annotations

import math
import statistics
import time
from dataclasses import replace

from harness.measure.accuracy.data import STATS, Point
from harness.run.master import Result, run_scene
from harness.run.metrics import metric_scales, relative_errors
from harness.run.report import stat
from harness.run.runner import fmu_files_for, prepare_scene
from harness.scene.spec import Scene, SceneError


def metrics_of(scene: Scene) -> list[tuple[str, list | None]]:
    """Quantities whose mean/max/min are compared, with their windows: the rows of the scene's
    results table (torques, forces, speeds ... over the window the scene reports them in). The
    checks are left out: many are residuals (a kinematic constraint that is zero to round-off),
    whose relative error says nothing about accuracy; so are rows marked ``accuracy = false``
    (flags: when a 0/1 flag first shows depends on the communication step, not on accuracy)."""
    return list(dict.fromkeys((row["var"], tuple(row["window"]) if row.get("window") else None)
                              for row in scene.table if row.get("accuracy", True)))


def metric_values(result: Result, quantities, window=None) -> dict[str, float]:
    out = {}
    for q in quantities:
        q, w = q if isinstance(q, tuple) else (q, window)
        for k in STATS:
            out[f"{k}({q})"] = stat(result, q, k, list(w) if w else None)
    return out


def configure(scene_name: str, fid: dict, step: float, tolerance: float | None, duration: float | None) -> Scene:
    scene = prepare_scene(scene_name, step=step, duration=duration)
    effects = {**scene.effects, **fid}
    if tolerance is not None:
        effects["tolerance"] = tolerance
    return replace(scene, effects=effects, output_interval=max(step, scene.output_interval))


def run_point(scene: Scene, repeats: int, budget: float = math.inf) -> tuple[Result, float]:
    """Median stepping time of up to ``repeats`` runs; repeating stops once the runs so far took
    ``budget`` seconds (a run of tens of seconds varies by far less than a run of milliseconds)."""
    files = fmu_files_for(scene, build_missing=False)   # built once, in measure_scene
    walls, res = [], None
    for _ in range(repeats):
        res = run_scene(scene, files)
        if not res.ok:
            break
        walls.append(res.wall_time)
        if sum(walls) >= budget:
            break
    return res, (statistics.median(walls) if walls else math.nan)


def measure_scene(name: str, spec: dict, quick: bool = False, log=print) -> tuple[list[Point], dict]:
    """Run the grid of one scene; returns the points and facts about the reference."""
    sub = spec.get("quick", {}) if quick else {}
    fidelities = sub.get("fidelities", spec["fidelities"])
    steps = sub.get("steps", spec["steps"])
    tols = sub.get("tolerances", spec.get("tolerances", [None]))
    duration = sub.get("duration", spec.get("duration"))
    repeats = sub.get("repeats", spec.get("repeats", 3))
    budget = float(spec.get("repeat_budget", math.inf))
    ref_spec = sub.get("reference", spec["reference"])
    ref_fid = ref_spec["fidelity"]
    fid_by_name = {f["name"]: {k: v for k, v in f.items() if k != "name"} for f in fidelities}
    if ref_fid not in fid_by_name:
        raise SceneError(f"accuracy grid for {name}: reference fidelity {ref_fid!r} is not in its fidelities")
    ref_scene = configure(name, fid_by_name[ref_fid], ref_spec["step"], ref_spec.get("tolerance"), duration)
    quantities = metrics_of(ref_scene)
    fmu_files_for(ref_scene)   # build what is missing once: every point runs the same FMUs
    t0 = time.perf_counter()
    ref_res, ref_wall = run_point(ref_scene, 1)
    if not ref_res.ok:
        raise SceneError(f"{name}: the reference run failed: {ref_res.failure}")
    ref = metric_values(ref_res, quantities)
    scales = metric_scales(ref)
    # convergence of the reference: the same fidelity one refinement coarser
    check_scene = configure(name, fid_by_name[ref_fid], ref_spec.get("check_step", ref_spec["step"] * 2),
                            ref_spec.get("check_tolerance", ref_spec.get("tolerance")), duration)
    chk_res, _ = run_point(check_scene, 1)
    conv_metrics = relative_errors(metric_values(chk_res, quantities), ref, scales) if chk_res.ok else {}
    conv = max(conv_metrics.values()) if conv_metrics else math.inf
    log(f"{name}: reference {ref_fid}, step {ref_spec['step']:g} s, tolerance {ref_spec.get('tolerance')}: "
        f"{ref_res.wall_time:.2f} s; next-coarser differs by {conv:.2e} (its convergence)")
    points = []
    for fname, fid in fid_by_name.items():
        for h in steps:
            for tol in (tols if fid.get("meshModel", "rigid") != "rigid" else [None]):
                sc = configure(name, fid, h, tol, duration)
                res, wall = run_point(sc, repeats, budget)
                p = Point(name, fname, fid, h, tol, wall)
                if res.ok:
                    errs = relative_errors(metric_values(res, quantities), ref, scales)
                    p.metric_errors = errs
                    p.error = max(errs.values()) if errs else 0.0
                else:
                    p.ok, p.reason = False, str(res.failure)
                points.append(p)
                log(f"  {fname:28s} step {h:8.0e} tol {str(tol):6s} wall {wall:8.4f} s  error {p.error:9.2e}"
                    + ("" if p.ok else f"  FAILED: {p.reason[:80]}"))
    facts = {"reference": ref_fid, "ref_step": ref_spec["step"], "ref_tolerance": ref_spec.get("tolerance"),
             "ref_wall": ref_res.wall_time, "convergence": conv, "elapsed": time.perf_counter() - t0,
             "duration": ref_scene.duration, "check_step": check_scene.step, "convergence_metrics": conv_metrics}
    return points, facts
