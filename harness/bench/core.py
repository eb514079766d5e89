"""`spurdiff bench` (= `python -m harness bench`): measured cost ratios, printed, never asserted.

Each comparison runs A and B alternately in the same process, several times, and reports the
ratio of the medians of the stepping wall time (setup excluded), so machine noise hits both:

1. FMI-coupled run versus the same physics called directly in Python (:mod:`harness.direct`);
2. cost of each differential fidelity level relative to the rigid model (paper-straight);
3. real-time factor of each scene at its default fidelity;
4. the targets;
5. fixed versus variable communication steps (:mod:`harness.stepcontrol`) on tip-in-tip-out.
"""
from __future__ import annotations

import contextlib
import math
import statistics
import sys
import types
from pathlib import Path
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


@contextlib.contextmanager
def cpu_clock():
    """While active, the master's and the direct run's stepping times (``Result.wall_time``) are
    CPU time of this thread: what one core spends on the run (the FMUs run in this thread too),
    whatever else the shared machine runs."""
    import harness.direct as hdir
    import harness.master as hm

    saved = hm.time, hdir.time
    hm.time = hdir.time = types.SimpleNamespace(perf_counter=time.thread_time)
    try:
        yield
    finally:
        hm.time, hdir.time = saved


def fmi_overhead(scene_name: str, duration: float | None = None, repeats: int = 5) -> dict:
    """Median stepping time through FMI and directly, interleaved; ratio FMI / direct. Also in CPU
    time of this thread (:func:`cpu_clock`), the fastest of ``repeats`` interleaved runs each (CPU
    time does not count waiting for the processor: its noise on a shared machine is upward only)."""
    scene = prepare_scene(scene_name, duration=duration)
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


def fmi_call_cost(scene_name: str, calls: int = 2000) -> dict:
    """Microseconds per FMI call through the whole path a master's step loop takes (fmpy's ctypes
    call, our loader, the bridge, the adapter), per FMU of the scene, with one preallocated
    value-reference array as a master keeps it: ``fmi2GetReal`` of up to 4 Real outputs,
    ``fmi2SetReal`` of up to 4 Real inputs (their own values); and a call the loader refuses at
    once (NULL instance: the host's ctypes call alone). Medians of 5 rounds."""
    import ctypes

    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave, fmi2Real, fmi2ValueReference
    import shutil

    scene = prepare_scene(scene_name)
    files = fmu_files_for(scene)
    out = {"per_fmu": {}}
    for fmu_name, path in sorted(files.items()):
        unzip = extract(str(path))
        try:
            md = read_model_description(unzip)
            slave = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier,
                              instanceName="bench")
            slave.instantiate()
            slave.setupExperiment(startTime=0.0)
            slave.enterInitializationMode()
            slave.exitInitializationMode()
            reals = [v for v in md.modelVariables if v.type == "Real"]
            outs = [v.valueReference for v in reals if v.causality == "output"][:4]
            ins = [v.valueReference for v in reals if v.causality == "input"][:4]
            fns = {}
            for name in ("fmi2GetReal", "fmi2SetReal"):
                f = getattr(slave.dll, name)
                f.argtypes = [ctypes.c_void_p, ctypes.POINTER(fmi2ValueReference), ctypes.c_size_t,
                              ctypes.POINTER(fmi2Real)]
                f.restype = ctypes.c_int
                fns[name] = f
            row = {}
            for name, vrs in (("fmi2GetReal", outs), ("fmi2SetReal", ins), ("refused", outs)):
                n = len(vrs)
                vr, val = (fmi2ValueReference * n)(*vrs), (fmi2Real * n)()
                fns["fmi2GetReal"](slave.component, vr, n, val)   # the inputs' own values for the setter
                f = fns["fmi2SetReal" if name == "fmi2SetReal" else "fmi2GetReal"]
                comp = None if name == "refused" else slave.component
                rounds = []
                for _ in range(5):
                    t0 = time.perf_counter()
                    for _ in range(calls):
                        f(comp, vr, n, val)
                    rounds.append(time.perf_counter() - t0)
                if name != "refused" and f(comp, vr, n, val) != 0:
                    raise RuntimeError(f"{fmu_name}: {name} failed in the call-cost measurement")
                row[name] = (1e6 * statistics.median(rounds) / calls, n)
            out["per_fmu"][fmu_name] = row
            slave.terminate()
            slave.freeInstance()
        finally:
            shutil.rmtree(unzip, ignore_errors=True)
    return out


# Fidelity settings whose cost `bench` compares (structural parameters of the differential).
def _effect_sets() -> dict[str, dict]:
    """The fidelity settings of paper-straight's accuracy grid (harness/accuracy_grid.toml: every
    mesh level, every contact effect on alone and left out of the full set), without the grid's
    unloaded start, which fidelity_cost adds itself: one list of settings for both commands."""
    from harness.accuracy import load_grid

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
    from harness.accuracy import apply_choice, choose
    from harness.scene import SceneError

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


def step_cost_breakdown(scene_name: str = "vehicle-cornering", repeats: int = 3) -> dict:
    """Direct run of a scene with each instance's stepping time measured in CPU time of this thread
    (robust to other processes on a shared machine; the fastest of ``repeats`` runs): microseconds
    per communication step per instance, of it in the model's do_step (the rest: the interface
    module's input and output copies), and for a differential owning its half-shafts the inner
    model's evaluations per step with the time in its steps and its state copies (what bounds the
    real-time factor)."""
    import harness.direct as hd

    scene = prepare_scene(scene_name)
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


def step_control_comparison(scene_name: str = "tip-in-tip-out", repeats: int = 3) -> list[dict]:
    """Fixed steps (the scene's and 1 ms) and the energy-controlled variable step against a
    fixed 0.2 ms run: wall time, steps, rejected steps, largest error of the wheel-speed ratio and
    of the locking torque at the 0.2 ms run's recording instants."""
    import numpy as np

    from harness.report import series
    from harness.stepcontrol import StepControl, VariableStepMaster

    scene = prepare_scene(scene_name)
    files = fmu_files_for(scene)
    ref = run_scene(replace(scene, step=2e-4, output_interval=1e-3), files)
    qs = ("{wheelR.wheel.w} / {wheelL.wheel.w}", "diff.lockingTorque")

    def errors(r):
        return [float(np.max(np.abs(np.interp(ref.time, r.time, series(r, q)) - series(ref, q)))) for q in qs]

    rows = []
    for label, h in ((f"fixed {scene.step * 1e3:g} ms (scene default)", scene.step), ("fixed 1 ms", 1e-3)):
        sc = replace(scene, step=h, output_interval=h)
        wall, r = _median_wall(lambda: run_scene(sc, files), repeats)
        rows.append({"run": label, "wall_s": wall, "steps": r.steps, "rejected": 0, "ok": r.ok,
                     "err_ratio": errors(r)[0], "err_lock": errors(r)[1]})
    for ctl in (StepControl(rtol=1e-2, atol=1e-2), StepControl(rtol=1e-3, atol=1e-3)):
        walls = []
        for _ in range(repeats):
            m = VariableStepMaster(scene, files, ctl)
            r = m.run()
            walls.append(r.wall_time)
        rows.append({"run": f"variable (rtol {ctl.rtol:g}, atol {ctl.atol:g} J)", "wall_s": statistics.median(walls),
                     "steps": r.steps, "rejected": m.rejected, "ok": r.ok,
                     "err_ratio": errors(r)[0], "err_lock": errors(r)[1]})
    return rows


def main(argv: list[str] | None = None) -> int:
    """``spurdiff bench`` (see :mod:`harness.cli.bench`)."""
    from harness.cli.bench import main as _main
    return _main(argv)


def run(args) -> int:
    """``spurdiff bench`` with its parsed options (:mod:`harness.cli.bench`): the report, printed,
    and with ``--write`` also as Markdown."""
    import contextlib
    import io
    buf = io.StringIO()
    with contextlib.redirect_stdout(_Tee(sys.stdout, buf)):
        code = _report(args)
    if args.write:
        cmd = "spurdiff bench" + (f" --repeats {args.repeats}" if args.repeats != 5 else "") + f" --write {args.write}"
        old = Path(args.write).read_text() if Path(args.write).exists() else ""
        cut = old.find("\n## ")
        tail = old[cut:] if cut >= 0 else ""   # the sections after the generated block stay
        Path(args.write).write_text(
            "# Performance\n\nMeasured by `" + cmd + "`: the block below is regenerated by that command, not edited by hand (the sections after it are kept). "
            "Ratios compare runs interleaved in one process, so machine noise hits both sides; absolute times "
            "depend on the machine (this one: 2 cores, shared).\n\n```\n" + buf.getvalue() + "```\n" + tail)
        print(f"wrote {args.write}")
    return code


def _solve_ivp_ratio(restarted_only: bool = False) -> float | None:
    """Best speed ratio of ours over the best solve_ivp variant at equal accuracy on the contact
    model (error on the paper scenes' metrics where stored, else on the states), from the stored
    accuracy facts (`spurdiff accuracy`). ``restarted_only``: only solve_ivp restarted at every
    communication point, as a co-simulation slave must run it."""
    import json

    from harness.accuracy import FACTS_FILE, equal_accuracy_ratios, ivp_error_key
    try:
        ivp = json.loads(FACTS_FILE.read_text()).get("ivp") or []
    except (OSError, ValueError):
        return None
    key = ivp_error_key(ivp)
    # ours as the FMU runs it (harness.bench.mesh.OURS: a do_step per communication step, compiled)
    ivp = [p for p in ivp if not p["integrator"].startswith("ours") or p["integrator"] == "ours, compiled (do_step loop)"
           or p["integrator"] == "ours (ROS34PW2, do_step loop)"]
    if restarted_only:
        ivp = [p for p in ivp if "one call" not in p["integrator"]]
    r = [x["ratio"] for x in equal_accuracy_ratios(ivp, key)
         if x["ratio"] is not None and x["case"].startswith("contact")]
    return max(r) if r else None


def _load() -> str:
    """The machine's load when measuring (wall times on a shared machine grow with it)."""
    import os

    try:
        one, five, _ = os.getloadavg()
    except OSError:
        return f"{os.cpu_count()} cores"
    return f"load average {one:.1f} (1 min), {five:.1f} (5 min) on {os.cpu_count()} cores"


class _Tee:
    def __init__(self, *streams):
        self.streams = streams

    def write(self, s):
        for st in self.streams:
            st.write(s)
        return len(s)

    def flush(self):
        for st in self.streams:
            st.flush()


def _report(args) -> int:
    from harness.report import render

    sets = {k: v for k, v in EFFECT_SETS.items() if not args.levels or k in args.levels or k == "rigid"}
    t0 = time.perf_counter()
    print(f"spurdiff bench (medians of {args.repeats} interleaved runs, stepping time only; {_load()})\n")
    o = fmi_overhead("vehicle-cornering" if "vehicle-cornering" in available() else "paper-cornering",
                     repeats=args.repeats)
    print("1. FMI-coupled versus direct physics, same scene and loop")
    print(render(["scene", "simulated s", "FMI s", "direct s", "FMI / direct"],
                 [[o["scene"], f"{o['simulated_s']:g}", f"{o['fmi_s']:.4f}", f"{o['direct_s']:.4f}",
                   f"{o['ratio']:.2f}"]]))
    n_steps = round(o["simulated_s"] / o["step"])
    per_fmi, per_direct = 1e6 * o["fmi_s"] / n_steps, 1e6 * o["direct_s"] / n_steps
    print(f"   per communication step ({o['step']:g} s, {n_steps} steps): FMI {per_fmi:.0f} us, direct "
          f"{per_direct:.0f} us;\n   the difference, {per_fmi - per_direct:.0f} us, is {o['instances']} instances x "
          f"(setReal + doStep + getReal through our C bridge and the adapter, and the master's own step loop) = "
          f"{(per_fmi - per_direct) / o['instances']:.0f} us per instance and step.\n"
          f"   20x real time at this step leaves {1e6 * o['step'] / 20:.0f} us per step for everything.")
    if "fmi_cpu_s" in o:
        print(f"   in CPU time of the stepping thread (fastest of {args.repeats} interleaved runs; what one core spends, "
              f"whatever else the machine runs): FMI {1e6 * o['fmi_cpu_s'] / n_steps:.0f} us, direct "
              f"{1e6 * o['direct_cpu_s'] / n_steps:.0f} us per step, FMI / direct {o['ratio_cpu']:.2f}, real-time "
              f"factor through FMI {o['simulated_s'] / o['fmi_cpu_s']:.1f}.")
    calls = fmi_call_cost(o["scene"]) if o["scene"] == "vehicle-cornering" else None
    call_us = None
    if calls:
        parts = []
        for fmu_name, row in calls["per_fmu"].items():
            (g, ng), (st, ns), (rf, _) = row["fmi2GetReal"], row["fmi2SetReal"], row["refused"]
            parts.append(f"{fmu_name} getReal({ng}) {g:.1f}, setReal({ns}) {st:.1f}, refused {rf:.1f}")
        rows = list(calls["per_fmu"].values())
        get_us = statistics.mean(r["fmi2GetReal"][0] for r in rows)
        set_us = statistics.mean(r["fmi2SetReal"][0] for r in rows)
        host_us = statistics.mean(r["refused"][0] for r in rows)
        call_us = get_us + set_us
        print(f"   one FMI call (us; 'refused': a call the loader refuses at once, i.e. the host's ctypes call "
              f"alone): {'; '.join(parts)}.\n   Per instance and step the set and get calls cost {call_us:.1f} us "
              f"({2 * host_us:.1f} us of it in the host's ctypes calls); the rest, "
              f"{(per_fmi - per_direct) / o['instances'] - call_us:.0f} us of the "
              f"{(per_fmi - per_direct) / o['instances']:.0f} us, is the master's step loop (its recording reads "
              "included), fmi2DoStep's call and the adapter's checks.")
        rec = recording_cost(o["scene"], max(5, args.repeats))
        print(f"   Recording the scene's {rec['recorded']} variables every {rec['every']} step(s) costs the FMI run "
              f"{rec['fmi_us']:.0f} us per step (the master's reads at the recording instants), the direct run "
              f"{rec['direct_us']:.0f} us (measured against the same runs recording only at their end).")
    b = step_cost_breakdown(o["scene"]) if o["scene"] == "vehicle-cornering" else None
    if b:
        parts = ", ".join(f"{k} {v:.0f} us" for k, v in b["us_per_step"].items())
        print(f"   direct physics per step by instance (CPU time of this thread, fastest of 3 runs): {parts} "
              f"(sum {sum(b['us_per_step'].values()):.0f} us);\n   of it in the models' do_step: "
              + ", ".join(f"{k} {v:.0f} us" for k, v in b["model_us"].items())
              + " (the rest: the interface modules' input and output copies);")
        for name, (ev, sub, jac) in b["evals_per_step"].items():
            step_us, state_us = b["inner_us"].get(name, (0.0, 0.0))
            own = b["model_us"].get(name, 0.0) - step_us - state_us
            print(f"   {name} owns the half-shafts: {sub:.1f} sub-steps and {ev:.1f} inner-model steps per communication "
                  f"step ({jac:.3f} Jacobians): the inner model's steps {step_us:.0f} us ({step_us / max(ev, 1e-9):.0f} "
                  f"us each, mostly the rigid model's pin-load solve), its state copies {state_us:.0f} us, the shafts' "
                  f"Newton and bookkeeping {own:.0f} us.")
    print("\n2. Cost of each effect relative to rigid (paper-straight from unloaded meshes, mesh.preload = false:"
          "\n   the loads hit at t = 0, a transient with impacts and stick-slip; 0.3 s)")
    rows = fidelity_cost("paper-straight", sets, max(3, args.repeats // 2), extra={"mesh.preload": False})
    cost = {r["level"]: r for r in rows}
    print(render(["level", "wall s", "relative to rigid", "real-time factor"],
                 [[r["level"], f"{r['wall_s']:.4f}", f"{r['relative']:.1f}", f"{r['realtime_factor']:.1f}"]
                  for r in rows]))
    print("\n3. Real-time factor of each scene at its default fidelity")
    rows = realtime_factors(max(3, args.repeats // 2))
    rtf = {r["scene"]: r for r in rows}
    print(render(["scene", "simulated s", "wall s", "real-time factor", "fidelity"],
                 [[r["scene"], f"{r['simulated_s']:g}", f"{r['wall_s']:.3f}", f"{r['realtime_factor']:.1f}",
                   r["fidelity"]] for r in rows]))
    print("\n4. The targets of issues 5 and 19, from the numbers above (and docs/accuracy.md for solve_ivp)")
    targets = [[f"coupled / direct run, vehicle-cornering (step {o['step'] * 1e3:g} ms)", "<= 1.25",
                f"{o['ratio']:.2f}", o["ratio"] <= 1.25]]
    if "vehicle-cornering" in rtf:
        v = rtf["vehicle-cornering"]["realtime_factor"]
        targets.append([f"real-time factor, vehicle-cornering at rigid (step {o['step'] * 1e3:g} ms, one core)",
                        ">= 20", f"{v:.1f}", v >= 20.0])
    if "fmi_cpu_s" in o:
        rc, vc = o["ratio_cpu"], o["simulated_s"] / o["fmi_cpu_s"]
        targets.append(["  the same two in CPU time of the stepping thread: coupled / direct", "<= 1.25", f"{rc:.2f}",
                        rc <= 1.25])
        targets.append(["  real-time factor through FMI", ">= 20", f"{vc:.1f}", vc >= 20.0])
    if "contact" in cost:
        c = cost["contact"]["realtime_factor"]
        targets.append(["real-time factor, paper-straight at contact (unloaded start)", ">= 1", f"{c:.1f}", c >= 1.0])
    for restarted, label in ((False, "any"), (True, "restarted every 1 ms")):
        best = _solve_ivp_ratio(restarted)
        if best is not None:
            targets.append([f"our solver vs best solve_ivp ({label}) at equal accuracy (contact, best case)",
                            ">= 10", f"{best:.2f}", best >= 10.0])
    print(render(["target", "wanted", "measured", "met"],
                 [[a, b, c, "yes" if ok else "NO"] for a, b, c, ok in targets]))
    if o["ratio"] > 1.25:
        what = (f" (the set and get calls {call_us:.1f} us of it, the rest the master's step loop and fmi2DoStep)"
                if call_us is not None else "")
        print(f"   coupled / direct is bounded by the FMI path, {(per_fmi - per_direct) / o['instances']:.0f} us per "
              f"instance and step{what}, against {per_direct:.0f} us of physics per step: (physics + "
              f"{o['instances']} x FMI path) / physics; a larger step does not change it, cheaper physics makes it "
              f"worse: 1.25 needs the FMI path at most {0.25 * per_direct / o['instances']:.0f} us per instance and step.")
    if b and "vehicle-cornering" in rtf and rtf["vehicle-cornering"]["realtime_factor"] < 20.0:
        us = b["us_per_step"]
        print(f"   the real-time factor is bounded by the physics per {b['step'] * 1e3:g} ms step ("
              + ", ".join(f"{k} {v:.0f} us" for k, v in us.items())
              + f", CPU time) plus the FMI path; 20x needs {1e6 * b['step'] / 20:.0f} us per step for everything.")
    print("\n5. Fixed versus variable communication steps on tip-in-tip-out (errors: largest difference from a")
    print("   fixed 0.2 ms run at its 1 ms recording instants; variable: harness/stepcontrol.py, power-bond residual)")
    rows = step_control_comparison("tip-in-tip-out", max(3, args.repeats // 2))
    print(render(["run", "wall s", "steps", "rejected", "ratio error", "locking torque error N m"],
                 [[r["run"], f"{r['wall_s']:.3f}", str(r["steps"]), str(r["rejected"]),
                   f"{r['err_ratio']:.2e}", f"{r['err_lock']:.3g}"] for r in rows]))
    print("\n6. The mesh levels' compiled kernel against the Python reference (harness/bench/mesh.py; the same "
          "numbers bit for bit)")
    from harness.bench.mesh import kernel_report
    print("\n".join(kernel_report(args.repeats)))
    print(f"\n(bench took {time.perf_counter() - t0:.1f} s on {sys.platform}, python {sys.version.split()[0]}; "
          f"{_load()})")
    return 0
