"""Issue 19 item 4: what the rigid level's compiled kernel (spurdiff.rigid_kernel) saves on
vehicle-cornering, A/B in one process, interleaved (solver.kernel = python, the reference, against
the compiled kernel), CPU time of the stepping thread, fastest of ROUNDS runs each:

* the differential's cost per communication step in the direct run, split as
  harness.bench.core.step_cost_breakdown does (the inner rigid model's steps, per inner step);
* the whole scene through FMI and directly (harness.bench.core.cpu_clock): us per step and the
  real-time factor.

    SPURDIFF_FMU_DIR=... .venv/bin/python tests/rigid_kernel_cost.py [ROUNDS]
"""
import sys
from pathlib import Path

if sys.path and Path(sys.path[0]).resolve() == Path(__file__).resolve().parent:
    sys.path.pop(0)     # this folder's harness/ (the harness tests) would shadow the harness package

from harness.bench.core import cpu_clock, step_cost_breakdown
from harness.build import rigid_kernel_library
from harness.direct import run_direct
from harness.master import run_scene
from harness.runner import fmu_files_for, prepare_scene
from spurdiff import rigid_kernel

rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 5
rigid_kernel_library()
KERNELS = ("python", "compiled")
real_choose = rigid_kernel.choose

# 1. the differential's step, direct (step_cost_breakdown runs the scene as it is: the kernel
#    switched by replacing the choice for the python rounds)
parts = {k: [] for k in KERNELS}
for _ in range(rounds):
    for k in KERNELS:
        rigid_kernel.choose = real_choose if k == "compiled" else (lambda m: (None, "python (A/B)"))
        try:
            o = step_cost_breakdown("vehicle-cornering", 3)
        finally:
            rigid_kernel.choose = real_choose
        parts[k].append((o["us_per_step"]["diff"], o["model_us"]["diff"], o["inner_us"]["diff"][0],
                         o["evals_per_step"]["diff"][0]))
print("vehicle-cornering, the differential per 5 ms communication step (us, CPU time, fastest of "
      f"{rounds} x 3 runs):")
for k in KERNELS:
    best = [min(r[i] for r in parts[k]) for i in range(4)]
    print(f"  {k:8s}  instance {best[0]:6.1f}  do_step {best[1]:6.1f}  inner rigid steps {best[2]:5.1f} "
          f"({best[3]:.2f} per step, {best[2] / best[3]:.2f} each)")

# 2. the whole scene, FMI and direct, the kernel chosen by the FMU parameter
scenes = {k: prepare_scene("vehicle-cornering", sets=[f"diff.solver.kernel={k}"]) for k in KERNELS}
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
n = round(sc.duration / sc.step)
print(f"vehicle-cornering, the whole scene (CPU time, fastest of {rounds} interleaved runs):")
for (k, w), v in walls.items():
    b = min(v)
    print(f"  {k:8s} {w:6s}  {1e6 * b / n:6.1f} us per step  real-time factor {sc.duration / b:5.2f}")
