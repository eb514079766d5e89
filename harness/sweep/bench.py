"""``spurdiff sweep --bench``: the speed-up of a sweep with 1 versus 2 local workers, and the
per-run cost of the sweep machinery versus a bare scene run."""
from __future__ import annotations

import os
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from harness.sweep.execution.executors import local_cluster
from harness.sweep.plan import plan_sweep
from harness.sweep.run import run_sweep
from harness.sweep.sampling import expand
from harness.sweep.spec import Param, Sweep
from harness.sweep.execution.worker import scene_for

def bench(sweep: Sweep, n_runs: int = 64, worker_counts=(1, 2), duration: float | None = None,
          out=print) -> dict:
    """Speed-up of an ``n_runs`` sweep with 1 versus 2 local workers (one run each, printed), and the
    per-run cost of the sweep machinery versus a bare scene run (``harness.run.master.run_scene``)."""
    import statistics
    import tempfile

    from harness.run.master import run_scene

    plan = plan_sweep(sweep, duration=duration)
    cyc = [plan.tasks[i % len(plan.tasks)] for i in range(n_runs)]
    listed = replace(sweep, method="list", n=None, seed=None,
                     params=[Param(p.name, values=[t.params[p.name] for t in cyc]) for p in sweep.params])
    plan = replace(plan, sweep=listed, tasks=expand(listed))
    res: dict[str, Any] = {"runs": n_runs, "scene": plan.job.scene.name, "duration": plan.job.scene.duration}
    run_scene(scene_for(plan.job, plan.tasks[0]), plan.fmu_files)  # warm-up: imports inside the FMU
    bare, stepping = [], []
    for t in plan.tasks:
        sc = scene_for(plan.job, t)
        t1 = time.perf_counter()
        r = run_scene(sc, plan.fmu_files)
        bare.append(time.perf_counter() - t1)
        stepping.append(r.wall_time)
    res["bare_per_run"] = statistics.mean(bare)
    res["stepping_per_run"] = statistics.mean(stepping)
    with tempfile.TemporaryDirectory() as tmp:
        o = run_sweep(listed, Path(tmp) / "serial", workers=0, plan=plan, progress=False)
        res["serial_per_run"] = o.wall / n_runs
        for w in worker_counts:
            t1 = time.perf_counter()
            client, cluster = local_cluster(w)
            start = time.perf_counter() - t1
            try:
                o = run_sweep(listed, Path(tmp) / f"w{w}", client=client, plan=plan, progress=False)
            finally:
                client.close()
                cluster.close()
            res[f"cluster{w}_start"] = start
            res[f"cluster{w}_wall"] = o.wall
            res[f"cluster{w}_ok"] = sum(r["status"] == "ok" for r in o.rows)
            inside = [float(r["wall_time_s"]) for r in o.rows]
            res[f"cluster{w}_inside_median"] = statistics.median(inside)
            res[f"cluster{w}_inside_sum"] = sum(inside)
    if len(worker_counts) == 2:
        a, b = worker_counts
        res["speedup"] = res[f"cluster{a}_wall"] / res[f"cluster{b}_wall"]
        res["speedup_with_start"] = ((res[f"cluster{a}_wall"] + res[f"cluster{a}_start"])
                                     / (res[f"cluster{b}_wall"] + res[f"cluster{b}_start"]))
    ms = 1e3
    out(f"sweep bench: {n_runs} runs of {res['scene']} ({res['duration']:g} s simulated each), "
        f"{os.cpu_count()} CPUs, python {sys.version.split()[0]}; one run of each, not repeated")
    out(f"  bare scene run (run_scene, instantiate per run): {res['bare_per_run'] * ms:.2f} ms per run "
        f"(of which stepping {res['stepping_per_run'] * ms:.2f} ms)")
    out(f"  sweep in this process (--workers 0, reused FMUs, table row per run): {res['serial_per_run'] * ms:.2f} ms "
        f"per run, overhead {(res['serial_per_run'] - res['bare_per_run']) * ms:+.2f} ms per run versus bare")
    for w in worker_counts:
        per = res[f"cluster{w}_wall"] / n_runs
        out(f"  local cluster, {w} worker process{'es' if w > 1 else ''}: {res[f'cluster{w}_wall']:.2f} s for the sweep "
            f"({per * ms:.2f} ms per run, overhead {(per - res['bare_per_run']) * ms:+.2f} ms versus bare), "
            f"cluster start {res[f'cluster{w}_start']:.2f} s, {res[f'cluster{w}_ok']} ok; inside the workers "
            f"{res[f'cluster{w}_inside_median'] * ms:.2f} ms per run (median), {res[f'cluster{w}_inside_sum']:.2f} s "
            f"in all (first run per process included)")
    if "speedup" in res:
        out(f"  speed-up {worker_counts[1]} versus {worker_counts[0]} workers: {res['speedup']:.2f}x "
            f"(sweep only), {res['speedup_with_start']:.2f}x (with cluster start)")
    return res
