"""What the compiled steps of the car, the wheel (:mod:`spurdiff.vehicle.kernel`) and the differential
with its half-shafts (:mod:`spurdiff.differential.shaft_kernel`, with the rigid level's
:mod:`spurdiff.differential.rigid_kernel`) save on vehicle-cornering: A/B in one process,
interleaved (``solver.kernel = python`` on the car, both wheels and the differential, the reference,
against ``compiled``, the kernels inside the Python models' steps, and ``native``, compiled with the
car's and the wheels' whole steps in C (``solver.nativeStep``, :mod:`spurdiff.native_step`); in the
direct runs also ``shafts python``: everything compiled but the differential's half-shaft step, the
state before the shaft kernel), CPU time of the stepping thread, fastest of ``rounds`` runs each:

* the cost per communication step of each instance in the direct run and of it in the model's
  ``do_step`` (:func:`harness.measure.bench.core.step_cost_breakdown`), with the differential's inner
  model and state copies (what the half-shaft solve leaves besides);
* the whole scene through FMI and directly (:func:`harness.measure.bench.core.fmi_overhead`): us per step,
  FMI / direct and the real-time factor;
* the FMI path without the physics (:func:`harness.measure.bench.core.fmi_path_cost`): what bounds FMI /
  direct as the physics gets cheaper.

Run ``python -m harness.cli.tools.vehicle_kernel_bench [--rounds N]``. Printed, never asserted.
"""
from __future__ import annotations

import contextlib
import os

from harness.measure.bench.core import fmi_overhead, fmi_path_cost, step_cost_breakdown
from harness.build.fmu import kernel_library

KERNELS = ("python", "compiled", "native")
CONFIGS = ("python", "shafts python", "compiled", "native")    # the direct runs' breakdown
SCENE = "vehicle-cornering"
VEHICLE_INSTANCES = ("car", "wheelL", "wheelR", "diff")
NATIVE_INSTANCES = ("car", "wheelL", "wheelR", "diff")     # those with a native step (solver.nativeStep)


def sets_for(kernel: str) -> list[str]:
    """The scene overrides that select ``kernel`` for the car, the wheels and the differential:
    python, compiled (the compiled kernels inside the Python models' steps: solver.nativeStep
    false) or native (compiled, and every instance's whole step in C)."""
    impl = "python" if kernel == "python" else "compiled"
    return ([f"{i}.solver.kernel={impl}" for i in VEHICLE_INSTANCES]
            + [f"{i}.solver.nativeStep={'true' if kernel == 'native' else 'false'}" for i in NATIVE_INSTANCES])


@contextlib.contextmanager
def _shafts_in_python(on: bool):
    """The differential's half-shaft step in Python, the rest as the switch says (direct runs only:
    the models of this process)."""
    from spurdiff.differential import shaft_kernel

    choose = shaft_kernel.choose
    if on:
        shaft_kernel.choose = lambda model: (None, "python (bench: shafts python)")
    try:
        yield
    finally:
        shaft_kernel.choose = choose


def part_costs(rounds: int) -> dict[str, dict]:
    """Per configuration (:data:`CONFIGS`): us per step of each instance and of it in do_step, the
    differential's inner steps and state copies (fastest of ``rounds`` x 3 direct runs, the
    configurations alternating)."""
    best: dict[str, dict] = {k: {} for k in CONFIGS}
    for _ in range(rounds):
        for k in CONFIGS:
            with _shafts_in_python(k == "shafts python"):
                o = step_cost_breakdown(SCENE, 3, sets=sets_for("compiled" if k == "shafts python" else k))
            if k == "native":   # no do_step: the whole step in C (what the instance's time shows)
                o["model_us"] = {n: v for n, v in o["model_us"].items() if n not in NATIVE_INSTANCES}
            rows = {**{n: v for n, v in o["us_per_step"].items()},
                    **{f"{n} do_step": v for n, v in o["model_us"].items()},
                    **{f"{n} inner steps": v[0] for n, v in o["inner_us"].items()},
                    **{f"{n} inner state copies": v[1] for n, v in o["inner_us"].items()}}
            for key, v in rows.items():
                best[k][key] = min(best[k].get(key, v), v)
    return best


def scene_costs(rounds: int) -> dict[str, dict]:
    """Per kernel: :func:`fmi_overhead` (FMI and direct in CPU time, fastest of ``rounds``; the two
    kernels measured one after the other, each interleaving its FMI and direct runs)."""
    return {k: fmi_overhead(SCENE, repeats=rounds, sets=sets_for(k)) for k in KERNELS}


def load_line() -> str:
    try:
        one, five, _ = os.getloadavg()
    except OSError:
        return "load average unknown"
    return f"load average {one:.1f} (1 min), {five:.1f} (5 min) on {os.cpu_count()} cores"


def run(rounds: int = 5) -> int:
    """Measure and print."""
    kernel_library()
    print(f"{SCENE}: the car, the wheels and the differential stepped in Python (solver.kernel = python) and "
          f"compiled, A/B in one process ({load_line()})")
    best = part_costs(rounds)
    print(f"per 5 ms communication step, direct run (us, CPU time of the stepping thread, fastest of {rounds} x 3):")
    seen = list(dict.fromkeys(n for k in CONFIGS for n in best[k]))
    keys = [n for n in seen if " " not in n] + [n for n in seen if " " in n]
    print(f"  {'part':28s} " + " ".join(f"{k:>14s}" for k in CONFIGS))
    for key in keys:
        print(f"  {key:28s} " + " ".join(f"{best[k].get(key, float('nan')):14.1f}" for k in CONFIGS))
    print("  (nan: not called in that configuration; the compiled differential steps its inner model in C; native:\n"
          "  every instance's whole step in C (solver.nativeStep), no do_step)")
    for k in CONFIGS:
        tot = sum(v for n, v in best[k].items() if " " not in n)
        print(f"  sum of the instances, {k}: {tot:.1f} us")
    sc = scene_costs(rounds)
    print(f"the whole scene (CPU time, fastest of {rounds}; FMI and direct interleaved):")
    for k, o in sc.items():
        steps = round(o["simulated_s"] / o["step"])
        print(f"  {k:8s}  FMI {1e6 * o['fmi_cpu_s'] / steps:6.1f} us/step  direct {1e6 * o['direct_cpu_s'] / steps:6.1f}"
              f" us/step  FMI / direct {o['ratio_cpu']:.3f}  real-time factor FMI {o['simulated_s'] / o['fmi_cpu_s']:6.1f}"
              f"  direct {o['simulated_s'] / o['direct_cpu_s']:6.1f}")
    path = fmi_path_cost(SCENE, repeats=rounds)
    print(f"the FMI path without the physics (native steps off, every do_step a no-op, CPU time, fastest of {rounds}): FMI "
          f"{path['fmi_us']:.1f} us, direct {path['direct_us']:.1f} us per step: {path['per_instance_us']:.1f} us "
          f"per instance and step")
    print(f"({load_line()})")
    return 0
