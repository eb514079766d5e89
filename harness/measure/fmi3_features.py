"""What the FMI 3.0 features of :mod:`harness.run.master3` change, measured (issue 28 item 2): each scene
run with the FMI 3.0 FMUs at the given communication steps in several variants (Gauss-Seidel or
Jacobi, zero- or first-order hold, early return or not) against its reference, the same scene at
a fine step (Gauss-Seidel, zero-order hold). Per run:

* ``metric``: the largest error of the scene's table quantities (mean, max, min over their windows),
  each relative to its quantity's scale, as ``spurdiff accuracy`` measures a scene
  (:func:`harness.run.metrics.metric_error`);
* ``traj``: the largest difference of the trajectories :data:`TRAJ_VARS` (the exchanged shaft
  torques, the flange speeds) from the reference at the samples both have, relative to each
  variable's largest magnitude in the reference;
* ``cpu``: the process CPU time of the run (s; the FMUs run in this process), the median of
  ``repeats`` runs (the results of a run are the same every time), and the counts of
  :attr:`Master3.stats`.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from harness.measure.accuracy.measure import metric_values, metrics_of
from harness.run.master3 import run_scene3
from harness.run.metrics import metric_error
from harness.run.runner import fmu_files_for, prepare_scene

TRAJ_VARS = ("diff.leftShaft.tau", "diff.rightShaft.tau", "diff.left.w", "diff.right.w")
# (label, algorithm, hold, early return)
FOH_VARIANTS = (("GS ZOH", "gauss-seidel", "zoh", False), ("GS FOH", "gauss-seidel", "foh", False),
                ("Jacobi ZOH", "jacobi", "zoh", False), ("Jacobi FOH", "jacobi", "foh", False))
ER_VARIANTS = (("GS ZOH", "gauss-seidel", "zoh", False), ("GS ZOH + early return", "gauss-seidel", "zoh", True))


@dataclass
class Row:
    scene: str
    step: float
    label: str
    metric: float
    traj: float
    cpu: float
    stats: dict = field(default_factory=dict)
    failure: str = ""


def _scene(name: str, step: float, algorithm: str, duration: float | None):
    sc = prepare_scene(name, step=step, duration=duration, algorithm=algorithm)
    return replace(sc, output_interval=max(step, sc.output_interval))


def _run(sc, hold: str, early: bool, repeats: int = 1):
    files = fmu_files_for(sc, build_missing=False, fmi_version=3)
    cpus = []
    for _ in range(max(1, repeats)):
        t0 = time.process_time()
        res, stats = run_scene3(sc, files, hold=hold, early_return=early)
        cpus.append(time.process_time() - t0)
        if not res.ok:
            break
    return res, stats, float(np.median(cpus))


def trajectory_error(res, ref, names=TRAJ_VARS) -> float:
    """Largest |run - reference| of ``names`` at the sample times both recorded, over the
    reference's largest magnitude of each."""
    t, tr = res.data[:, 0], ref.data[:, 0]
    common, i, j = np.intersect1d(np.round(t, 9), np.round(tr, 9), return_indices=True)
    if not len(common):
        return math.inf
    worst = 0.0
    for n in names:
        if n not in res.names or n not in ref.names:
            continue
        a, b = res[n][i], ref[n][j]
        scale = float(np.max(np.abs(ref[n]))) or 1.0
        worst = max(worst, float(np.max(np.abs(a - b))) / scale)
    return worst


def measure(name: str, steps=(5e-3, 1e-2), variants=FOH_VARIANTS, ref_step: float = 5e-4,
            duration: float | None = None, repeats: int = 3, log=print) -> list[Row]:
    ref_scene = _scene(name, ref_step, "gauss-seidel", duration)
    ref, _, cpu = _run(ref_scene, "zoh", False)
    if not ref.ok:
        raise RuntimeError(f"{name}: the reference run at {ref_step:g} s failed: {ref.failure}")
    quantities = metrics_of(ref_scene)
    ref_values = metric_values(ref, quantities)
    log(f"{name}: reference at {ref_step * 1e3:g} ms, {cpu:.2f} s CPU")
    rows = []
    for step in steps:
        for label, algorithm, hold, early in variants:
            sc = _scene(name, step, algorithm, duration)
            res, stats, cpu = _run(sc, hold, early, repeats)
            if res.ok:
                row = Row(name, step, label, metric_error(metric_values(res, quantities), ref_values),
                          trajectory_error(res, ref), cpu, stats)
            else:
                row = Row(name, step, label, math.inf, math.inf, cpu, stats, str(res.failure))
            log(f"  {step * 1e3:g} ms {label}: metric {row.metric:.3g}, traj {row.traj:.3g}, {cpu:.2f} s CPU {stats}"
                + (f" FAILED {row.failure}" if row.failure else ""))
            rows.append(row)
    return rows


def markdown(rows: list[Row], command: str) -> str:
    lines = [f"Made by `{command}`.", "",
             "| scene | step | variant | scene metric error | trajectory error | CPU (s, median) | early returns | derivative reads |",
             "|---|---:|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r.scene} | {r.step * 1e3:g} ms | {r.label} | {r.metric:.3g} | {r.traj:.3g} | {r.cpu:.2f} | "
                     f"{r.stats.get('early_returns', 0)} | {r.stats.get('derivative_reads', 0)} |"
                     + (f" failed: {r.failure}" if r.failure else ""))
    return "\n".join(lines) + "\n"
