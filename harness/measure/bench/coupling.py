"""Issue 19 item 2: the vehicle scenes with the shaft-owning differential (``shaftCoupling = wheel``)
at 1, 5, 10 and 20 ms against the old coupling (the wheels own the half-shafts, every input held
over the step) at its stable 0.2 ms step. Prints one table: per scene and step the mean
outer/inner wheel-speed ratio's difference (absolute) and the mean locking torque's difference
(relative to the reference mean, and in N m), over the scene's window.

    SPURDIFF_FMU_DIR=/tmp/fmus_x python -m harness.cli.tools.coupling_bench [scene ...] [--steps 1e-3,5e-3] [--fresh]

The reference runs' means are cached in ./results/coupling_refs.json (keyed by scene and window;
``--cache PATH`` for another file); ``--fresh`` recomputes them (do so after changing the old
coupling's physics). Wall times are printed, never asserted.
"""
from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

from harness.common.paths import results_dir

# scene -> window (s) of the means: the scene's own results window (or its driven part)
WINDOWS = {
    "vehicle-cornering": (1.0, 3.0),
    "split-mu-launch": (1.0, 2.0),
    "wheel-lift": (1.1, 2.2),
    "standstill-launch": (0.5, 3.0),
    "tip-in-tip-out": (0.5, 3.5),
}
RATIO = "{wheelR.wheel.w} / {wheelL.wheel.w}"
LOCK = "diff.lockingTorque"


def torque_coupled(name: str, **changes) -> dict:
    """The scene's data with the old interface: the wheels own the half-shafts (flange angle and
    speed in, flange torque out), the differential gets the flange torques; every input held over
    the step (no FzRate / vxRate from the car, no speedTargetRate / pathRadiusRate): the reference
    of issue 19 as it was measured. ``changes`` replace top-level keys (step, duration ...)."""
    from harness.scene.spec import read_scene_data, within_run

    data = read_scene_data(name)
    for k in [k for k in data.get("inputs", {}) if k.endswith("Rate")]:
        del data["inputs"][k]
    for k in [k for k in data["connections"] if k.endswith(("FzRate", "vxRate"))]:
        del data["connections"][k]
    dp = data["fmus"]["diff"]["parameters"]
    dp.pop("shaftCoupling")
    for side, w in (("left", "wheelL"), ("right", "wheelR")):
        twist = dp.pop(f"{side}Shaft.phi_rel_start", 0.0)
        data["fmus"][w]["parameters"] = {"halfShaft.phi_rel_start": twist}
        con = data["connections"]
        for k in [k for k in con if k.startswith((f"diff.{side}Wheel.", f"{w}.shaftIn."))]:
            del con[k]
        con[f"diff.{side}.tau"] = f"{w}.flange.tau"
        con[f"{w}.flange.phi"] = f"diff.{side}.phi"
        con[f"{w}.flange.w"] = f"diff.{side}.w"
        for c in data["couplings"]:
            if c["torque"] == f"diff.{side}Shaft.tau":
                c["torque"] = f"{w}.shaft.tau"
    data.update(changes)
    within_run(data)   # a shortened run keeps only the windows it covers
    return data


def measures(result, window) -> dict[str, float]:
    """The means over ``window`` the table compares."""
    from harness.run.report import stat

    return {"ratio": stat(result, RATIO, "mean", list(window)), "lock": stat(result, LOCK, "mean", list(window)),
            "lock_absmean": stat(result, "abs({diff.lockingTorque})", "mean", list(window))}


def parse_steps(text: str) -> list[float]:
    """The steps of ``--steps`` (comma-separated seconds); ValueError naming the allowed range."""
    try:
        steps = [float(x) for x in text.split(",")]
    except ValueError:
        steps = []
    if not steps or not all(math.isfinite(h) and 0.0 < h <= 0.1 for h in steps):
        raise ValueError(f"--steps {text!r}: allowed a comma-separated list of steps in (0, 0.1] s")
    return steps


def run(scenes: list[str], steps: list[float], fresh: bool = False, cache_path: Path | None = None) -> int:
    """Measure and print the table (the command line: :mod:`harness.cli.tools.coupling_bench`); the exit
    code: 0, 1 if a reference run failed, 2 for a bad scene or step (one line on stderr)."""
    for s in scenes:
        if s not in WINDOWS:
            print(f"error: scene {s!r} not one of {', '.join(WINDOWS)}", file=sys.stderr)
            return 2
    from harness.build.fmu import FMUS, build
    from harness.run.master import run_scene
    from harness.run.runner import prepare_scene
    from harness.scene.spec import SceneError, parse_scene

    fmu_files = dict(zip(FMUS, build(list(FMUS), quiet=True)))
    cache_path = cache_path or results_dir("coupling_refs.json")
    try:
        cache = {} if fresh or not cache_path.exists() else json.loads(cache_path.read_text())
    except (OSError, ValueError) as e:
        print(f"error: --cache {cache_path}: not a readable JSON file ({e}); rerun with --fresh", file=sys.stderr)
        return 2
    rows = []
    for name in scenes:
        win = WINDOWS[name]
        key = f"{name} {win}"
        if key not in cache:
            t0 = time.perf_counter()
            r = run_scene(parse_scene(torque_coupled(name, step=2e-4)), fmu_files)
            if not r.ok:
                print(f"error: the reference run of {name} failed: {r.failure}", file=sys.stderr)
                return 1
            cache[key] = measures(r, win)
            cache_path.parent.mkdir(parents=True, exist_ok=True)
            cache_path.write_text(json.dumps(cache, indent=1))
            print(f"# reference {name}: old coupling, 0.2 ms, {time.perf_counter() - t0:.0f} s wall", flush=True)
        ref = cache[key]
        for h in steps:
            t0 = time.perf_counter()
            try:
                scene = prepare_scene(name, step=h)
            except SceneError as e:
                print(f"error: {e}", file=sys.stderr)
                return 2
            r = run_scene(scene, fmu_files)
            wall = time.perf_counter() - t0
            if not r.ok:
                rows.append((name, h, "failed", str(r.failure)[:60], "", "", wall))
                continue
            m = measures(r, win)
            dl = m["lock"] - ref["lock"]
            rel = abs(dl) / max(abs(ref["lock"]), 1e-12)
            rows.append((name, h, f"{abs(m['ratio'] - ref['ratio']):.2e}", f"{rel:.2e}", f"{abs(dl):.2e}",
                         f"{ref['lock']:.4g}", wall))
            print(f"# {name} {h * 1e3:g} ms done ({wall:.1f} s)", flush=True)
    print("\n| scene | step ms | window s | ratio diff (abs) | locking torque diff (rel) | (N m) "
          "| ref. locking torque N m | wall s |")
    print("|---|---|---|---|---|---|---|---|")
    for name, h, a, b, c, ref_lock, wall in rows:
        w0, w1 = WINDOWS[name]
        print(f"| {name} | {h * 1e3:g} | {w0:g}-{w1:g} | {a} | {b} | {c} | {ref_lock} | {wall:.1f} |")
    return 0
