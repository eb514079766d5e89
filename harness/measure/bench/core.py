"""`spurdiff bench` (= `python -m harness bench`): measured cost ratios, printed, never asserted.

This module holds the measurements. Each comparison runs A and B alternately in the same process,
several times, and reports the ratio of the medians of the stepping wall time (setup excluded), so
machine noise hits both: an FMI-coupled run against the same physics called directly in Python
(:mod:`harness.run.direct`), the cost of one FMI call and of recording, the per-instance cost of a
step, each differential fidelity against the rigid model, each scene's real-time factor, fixed
against variable communication steps (:mod:`harness.run.stepcontrol`). The report printed from them,
with its targets table and ``--write``, is :mod:`harness.measure.bench.report`.
"""
from __future__ import annotations

import contextlib
import math
import statistics
import sys
import time
import types
from dataclasses import replace

from harness.run.direct import run_direct
from harness.run.master import run_scene
from harness.run.runner import fmu_files_for, prepare_scene
from harness.scene.spec import available, load_scene


def _median_wall(fn, repeats: int) -> tuple[float, object]:
    walls, last = [], None
    for _ in range(repeats):
        last = fn()
        walls.append(last.wall_time)
    return statistics.median(walls), last


@contextlib.contextmanager
def cpu_clock():
    """While active, the master's, the variable-step master's and the direct run's stepping times (``Result.wall_time``) are
    CPU time of this thread: what one core spends on the run (the FMUs run in this thread too),
    whatever else the shared machine runs."""
    import harness.run.direct as hdir
    import harness.run.master as hm
    import harness.run.stepcontrol as hsc

    saved = hm.time, hdir.time, hsc.time
    hm.time = hdir.time = hsc.time = types.SimpleNamespace(perf_counter=time.thread_time)
    try:
        yield
    finally:
        hm.time, hdir.time, hsc.time = saved


def fmi_overhead(scene_name: str, duration: float | None = None, repeats: int = 5,
                 sets: list[str] | None = None) -> dict:
    """Median stepping time through FMI and directly, interleaved; ratio FMI / direct. Also in CPU
    time of this thread (:func:`cpu_clock`), the fastest of ``repeats`` interleaved runs each (CPU
    time does not count waiting for the processor: its noise on a shared machine is upward only).
    ``sets``: parameter overrides ('instance.parameter=value', as ``spurdiff run --set``)."""
    scene = prepare_scene(scene_name, duration=duration, sets=sets)
    files = fmu_files_for(scene)
    run_scene(scene, files)  # warm-up: first instantiation imports the model's modules
    fmi, direct, fmi_cpu, direct_cpu = [], [], [], []
    for _ in range(repeats):
        fmi.append(run_scene(scene, files).wall_time)
        direct.append(run_direct(scene).wall_time)
        with cpu_clock():
            fmi_cpu.append(run_scene(scene, files).wall_time)
            direct_cpu.append(run_direct(scene).wall_time)
    f, d = statistics.median(fmi), statistics.median(direct)
    fc, dc = min(fmi_cpu), min(direct_cpu)
    return {"scene": scene_name, "simulated_s": scene.duration, "fmi_s": f, "direct_s": d, "ratio": f / d,
            "fmi_cpu_s": fc, "direct_cpu_s": dc, "ratio_cpu": fc / dc,
            "step": scene.step, "instances": len(scene.instances)}


def recording_cost(scene_name: str, repeats: int = 3) -> dict:
    """Microseconds per communication step that recording every step costs, through FMI and
    directly: each run with the scene's output interval against the same run recording only at
    its end, interleaved; the fastest of each (a difference of two medians drowns in the noise of
    a shared machine)."""
    scene = prepare_scene(scene_name)
    once = replace(scene, output_interval=scene.duration)
    files = fmu_files_for(scene)
    walls: dict[str, list[float]] = {"fmi": [], "fmi_once": [], "direct": [], "direct_once": []}
    for _ in range(repeats):
        walls["fmi"].append(run_scene(scene, files).wall_time)
        walls["fmi_once"].append(run_scene(once, files).wall_time)
        walls["direct"].append(run_direct(scene).wall_time)
        walls["direct_once"].append(run_direct(once).wall_time)
    n = round(scene.duration / scene.step)
    med = {k: min(v) for k, v in walls.items()}
    return {"fmi_us": 1e6 * (med["fmi"] - med["fmi_once"]) / n,
            "direct_us": 1e6 * (med["direct"] - med["direct_once"]) / n,
            "recorded": len(scene.record), "every": round(scene.output_interval / scene.step)}


def initialized(inst) -> tuple[list[int], list[int]]:
    """``inst`` through Initialization Mode with its start values; the value references of its first
    4 Real outputs and first 4 Real inputs (the calls the benches time)."""
    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    inst.slave.exitInitializationMode()
    reals = [v for v in inst.md.modelVariables if v.type == "Real"]
    outs = [v.valueReference for v in reals if v.causality == "output"][:4]
    ins = [v.valueReference for v in reals if v.causality == "input"][:4]
    return outs, ins


def fmi_call_cost(scene_name: str, calls: int = 2000) -> dict:
    """Microseconds per FMI call as the master's step loop makes it (:class:`harness.fmi.instance.Port`:
    the FMU's C function through ctypes with its arguments converted once; then our loader, the
    bridge, the adapter's value table), per FMU of the scene, initialized and stepping:
    ``fmi2GetReal`` of up to 4 Real outputs, ``fmi2SetReal`` of up to 4 Real inputs (their own
    values); and a call the loader refuses at once (NULL instance: the host's ctypes call alone).
    Medians of 5 rounds."""
    from harness.fmi.instance import Instance, Port

    scene = prepare_scene(scene_name)
    files = fmu_files_for(scene)
    out = {"per_fmu": {}}

    def fail(reason: str, t: float):
        raise RuntimeError(reason)

    for fmu_name, path in sorted(files.items()):
        inst = Instance("bench", path)
        try:
            outs, ins = initialized(inst)
            getter, setter = Port(inst, outs, False, fail), Port(inst, ins, True, fail)
            setter.val[:] = Port(inst, ins, False, fail).get()   # the inputs' own values for the setter
            row = {}
            for name, port in (("fmi2GetReal", getter), ("fmi2SetReal", setter), ("refused", getter)):
                fn, args = port.fn, port.args
                if name == "refused":
                    args = (None,) + args[1:]
                rounds = []
                for _ in range(5):
                    t0 = time.perf_counter()
                    for _ in range(calls):
                        fn(*args)
                    rounds.append(time.perf_counter() - t0)
                if name != "refused" and fn(*args) != 0:
                    raise RuntimeError(f"{fmu_name}: {name} failed in the call-cost measurement")
                row[name] = (1e6 * statistics.median(rounds) / calls, port.n)
            out["per_fmu"][fmu_name] = row
        finally:
            inst.close()
    return out


def python_step_sets(scene_name: str) -> list[str]:
    """The overrides that step every instance whose FMU has a native step (``solver.nativeStep``:
    the whole step in C, :mod:`spurdiff.native_step`) through its Python model instead."""
    import importlib

    from harness.build.fmu import FMUS

    out = []
    for spec in load_scene(scene_name).instances:
        iface = importlib.import_module(FMUS[spec.fmu])
        if any(v.name == "solver.nativeStep" for v in iface.VARIABLES):
            out.append(f"{spec.name}.solver.nativeStep=false")
    return out


def fmi_path_cost(scene_name: str = "vehicle-cornering", repeats: int = 5, sets: list[str] | None = None) -> dict:
    """The FMI path without the physics: the scene through FMI and directly, interleaved, with
    every model's ``do_step`` a no-op (the models' classes patched for the measurement: this
    process's and the FMUs' own copies, which they import under a private name,
    :func:`fmu_copies`), in CPU time of this thread, the fastest of
    ``repeats`` each. What is left is what both runs do around the physics (the interface modules'
    copies, the loops, the recording) and, in the FMI run only, fmi2DoStep's way through ctypes,
    the loader, the bridge and the adapter, the getReal calls and the master's Python. The
    outputs do not change, so the master skips the setReal of unchanged inputs (only the
    profiles' remain): ``setreal_calls_per_step`` counts those of the real run, for the
    difference. Microseconds per communication step. The native steps are off (every model steps
    through its Python ``do_step``: this is the cost of that path); ``sets``: more overrides."""
    import harness.run.direct as hd
    import harness.fmi.instance as hi
    import harness.run.master as hm

    scene = prepare_scene(scene_name, sets=python_step_sets(scene_name) + list(sets or []))
    files = fmu_files_for(scene)
    classes = set()
    for spec in scene.instances:   # the model classes the scene builds
        d = hd.DirectInstance(spec.name, spec.fmu, scene.parameters_of(spec.name))
        d.initialize()
        classes.add(type(d.model))
    calls = [0]

    def no_step(self, t, h):
        calls[0] += 1

    # the setReal calls the real run makes per step (the ports skip unchanged values)
    sets, orig_set = [0], hi.Port.set

    def counted(self, values, t=math.nan):
        if values != self.last:
            sets[0] += 1
        return orig_set(self, values, t)

    def start(self):   # the calls of the stepping loop only
        orig_start(self)
        sets[0] = 0

    orig_start = hm.Master._start
    hi.Port.set, hm.Master._start = counted, start
    try:
        real = run_scene(scene, files)
    finally:
        hi.Port.set, hm.Master._start = orig_set, orig_start
    classes |= fmu_copies(classes)
    saved = {c: c.__dict__.get("do_step") for c in classes}
    fmi, direct = [], []
    try:
        for c in classes:
            c.do_step = no_step
        run_scene(scene, files)
        for _ in range(repeats):
            with cpu_clock():
                calls[0] = 0
                r = run_scene(scene, files)
                if calls[0] != r.steps * len(scene.instances):   # the FMUs ran the patched classes
                    raise RuntimeError(f"fmi_path_cost: {calls[0]} no-op steps in {r.steps} steps of "
                                       f"{len(scene.instances)} FMUs: the FMUs do not run this process's models")
                fmi.append(r.wall_time / r.steps)
                r = run_direct(scene)
                direct.append(r.wall_time / r.steps)
    finally:
        for c, f in saved.items():
            if f is None:
                del c.do_step
            else:
                c.do_step = f
    f, d = 1e6 * min(fmi), 1e6 * min(direct)
    return {"fmi_us": f, "direct_us": d, "instances": len(scene.instances),
            "per_instance_us": (f - d) / len(scene.instances),
            "setreal_calls_per_step": sets[0] / max(1, real.steps)}


def fmu_copies(classes) -> set:
    """The FMUs' copies of ``classes`` in this process: each FMU imports its package as
    ``_spurdiff_fmu_<key>`` (fmu_src/native/fmi2_pybridge.c), so ``spurdiff.rigid.RigidModel`` is also
    ``_spurdiff_fmu_<key>.rigid.RigidModel`` for every FMU folder loaded here."""
    out = set()
    for c in classes:
        rest = c.__module__.split(".", 1)
        if rest[0] != "spurdiff":
            continue
        for name, mod in list(sys.modules.items()):
            if name.startswith("_spurdiff_fmu_") and "." not in name:
                sub = sys.modules.get(name + ("." + rest[1] if len(rest) > 1 else ""))
                copy = getattr(sub, c.__name__, None) if sub is not None else None
                if isinstance(copy, type):
                    out.add(copy)
    return out


# Fidelity settings whose cost `bench` compares (structural parameters of the differential).
def _effect_sets() -> dict[str, dict]:
    """The fidelity settings of paper-straight's accuracy grid (harness/measure/accuracy/accuracy_grid.toml: every
    mesh level, every contact effect on alone and left out of the full set), without the grid's
    unloaded start, which fidelity_cost adds itself: one list of settings for both commands."""
    from harness.measure.accuracy import load_grid

    return {f["name"]: {k: v for k, v in f.items() if k not in ("name", "mesh.preload")}
            for f in load_grid()["paper-straight"]["fidelities"]}


EFFECT_SETS: dict[str, dict] = _effect_sets()


def fidelity_cost(scene_name: str = "paper-straight", sets: dict[str, dict] | None = None, repeats: int = 3,
                  extra: dict | None = None) -> list[dict]:
    """Median stepping time of each fidelity setting on one scene, relative to the first.
    ``extra``: parameters added to every setting (e.g. an unloaded start)."""
    rows = []
    base = None
    for label, effects in (sets or EFFECT_SETS).items():
        scene = prepare_scene(scene_name)
        scene = replace(scene, effects={**scene.effects, **effects, **(extra or {})})
        files = fmu_files_for(scene)
        run_scene(scene, files)
        wall, res = _median_wall(lambda: run_scene(scene, files), repeats)
        if base is None:
            base = wall
        rows.append({"level": label, "wall_s": wall, "relative": wall / base,
                     "realtime_factor": scene.duration / wall if wall > 0 else float("inf"), "ok": res.ok})
    return rows


def realtime_factors(repeats: int = 3) -> list[dict]:
    from harness.measure.accuracy import apply_choice, choose
    from harness.scene.spec import SceneError

    rows = []
    for name in available():
        scene = load_scene(name)
        auto = scene.fidelity.get("mode") == "auto"
        if auto:
            try:
                scene = apply_choice(scene, choose(scene)[0])
            except SceneError:
                continue   # no stored accuracy data yet
        files = fmu_files_for(scene)
        run_scene(scene, files)
        wall, res = _median_wall(lambda: run_scene(scene, files), repeats)
        rows.append({"scene": name, "simulated_s": scene.duration, "wall_s": wall,
                     "realtime_factor": scene.duration / wall if wall > 0 else float("inf"),
                     "fidelity": ", ".join(f"{k}={v}" for k, v in scene.effects.items())
                     + (f" (auto), step {scene.step:g} s" if auto else ""), "ok": res.ok})
    return rows


def step_cost_breakdown(scene_name: str = "vehicle-cornering", repeats: int = 3,
                        sets: list[str] | None = None) -> dict:
    """Direct run of a scene with each instance's stepping time measured in CPU time of this thread
    (robust to other processes on a shared machine; the fastest of ``repeats`` runs): microseconds
    per communication step per instance, of it in the model's do_step (the rest: the interface
    module's input and output copies), and for a differential owning its half-shafts the inner
    model's evaluations per step with the time in its steps and its state copies (what bounds the
    real-time factor). ``sets``: parameter overrides as for :func:`fmi_overhead`."""
    import harness.run.direct as hd

    scene = prepare_scene(scene_name, sets=sets)
    clock = time.thread_time
    acc: dict[str, float] = {}
    models: dict[str, object] = {}
    orig = hd.DirectInstance.step

    def add(key, dt):
        acc[key] = acc.get(key, 0.0) + dt

    def timing(obj, method, key):
        """obj.method timed into acc[key] (an instance attribute over the class's method)."""
        f = getattr(obj, method)

        def timed_method(*a, **k):
            t0 = clock()
            try:
                return f(*a, **k)
            finally:
                add(key, clock() - t0)
        obj.__dict__[method] = timed_method

    def timed(self, t, h):
        if self.name not in models:
            models[self.name] = m = self.model
            timing(m, "do_step", ("model", self.name))
            inner = m.__dict__.get("inner")
            if inner is not None:
                timing(inner, "do_step", ("inner_step", self.name))
                timing(inner, "set_state", ("inner_state", self.name))
                timing(inner, "get_state", ("inner_state", self.name))
        t0 = clock()
        orig(self, t, h)
        add(self.name, clock() - t0)

    best: dict = {}
    hd.DirectInstance.step = timed
    try:
        for _ in range(repeats):
            acc.clear()
            models.clear()
            r = run_direct(scene)
            if r.failure is not None:    # a failed run measures nothing
                raise RuntimeError(f"step_cost_breakdown: {scene_name} failed: {r.failure}")
            n = max(1, r.steps)
            for k, v in acc.items():
                best[k] = min(best.get(k, math.inf), 1e6 * v / n)
    finally:
        hd.DirectInstance.step = orig
    out = {"scene": scene_name, "step": scene.step, "steps": r.steps, "wall_s": r.wall_time,
           "us_per_step": {k: v for k, v in best.items() if isinstance(k, str)},
           "model_us": {k[1]: v for k, v in best.items() if k[0] == "model"},
           "inner_us": {k[1]: (v, best.get(("inner_state", k[1]), 0.0)) for k, v in best.items()
                        if k[0] == "inner_step"},
           "evals_per_step": {}}
    for name, m in models.items():
        if hasattr(m, "n_evals"):
            out["evals_per_step"][name] = (m.n_evals / n, m.n_substeps / n, m.n_jacobians / n)
    return out


# the fixed steps section 5 compares with (each divides tip-in-tip-out's 3.5 s and its input changes at
# 0.5 s and 2 s): the variable runs are set against the cheapest of them at equal or smaller errors
FIXED_STEPS = (4e-3, 2.5e-3, 2e-3, 1.25e-3, 1e-3)


def step_control_comparison(scene_name: str = "tip-in-tip-out", repeats: int = 3) -> list[dict]:
    """Fixed steps (the scene's and :data:`FIXED_STEPS`) and the energy-controlled variable step (redoing
    rejected steps at two tolerances, and never redoing one) against a fixed 0.2 ms run: CPU time
    of this thread (:func:`cpu_clock`, median of ``repeats`` interleaved rounds), steps, rejected
    steps, largest error of the wheel-speed ratio and of the locking torque at the 0.2 ms run's
    recording instants. Each variable row also gets ``fixed_over``: the cheapest fixed row with
    both errors at most its own, and ``cost_ratio``: its time over that row's (> 1: the fixed step
    reaches the same error for less)."""
    import numpy as np

    from harness.run.report import series
    from harness.run.stepcontrol import StepControl, VariableStepMaster

    scene = prepare_scene(scene_name)
    files = fmu_files_for(scene)
    ref = run_scene(replace(scene, step=2e-4, output_interval=1e-3), files)
    qs = ("{wheelR.wheel.w} / {wheelL.wheel.w}", "diff.lockingTorque")

    def errors(r):
        return [float(np.max(np.abs(np.interp(ref.time, r.time, series(r, q)) - series(ref, q)))) for q in qs]

    fixed = [(f"fixed {scene.step * 1e3:g} ms (scene default)", scene.step)] + [
        (f"fixed {h * 1e3:g} ms", h) for h in FIXED_STEPS if h < scene.step]
    controls = [(f"variable (rtol {c.rtol:g}, atol {c.atol:g} J{'' if c.reject else ', no redo'})", c)
                for c in (StepControl(rtol=1e-2, atol=1e-2), StepControl(rtol=1e-3, atol=1e-3),
                          StepControl(rtol=1e-2, atol=1e-2, reject=False))]
    walls: dict[str, list[float]] = {label: [] for label, _ in fixed + controls}
    last: dict[str, tuple] = {}
    for _ in range(repeats):
        with cpu_clock():
            for label, h in fixed:
                r = run_scene(replace(scene, step=h, output_interval=h), files)
                walls[label].append(r.wall_time)
                last[label] = (r, 0)
            for label, ctl in controls:
                m = VariableStepMaster(scene, files, ctl)
                r = m.run()
                walls[label].append(r.wall_time)
                last[label] = (r, m.rejected)
    rows = []
    for label, _ in fixed + controls:
        r, rejected = last[label]
        e = errors(r)
        rows.append({"run": label, "wall_s": statistics.median(walls[label]), "steps": r.steps, "rejected": rejected,
                     "ok": r.ok, "err_ratio": e[0], "err_lock": e[1]})
    fixed_rows = rows[:len(fixed)]
    for row in rows[len(fixed):]:
        ok = [f for f in fixed_rows if f["err_ratio"] <= row["err_ratio"] and f["err_lock"] <= row["err_lock"]]
        best = min(ok, key=lambda f: f["wall_s"]) if ok else None
        row["fixed_over"] = best["run"] if best else None
        row["cost_ratio"] = row["wall_s"] / best["wall_s"] if best else None
    return rows
