"""`spurdiff bench` (= `python -m harness bench`): measured cost ratios, printed, never asserted.

Each comparison runs A and B alternately in the same process, several times, and reports the
ratio of the medians of the stepping wall time (setup excluded), so machine noise hits both:

1. FMI-coupled run versus the same physics called directly in Python (:mod:`harness.direct`);
2. cost of each differential fidelity level relative to the rigid model (paper-straight);
3. real-time factor of each scene at its default fidelity.
"""
from __future__ import annotations

import statistics
import sys
import time
from dataclasses import replace

from harness.direct import run_direct
from harness.master import run_scene
from harness.runner import fmu_files_for, prepare_scene
from harness.scene import available, load_scene


def _median_wall(fn, repeats: int) -> tuple[float, object]:
    walls, last = [], None
    for _ in range(repeats):
        last = fn()
        walls.append(last.wall_time)
    return statistics.median(walls), last


def fmi_overhead(scene_name: str, duration: float | None = None, repeats: int = 5) -> dict:
    """Median stepping time through FMI and directly, interleaved; ratio FMI / direct."""
    scene = prepare_scene(scene_name, duration=duration)
    files = fmu_files_for(scene)
    run_scene(scene, files)  # warm-up: first instantiation imports the model's modules
    fmi, direct = [], []
    for _ in range(repeats):
        fmi.append(run_scene(scene, files).wall_time)
        direct.append(run_direct(scene).wall_time)
    f, d = statistics.median(fmi), statistics.median(direct)
    return {"scene": scene_name, "simulated_s": scene.duration, "fmi_s": f, "direct_s": d, "ratio": f / d}


def fidelity_cost(scene_name: str = "paper-straight", levels=("rigid",), repeats: int = 3) -> list[dict]:
    rows = []
    base = None
    for level in levels:
        scene = prepare_scene(scene_name, mesh=level)
        files = fmu_files_for(scene)
        run_scene(scene, files)
        wall, res = _median_wall(lambda: run_scene(scene, files), repeats)
        if base is None:
            base = wall
        rows.append({"level": level, "wall_s": wall, "relative": wall / base,
                     "realtime_factor": scene.duration / wall if wall > 0 else float("inf"), "ok": res.ok})
    return rows


def realtime_factors(repeats: int = 3) -> list[dict]:
    rows = []
    for name in available():
        scene = load_scene(name)
        files = fmu_files_for(scene)
        run_scene(scene, files)
        wall, res = _median_wall(lambda: run_scene(scene, files), repeats)
        rows.append({"scene": name, "simulated_s": scene.duration, "wall_s": wall,
                     "realtime_factor": scene.duration / wall if wall > 0 else float("inf"),
                     "fidelity": ", ".join(f"{k}={v}" for k, v in scene.effects.items()), "ok": res.ok})
    return rows


def main(argv: list[str] | None = None) -> int:
    import argparse

    from harness.report import render

    ap = argparse.ArgumentParser(prog="spurdiff bench", description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--levels", nargs="*", default=None, help="mesh levels to compare (default: all available)")
    args = ap.parse_args(argv)
    from spurdiff.differential_fmu import MESH_MODELS
    levels = args.levels or list(MESH_MODELS)
    t0 = time.perf_counter()
    print(f"spurdiff bench (medians of {args.repeats} interleaved runs, stepping time only)\n")
    o = fmi_overhead("vehicle-cornering" if "vehicle-cornering" in available() else "paper-cornering",
                     repeats=args.repeats)
    print("1. FMI-coupled versus direct physics, same scene and loop")
    print(render(["scene", "simulated s", "FMI s", "direct s", "FMI / direct"],
                 [[o["scene"], f"{o['simulated_s']:g}", f"{o['fmi_s']:.4f}", f"{o['direct_s']:.4f}",
                   f"{o['ratio']:.2f}"]]))
    print("\n2. Cost of each mesh level relative to rigid (paper-straight, 0.3 s)")
    rows = fidelity_cost("paper-straight", levels, max(3, args.repeats // 2))
    print(render(["level", "wall s", "relative to rigid", "real-time factor"],
                 [[r["level"], f"{r['wall_s']:.4f}", f"{r['relative']:.1f}", f"{r['realtime_factor']:.1f}"]
                  for r in rows]))
    print("\n3. Real-time factor of each scene at its default fidelity")
    rows = realtime_factors(max(3, args.repeats // 2))
    print(render(["scene", "simulated s", "wall s", "real-time factor", "fidelity"],
                 [[r["scene"], f"{r['simulated_s']:g}", f"{r['wall_s']:.3f}", f"{r['realtime_factor']:.1f}",
                   r["fidelity"]] for r in rows]))
    print(f"\n(bench took {time.perf_counter() - t0:.1f} s on {sys.platform}, python {sys.version.split()[0]})")
    return 0
