"""What the rigid level's compiled kernel (:mod:`spurdiff.differential.rigid_kernel`) saves on
vehicle-cornering: A/B in one process, interleaved (``solver.kernel = python``, the reference,
against the compiled kernel), CPU time of the stepping thread, fastest of ``rounds`` runs each:

* the differential's cost per communication step in the direct run, split as
  :func:`harness.measure.bench.core.step_cost_breakdown` does (the inner rigid model's steps, per inner step);
* the whole scene through FMI and directly (:func:`harness.measure.bench.core.cpu_clock`): us per step and
  the real-time factor.

Run ``python -m harness.cli.tools.rigid_kernel_bench [--rounds N]`` (the command line is
harness/cli/tools/rigid_kernel_bench.py). Printed, never asserted.
"""
from __future__ import annotations

from harness.measure.bench.core import cpu_clock, step_cost_breakdown
from harness.build.fmu import rigid_kernel_library
from harness.run.direct import run_direct
from harness.run.master import run_scene
from harness.scene.recording import recording_size
from harness.run.runner import fmu_files_for, prepare_scene
from spurdiff.differential import rigid_kernel, shaft_kernel

KERNELS = ("python", "compiled")
SCENE = "vehicle-cornering"


def differential_step_cost(rounds: int) -> dict[str, list[float]]:
    """Per kernel: the fastest of ``rounds`` x 3 direct runs of (us per instance-step, do_step us,
    inner rigid steps us, inner steps per communication step). The python rounds replace the
    kernel choice (step_cost_breakdown runs the scene as it is)."""
    real_choose, shafts_choose = rigid_kernel.choose, shaft_kernel.choose
    parts = {k: [] for k in KERNELS}
    for _ in range(rounds):
        for k in KERNELS:
            rigid_kernel.choose = real_choose if k == "compiled" else (lambda m: (None, "python (A/B)"))
            # the half-shaft step in Python both ways (its compiled step, spurdiff.differential.shaft_kernel,
            # steps the rigid model in C: harness.measure.bench.vehicle_kernel measures it)
            shaft_kernel.choose = lambda m: (None, "python (A/B of the rigid kernel)")
            try:
                o = step_cost_breakdown(SCENE, 3)
            finally:
                rigid_kernel.choose, shaft_kernel.choose = real_choose, shafts_choose
            parts[k].append((o["us_per_step"]["diff"], o["model_us"]["diff"], o["inner_us"]["diff"][0],
                             o["evals_per_step"]["diff"][0]))
    return {k: [min(r[i] for r in parts[k]) for i in range(4)] for k in KERNELS}


def scene_cost(rounds: int) -> tuple[dict, float, int]:
    """Per (kernel, "FMI" | "direct"): the fastest of ``rounds`` interleaved whole-scene runs (CPU
    s), the kernel chosen by the FMU parameter; with the scene's duration and step count."""
    scenes = {k: prepare_scene(SCENE, sets=[f"diff.solver.kernel={k}"]) for k in KERNELS}
    files = fmu_files_for(scenes["compiled"])
    for s in scenes.values():      # warm-up: the first instantiation imports the models' modules
        run_scene(s, files)
        run_direct(s)
    walls = {(k, w): [] for k in KERNELS for w in ("FMI", "direct")}
    for _ in range(rounds):
        for k, s in scenes.items():
            with cpu_clock():
                walls[(k, "FMI")].append(run_scene(s, files).wall_time)
                walls[(k, "direct")].append(run_direct(s).wall_time)
    sc = scenes["compiled"]
    return {key: min(v) for key, v in walls.items()}, sc.duration, recording_size(sc)[0]


def run(rounds: int = 5) -> int:
    """Measure and print both parts."""
    rigid_kernel_library()
    best = differential_step_cost(rounds)
    print(f"{SCENE}, the differential per 5 ms communication step (us, CPU time, fastest of "
          f"{rounds} x 3 runs):")
    for k, b in best.items():
        print(f"  {k:8s}  instance {b[0]:6.1f}  do_step {b[1]:6.1f}  inner rigid steps {b[2]:5.1f} "
              f"({b[3]:.2f} per step, {b[2] / b[3]:.2f} each)")
    walls, duration, n = scene_cost(rounds)
    print(f"{SCENE}, the whole scene (CPU time, fastest of {rounds} interleaved runs):")
    for (k, w), b in walls.items():
        print(f"  {k:8s} {w:6s}  {1e6 * b / n:6.1f} us per step  real-time factor {duration / b:5.2f}")
    return 0
