"""What the model's own process costs (issue 25): the same FMU in this process and in its own.

A host whose Python is not the FMU runtime's version runs the model in a process of its own
(fmu_src/native/fmi/fmi2_remote.c, fmi2_server.c: shared memory, one round trip per FMI call, but
for a step's set and get: fmi2_remote_batch.c);
``SPURDIFF_FMU_PROCESS=out`` asks for that in any host, which is how this module measures it from
this process, interleaved with the in-process runs so machine noise hits both sides:

* per call, as a master's step loop makes it (the C function through ctypes with its arguments
  converted once, :meth:`harness.fmi.instance.Instance.fast_function`): ``fmi2GetReal`` of 4
  outputs before any step (in its own process a round trip each), and the sequence
  ``fmi2SetReal`` (4 inputs) + ``fmi2DoStep`` + ``fmi2GetReal`` (4 outputs) of one communication
  step of SpurDifferential (rigid, 5 ms); the difference between the two sides is the cost of the
  round trips;
* the same step under load (issue 44 item 4): with ``2 x cores`` processes that only spin beside it
  (:func:`busy_load`), the own process's step against this process's, both measured under that load
  in the same run as the quiet ones (target: within 1.5x);
* a whole scene: vehicle-cornering through FMI with every FMU in its own process against in this
  process (:func:`harness.measure.bench.core.fmi_overhead`'s run, wall and CPU time of this process:
  the model processes' CPU is not counted, it runs on the other core).

``python -m harness.cli.tools.process_bench`` prints the table; ``--load [N]`` only the step quiet
and beside N spinning processes (default 2 x cores).
"""
from __future__ import annotations

import contextlib
import os
import statistics
import subprocess
import sys
import time
from ctypes import c_double, c_size_t, c_uint
from pathlib import Path

ENV = "SPURDIFF_FMU_PROCESS"
START_ENV = "SPURDIFF_FMU_START"
STEP_ENV = "SPURDIFF_FMU_STEP"
# the sides measured: this process; its own, the compiled step handed to this process (the loader's
# default, fmu_src/native/fmi/fmi2_loader.c); its own with every step there (SPURDIFF_FMU_STEP=model)
MODES = ("in", "out", "out-model")


@contextlib.contextmanager
def environment(values: dict[str, str] | None):
    """``values`` in this process's environment for the block, each variable as it was after it."""
    old = {k: os.environ.get(k) for k in values or {}}
    os.environ.update(values or {})
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def model_process(mode: str):
    """Instances made inside the block run the model in this process ("in") or its own ("out": its
    compiled step handed to this process; "out-model": every step in the model's process), its
    Python started at fmi2Instantiate (``SPURDIFF_FMU_START=python``: at its defaults an FMU would
    otherwise start natively, with no model process at all: fmu_src/native/fmi/native_start.c)."""
    if mode not in MODES:
        raise ValueError(f"model_process: mode {mode!r}; allowed: {', '.join(MODES)}")
    return environment({ENV: mode.split("-")[0], START_ENV: "python",
                        STEP_ENV: "model" if mode == "out-model" else "auto"})


@contextlib.contextmanager
def busy_load(n: int):
    """``n`` processes of this Python that only spin, for the block (each ended by its pid after it):
    a machine oversubscribed as a busy host's is."""
    procs = [subprocess.Popen([sys.executable, "-c", "while True: pass"], stdin=subprocess.DEVNULL)
             for _ in range(n)]
    try:
        time.sleep(0.2)   # all of them running
        yield
    finally:
        for p in procs:
            p.kill()
        for p in procs:
            p.wait()


def _calls(path: Path, mode: str, n: int, h: float = 5e-3) -> dict[str, float]:
    """Microseconds per getReal(4) and per setReal(4) + doStep + getReal(4), median of 5 rounds."""
    from harness.fmi.instance import Instance
    from harness.measure.bench.core import initialized

    with model_process(mode):
        inst = Instance("bench", path)
    try:
        outs, ins = initialized(inst)
        get, set_, step = (inst.fast_function(f) for f in ("fmi2GetReal", "fmi2SetReal", "fmi2DoStep"))
        c = inst.c_component
        vo, vi = (c_uint * len(outs))(*outs), (c_uint * len(ins))(*ins)
        xo, xi = (c_double * len(outs))(), (c_double * len(ins))()
        no, ni = c_size_t(len(outs)), c_size_t(len(ins))
        if get(c, vi, ni, xi) != 0:   # the inputs' own values, set back unchanged
            raise RuntimeError(f"{path.name}: getReal of the inputs failed ({mode})")
        hh = c_double(h)
        t = 0.0
        rounds_get, rounds_step = [], []
        for _ in range(5):   # before any step: in its own process each get is a round trip
            t0 = time.perf_counter()
            for _ in range(n):
                get(c, vo, no, xo)
            rounds_get.append(time.perf_counter() - t0)
        for _ in range(5):   # the step's set and get need none there (fmi2_remote_batch.c)
            t0 = time.perf_counter()
            for _ in range(n):
                set_(c, vi, ni, xi)
                if step(c, c_double(t), hh, 1) != 0:
                    raise RuntimeError(f"{path.name}: doStep failed at t = {t} ({mode})")
                get(c, vo, no, xo)
                t += h
            rounds_step.append(time.perf_counter() - t0)
        return {"getReal": 1e6 * statistics.median(rounds_get) / n,
                "set+doStep+get": 1e6 * statistics.median(rounds_step) / n}
    finally:
        inst.close()


def _differential() -> Path:
    from harness.build.fmu import build

    return build(["SpurDifferential"], quiet=True)[0]


def round_trips(n: int = 2000, path: Path | None = None) -> dict:
    """SpurDifferential's calls in this process and in its own (the step handed over, and stepped there),
    interleaved (in, out, out-model, in, out, out-model): the best of each side by mode, and "overhead"
    and "overhead_model", the own process's against this one's."""
    path = path or _differential()
    runs = {m: [] for m in MODES}
    for mode in MODES * 2:
        runs[mode].append(_calls(path, mode, n))
    best = {m: {k: min(r[k] for r in rs) for k in rs[0]} for m, rs in runs.items()}
    return {**best, "overhead": {k: best["out"][k] - best["in"][k] for k in best["in"]},
            "overhead_model": {k: best["out-model"][k] - best["in"][k] for k in best["in"]}}


def under_load(n: int = 2000, load: int | None = None, path: Path | None = None) -> dict:
    """The communication step's cost (set + doStep + get) in its own process against this process,
    quiet and with ``load`` spinning processes beside it (default: twice the cores), in one run:
    {"load": load, "quiet": round_trips(), "loaded": round_trips() under the load, and "ratio_quiet",
    "ratio_loaded": own process / this process per step, "ratio_model_quiet", "ratio_model_loaded" the
    same with every step in the model's process}; ``path``: another build of the FMU
    (an older one, to compare)."""
    path = path or _differential()
    load = load or 2 * (os.cpu_count() or 1)
    quiet = round_trips(n, path)
    with busy_load(load):
        loaded = round_trips(n, path)
    k = "set+doStep+get"
    return {"load": load, "quiet": quiet, "loaded": loaded, "ratio_quiet": quiet["out"][k] / quiet["in"][k],
            "ratio_loaded": loaded["out"][k] / loaded["in"][k],
            "ratio_model_quiet": quiet["out-model"][k] / quiet["in"][k],
            "ratio_model_loaded": loaded["out-model"][k] / loaded["in"][k]}


def scene_in_own_processes(scene_name: str = "vehicle-cornering", repeats: int = 3) -> dict:
    """The scene through FMI with every FMU in its own process against in this process: stepping
    wall time (medians) and CPU time of the stepping thread (fastest), interleaved."""
    from harness.measure.bench.core import cpu_clock
    from harness.run.master import run_scene
    from harness.run.runner import fmu_files_for, prepare_scene

    scene = prepare_scene(scene_name)
    files = fmu_files_for(scene)
    walls, cpus = {"in": [], "out": []}, {"in": [], "out": []}
    for mode in ("in", "out"):   # warm-up
        with model_process(mode):
            run_scene(scene, files)
    for _ in range(repeats):
        for mode in ("in", "out"):
            with model_process(mode):
                walls[mode].append(run_scene(scene, files).wall_time)
                with cpu_clock():
                    cpus[mode].append(run_scene(scene, files).wall_time)
    return {"scene": scene_name, "in_wall": statistics.median(walls["in"]), "out_wall": statistics.median(walls["out"]),
            "in_cpu": min(cpus["in"]), "out_cpu": min(cpus["out"])}


def report(repeats: int = 3) -> list[str]:
    ul = under_load()
    rt = ul["quiet"]
    k = "set+doStep+get"
    lines = ["   SpurDifferential (rigid, 5 ms step), us per call as a master's loop makes it, best of 2 interleaved "
             "rounds; own process: its compiled step handed to this process (the default), and with every step "
             "in the model's process (SPURDIFF_FMU_STEP=model):",
             f"   {'':24s}{'this process':>14s}{'own process':>14s}{'own, steps there':>18s}"]
    for key in ("getReal", k):
        lines.append(f"   {key:24s}{rt['in'][key]:14.1f}{rt['out'][key]:14.1f}{rt['out-model'][key]:18.1f}")
    lines.append(f"   one round trip (getReal's difference, before any step): {rt['overhead']['getReal']:.1f} us; "
                 f"a communication step's difference: {rt['overhead'][k]:.1f} us handed over (no round trip), "
                 f"{rt['overhead_model'][k]:.1f} us stepped in the model's process (one round trip: the set deferred, "
                 f"the get answered from the step's answer) (target <= 10)")
    ld = ul["loaded"]
    lines.append(f"   with {ul['load']} spinning processes beside it ({ul['load'] / (os.cpu_count() or 1):g} x the cores): "
                 f"set+doStep+get {ld['in'][k]:.1f} us in this process, {ld['out'][k]:.1f} us in its own "
                 f"(handed over), {ld['out-model'][k]:.1f} us stepped there")
    lines.append(f"   own process / this process per step: quiet {ul['ratio_quiet']:.2f}x, under that load "
                 f"{ul['ratio_loaded']:.2f}x (target <= 1.5x); stepped in the model's process "
                 f"{ul['ratio_model_quiet']:.2f}x and {ul['ratio_model_loaded']:.2f}x")
    try:
        s = scene_in_own_processes(repeats=repeats)
    except Exception as e:   # noqa: BLE001 - a scene that cannot run here is reported, not fatal
        lines.append(f"   the scene in own processes: not measured ({type(e).__name__}: {e})")
    else:
        lines.append(f"   {s['scene']} with every FMU in its own process / in this process: wall "
                     f"{s['out_wall'] / s['in_wall']:.2f} ({s['out_wall']:.2f} s / {s['in_wall']:.2f} s), "
                     f"this process's CPU {s['out_cpu'] / s['in_cpu']:.2f}")
    return lines
