"""Measurements behind docs/mesh-dynamics.md: the paper's two cases at each mesh level, the
tolerance sweep that chose the default tolerance, and the comparison with scipy's solve_ivp on the
same differential ODE (:mod:`harness.measure.bench.mesh_ivp`; the cases: :mod:`harness.measure.bench.mesh_cases`).

Run ``python -m harness.cli.tools.mesh_bench [--full] [--section paper|tolerance|ivp]``. The paper's cases
are read from the scenes ``paper-straight`` and ``paper-cornering`` (carrier speed, sun loads,
locking law, duration, step). Wall times are measured here and printed, never asserted.

(About 400 lines: one function per measurement of docs/mesh-dynamics.md; the solve_ivp
comparison is :mod:`harness.measure.bench.mesh_ivp`, the paper's cases :mod:`harness.measure.bench.mesh_cases`.)
"""
from __future__ import annotations

import math
import time

import numpy as np

from harness.measure.bench.mesh_cases import PAPER_SCENES, SCALE, make, paper_case, simulate
from harness.measure.bench.mesh_ivp import OURS, ivp, ivp_model
from spurdiff.differential.mesh import MeshDifferential, MeshParams
from spurdiff.errors import StepError
from spurdiff.differential.mesh.params import METHODS
from spurdiff.differential.params import DifferentialParams

def paper(full: bool) -> None:
    levels = [("rigid", {}), ("compliant", {}), ("contact", {})]
    extra = [("contact", dict(backlash=True, flankFriction=True, meshStiffnessVariation=True))]
    print("## The paper's cases (means over 0.3 s, 1 ms output step; torques N m, forces N)\n")
    print("| case | level | effects | carrier | sun A | sun B | F_A1 | F_B2 | F_12 | w_A(0.3 s) | w_B(0.3 s) "
          "| wall s | x real time | internal steps |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for case in PAPER_SCENES:
        spec = paper_case(case)
        for level, mesh in levels + (extra if full or case == "paper-straight" else []):
            m = make(level, spec, **mesh)
            mean, last, wall = simulate(m, spec["duration"], spec["step"])
            eff = ", ".join(m.active_effects[1:]) if level != "rigid" else "-"
            steps = getattr(m, "n_internal_steps", m.n_steps)
            print(f"| {case} | {level} | {eff} | {mean[0]:.2f} | {mean[1]:.2f} | {mean[2]:.2f} | {mean[3]:.1f} | "
                  f"{mean[4]:.1f} | {mean[5]:.1f} | {last[6]:.2f} | {last[7]:.2f} | {wall:.3f} | {0.3 / wall:.1f} | "
                  f"{steps} |")
    print()


def tolerance() -> None:
    print("## Tolerance sweep (start with unloaded meshes: a real transient; means over 0.1 s)\n")
    print("| level | tolerance | max rel. error of the 6 means vs tolerance 1e-10 | |energy balance| J "
          "| internal steps | wall s |")
    print("|---|---|---|---|---|---|")
    spec = paper_case("paper-straight")
    for level in ("compliant", "contact"):
        ref, _, _ = simulate(make(level, spec, preload=False, tolerance=1e-10), 0.1)
        for tol in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8):
            m = make(level, spec, preload=False, tolerance=tol)
            e0 = m.kinetic_energy + m.potential_energy
            mean, _, wall = simulate(m, 0.1)
            err = np.max(np.abs(mean[:6] - ref[:6]) / np.abs(ref[:6]))
            bal = abs(m.work_in - (m.kinetic_energy + m.potential_energy - e0) - m.energy_loss)
            print(f"| {level} | {tol:g} | {err:.2e} | {bal:.1e} | {m.n_internal_steps} | {wall:.3f} |")
    print()


# the cases of the method comparison: (scene, level and effects), all from unloaded meshes but the first
METHOD_CASES = (
    ("paper-straight", dict(level="contact")),
    ("paper-straight", dict(level="contact", preload=False)),
    ("paper-cornering", dict(level="contact", preload=False)),
    ("paper-straight", dict(level="contact", preload=False, backlash=True, meshStiffnessVariation=True,
                            flankFriction=True)),
    ("paper-cornering", dict(level="compliant", preload=False, backlash=True)),
)


def methods(tols=(1e-4, 1e-6, 1e-8), repeats: int = 3) -> list[dict]:
    """The two integration methods (solver.method) as the FMU runs them: a do_step per 1 ms over
    0.3 s of the paper scenes (METHOD_CASES), per tolerance: internal steps, wall (fastest of
    ``repeats``), the largest scaled state error at the end and the loss error against a
    tolerance-1e-10 ROS34PW2 run. Printed and returned. Command:
    ``python -m harness.cli.tools.mesh_bench --section methods``."""
    rows = []
    for scene, mesh in METHOD_CASES:
        spec = paper_case(scene)
        ref = make(mesh["level"], spec, **{k: v for k, v in mesh.items() if k != "level"}, tolerance=1e-10)
        simulate(ref, 0.3)
        scale = np.maximum(np.abs(np.array(list(ref.y))), SCALE)
        for tol in tols:
            for method in METHODS:
                walls = []
                for _ in range(repeats):
                    m = make(mesh["level"], spec, **{k: v for k, v in mesh.items() if k != "level"},
                             tolerance=tol, method=method)
                    walls.append(simulate(m, 0.3)[2])
                rows.append({"case": f"{scene}, {', '.join(f'{k}={v}' for k, v in mesh.items())}",
                             "tolerance": tol, "method": method, "steps": m.n_internal_steps, "wall": min(walls),
                             "error": float(np.max(np.abs(np.array(list(m.y)) - np.array(list(ref.y))) / scale)),
                             "loss_error": abs(m.energy_loss - ref.energy_loss), "loss": ref.energy_loss})
    print("## The two methods in the do_step loop (1 ms, 0.3 s; errors against tolerance 1e-10, ROS34PW2)\n")
    print("| case | tolerance | method | internal steps | wall s | state error | loss error J (of loss J) |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['case']} | {r['tolerance']:g} | {r['method']} | {r['steps']} | {r['wall']:.4f} | "
              f"{r['error']:.1e} | {r['loss_error']:.1e} ({r['loss']:.4g}) |")
    print()
    return rows


def tight_tolerances(tols=(1e-8, 1e-9, 1e-10), t_end: float = 0.02,
                     scenes=("paper-cornering", "paper-straight")) -> list[dict]:
    """Tight tolerances through the mesh-phase boundaries: the paper scenes at the contact level
    from unloaded meshes, every effect and each phase effect alone, 1 ms steps over ``t_end``,
    both methods; per case the internal steps (rejected), the loaded flanks' single/double
    contact switches, the CPU time of the run (compiled kernel where it loads) or the failure
    (StepError). Printed and returned. Command: ``python -m harness.cli.tools.mesh_bench --section
    tight``."""
    cases = {"all effects": dict(backlash=True, meshStiffnessVariation=True, flankFriction=True),
             "stiffness wave": dict(meshStiffnessVariation=True), "flank friction": dict(flankFriction=True),
             "backlash": dict(backlash=True)}
    rows = []
    for scene in scenes:
        spec = paper_case(scene)
        for name, eff in cases.items():
            for method in METHODS:
                for tol in tols:
                    m = make("contact", spec, preload=False, tolerance=tol, method=method,
                             maxInternalSteps=10 ** 6, **eff)
                    t0 = time.process_time()
                    try:
                        for k in range(int(round(t_end / 1e-3))):
                            m.do_step(k * 1e-3, 1e-3)
                        how = "ok"
                    except StepError as e:
                        how = f"fails: {e}"
                    cpu = time.process_time() - t0
                    rows.append({"scene": scene, "case": name, "method": method, "tolerance": tol,
                                 "steps": m.n_internal_steps, "rejected": m.n_rejected_steps,
                                 "switches": m.solver_counts()["phase_switches"], "cpu": cpu, "result": how})
    print(f"## Tight tolerances (contact, unloaded, {t_end:g} s at 1 ms; CPU s of the run)\n")
    print("| scene | effects | method | tolerance | internal steps (rejected) | phase switches | CPU s | result |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['scene']} | {r['case']} | {r['method']} | {r['tolerance']:g} | {r['steps']} ({r['rejected']}) | "
              f"{r['switches']} | {r['cpu']:.3f} | {r['result']} |")
    print()
    return rows


def step_bound(tols=(1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8), case: str = "contact, unloaded start",
               quadrature_state: str | None = None, t_end: float = 0.3, h: float = 1e-3,
               ref_tol: float = 1e-11) -> list[dict]:
    """Which error estimate sets the step of ROS34PW2 (solver.method = ros34pw2) over ``case`` in one
    call (run_dense, the states at the 1 ms points), measured on the Python reference (the kernel's arithmetic bit for
    bit) by wrapping the driver's two tests: per trial step, the state error norm (rejects if > 1)
    and then the loss quadrature's (rejects if > 1); of the trials that pass both, ``loss_limited``
    counts those where the loss estimate is the larger (it then sets the next step size). With
    ``quadrature_state``, an experiment: the loss integrated as a quadrature state ``E' = P(y)``
    inside the Rosenbrock method instead of Simpson over the dense output, with the stage powers
    ``u_E,i = gamma h (P(Y_i) + g . u_i + sum_j c_ij u_E,j / h)`` (``u_i`` the states' transformed
    stages; the order-3 weights for the loss, the embedded difference for its error, scaled as the
    Simpson estimate's); ``"zero row"``: g = 0 (a W-method keeps its order with any Jacobian row),
    ``"gradient"``: g = dP/dy at the step's start by central differences (8 extra evaluations per
    step: a measurement of the step counts and the accuracy, not of the cost). ``loss_error``:
    against a run at ``ref_tol`` with the Simpson loss (compiled kernel where it loads). Printed and
    returned. Command: ``python -m harness.cli.tools.mesh_bench --section step-bound`` (all three)."""
    if quadrature_state not in (None, "zero row", "gradient"):
        raise ValueError(f"quadrature_state = {quadrature_state!r}: allowed None, 'zero row', 'gradient'")
    import statistics

    import spurdiff.differential.mesh.stepper as stepper
    from spurdiff.differential.mesh.integrator import METHOD, RosenbrockW

    times = np.arange(1, int(round(t_end / h)) + 1) * h
    ref = ivp_model(case, ref_tol, method="ros34pw2")
    ref.run_dense(t_end, times)
    trials: list[tuple[str, float]] = []
    stage_P: list[float] = []
    grad: list = [None]
    keep = stepper.error_norm, stepper.loss_quadrature, RosenbrockW.step

    def error_norm(*a):
        e = keep[0](*a)
        trials.append(("state", e))
        return e

    def step(self, y, f0, hs):
        ev = self.evaluate

        def ev_p(Y, F, J):
            sv = ev(Y, F, J)
            stage_P.append(sv.P)
            return sv
        stage_P.clear()
        self.evaluate = ev_p
        try:
            ok = keep[2](self, y, f0, hs)
        finally:
            self.evaluate = ev
        if quadrature_state == "gradient":
            g, F = np.zeros(len(y)), [0.0] * len(y)
            for k in range(len(y)):
                d = 1e-6 * max(abs(y[k]), SCALE[k] if k < SCALE.size else 1.0)
                yp, ym = list(y), list(y)
                yp[k] += d
                ym[k] -= d
                g[k] = (ev(yp, F, None).P - ev(ym, F, None).P) / (2.0 * d)
            grad[0] = (g, [np.array(u) for u in self.U])
        return ok

    def loss_quadrature(P0, Pm, P1, hs, rtol):
        if quadrature_state:
            u: list[float] = []
            for i, Pi in enumerate([P0] + stage_P):
                s = Pi + (float(grad[0][0] @ grad[0][1][i]) if quadrature_state == "gradient" else 0.0)
                for j in range(i):
                    s += METHOD.c_rows[i][j] / hs * u[j]
                u.append(METHOD.gamma * hs * s)
            d = sum(w * x for w, x in zip(METHOD.m, u))
            e = abs(sum(w * x for w, x in zip(METHOD.e, u))) / (rtol * (stepper.E_REF + abs(d)))
        else:
            d, e = keep[1](P0, Pm, P1, hs, rtol)
        trials.append(("loss", e))
        return d, e

    rows = []
    stepper.error_norm, stepper.loss_quadrature, RosenbrockW.step = error_norm, loss_quadrature, step
    try:
        for tol in tols:
            trials.clear()
            m = ivp_model(case, tol, "python", "ros34pw2")
            m.run_dense(t_end, times)
            rej_s = rej_l = lim_l = lim_s = 0
            ratios = []
            for k, (kind, e) in enumerate(trials):
                if kind != "state":
                    continue
                if not e <= 1.0:
                    rej_s += 1
                elif k + 1 < len(trials) and trials[k + 1][0] == "loss":
                    el = trials[k + 1][1]
                    if not el <= 1.0:
                        rej_l += 1
                    else:
                        lim_l += el > e
                        lim_s += el <= e
                        ratios.append((e, el))
                else:
                    lim_s += 1
            cnt = m.solver_counts()
            how = f"state, {quadrature_state}" if quadrature_state else "Simpson"
            rows.append({"tolerance": tol, "quadrature": how,
                         "steps": cnt["steps"], "rejected_state": rej_s, "rejected_loss": rej_l,
                         "loss_limited": lim_l, "state_limited": lim_s,
                         "median_state_err": statistics.median(r[0] for r in ratios) if ratios else math.nan,
                         "median_loss_err": statistics.median(r[1] for r in ratios) if ratios else math.nan,
                         "loss_error": abs(m.energy_loss - ref.energy_loss)})
    finally:
        stepper.error_norm, stepper.loss_quadrature, RosenbrockW.step = keep
    print(f"## Which error estimate sets the step ({case}, one call over {t_end:g} s, Python reference)\n")
    print("| loss by | tol | steps | rejected: state / loss | passing both: loss-limited / state-limited | "
          "median error norm: state / loss | loss error (J) |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['quadrature']} | {r['tolerance']:g} | {r['steps']} | {r['rejected_state']} / {r['rejected_loss']} "
              f"| {r['loss_limited']} / {r['state_limited']} | {r['median_state_err']:.2f} / "
              f"{r['median_loss_err']:.2f} | {r['loss_error']:.1e} |")
    print()
    return rows


# ---------------------------------------------------------------- the compiled kernel (issue 17)
def _paper_model(impl: str, **mesh) -> MeshDifferential:
    spec = paper_case("paper-straight")
    m = MeshDifferential(DifferentialParams(lockingLaw=spec["lockingLaw"]),
                         MeshParams(level="contact", kernel=impl, **mesh))
    m.w_ref = m.w_start_carrier = spec["w0"]
    m.tau_L, m.tau_R = spec["loads"]
    m.initialize()
    return m


def step_costs(repeats: int = 3) -> dict[str, dict]:
    """Per implementation (python, compiled), medians of ``repeats`` direct runs of paper-straight
    at the contact level, 0.3 s at 1 ms: microseconds per internal step from unloaded meshes (the
    start transient) and per communication step preloaded (quasi-static, about one internal step
    per communication step). Interleaved, so machine load hits both."""
    import statistics

    out: dict[str, dict] = {k: {"internal": [], "comm": [], "steps_per_comm": 0.0} for k in ("python", "compiled")}
    for _ in range(repeats):
        for impl in out:
            for key, mesh in (("internal", {"preload": False}), ("comm", {})):
                m = _paper_model(impl, **mesh)
                t0 = time.perf_counter()
                for k in range(300):
                    m.do_step(k * 1e-3, 1e-3)
                wall = time.perf_counter() - t0
                out[impl][key].append(1e6 * wall / (m.n_internal_steps if key == "internal" else 300))
                if key == "comm":
                    out[impl]["steps_per_comm"] = m.n_internal_steps / 300
        for method, name in (("ros34pw2", "in_kernel"), ("rodas5p", "in_kernel_rodas5p")):
            m = _paper_model("compiled", preload=False, method=method)     # the same run without leaving C
            t0 = time.perf_counter()
            m._kernel.run(m, 0.0, 1e-3, 300)
            out["compiled"].setdefault(name, []).append(1e6 * (time.perf_counter() - t0) / m.n_internal_steps)
    return {impl: {k: statistics.median(v) if isinstance(v, list) else v for k, v in d.items()}
            for impl, d in out.items()}


ALL_EFFECTS = {"meshModel": "contact", "backlash": True, "meshStiffnessVariation": True, "flankFriction": True,
               "pinFriction": True, "mesh.preload": False}


def fmu_realtime(repeats: int = 3) -> dict[str, float]:
    """Real-time factor of paper-straight at the contact level with all effects, from unloaded
    meshes, through FMI (our master), per implementation (solver.kernel); medians, interleaved."""
    import statistics
    from dataclasses import replace

    from harness.run.master import run_scene
    from harness.run.runner import fmu_files_for, prepare_scene

    scene = prepare_scene("paper-straight")
    runs = {impl: replace(scene, effects={**scene.effects, **ALL_EFFECTS, "solver.kernel": impl})
            for impl in ("python", "compiled")}
    files = fmu_files_for(runs["compiled"])
    walls: dict[str, list] = {impl: [] for impl in runs}
    for sc in runs.values():
        run_scene(sc, files)   # warm-up
    for _ in range(repeats):
        for impl, sc in runs.items():
            r = run_scene(sc, files)
            if not r.ok:
                raise RuntimeError(f"paper-straight ({impl}) failed: {r.failure}")
            walls[impl].append(r.wall_time)
    return {impl: scene.duration / statistics.median(w) for impl, w in walls.items()}


def solver_ratios() -> list[dict]:
    """Our solver against the best solve_ivp variant at equal accuracy, contact level (the stored
    points of `spurdiff accuracy`, error on the paper scenes' metrics): per variant of ours, the
    lowest and the highest ratio over its tolerances and the ratio at the default tolerance (1e-6), against every
    solve_ivp variant and against solve_ivp restarted every communication step."""
    import json

    from harness.measure.accuracy import FACTS_FILE, equal_accuracy_ratios, ivp_error_key

    ivp = json.loads(FACTS_FILE.read_text()).get("ivp") or []
    key = ivp_error_key(ivp)
    rows = []
    for label, pts in (("any", ivp), ("restarted", [p for p in ivp if "restarted" in p["integrator"]
                                                    or p["integrator"].startswith("ours")])):
        for name in OURS.values():
            if label == "restarted" and "one call" in name:
                continue
            r = [x for x in equal_accuracy_ratios([p for p in pts if not p["integrator"].startswith("ours")
                                                   or p["integrator"] == name], key)
                 if x["case"].startswith("contact") and x["ratio"] is not None]
            if r:
                at = [x["ratio"] for x in r if x["tolerance"] == 1e-6]
                rows.append({"ours": name, "against": label, "best": max(x["ratio"] for x in r),
                             "worst": min(x["ratio"] for x in r), "at_1e-6": at[0] if at else None})
    return rows


def _ratio(x: float) -> str:
    return f"{x:.1f}" if x >= 1.0 else f"{x:.2f}"


def kernel_report(repeats: int = 3) -> list[str]:
    """The lines `spurdiff bench` prints for the compiled kernel."""
    from harness.run.report import render

    c = step_costs(repeats)
    rt = fmu_realtime(repeats)
    py, cc = c["python"], c["compiled"]
    rows = [["per internal step, contact from unloaded meshes, do_step loop (us)", f"{py['internal']:.1f}",
             f"{cc['internal']:.1f}", f"{py['internal'] / cc['internal']:.1f}"],
            ["per internal step, the same run in one call (C only) (us)", "", f"{cc['in_kernel']:.2f}", ""],
            ["  the same with solver.method = rodas5p (8 stages, a Jacobian every step) (us)", "",
             f"{cc['in_kernel_rodas5p']:.2f}", ""],
            [f"per communication step, contact preloaded, 1 ms ({cc['steps_per_comm']:.2f} internal) (us)",
             f"{py['comm']:.1f}", f"{cc['comm']:.1f}", f"{py['comm'] / cc['comm']:.1f}"],
            ["real-time factor, paper-straight contact all effects, unloaded, through FMI",
             f"{rt['python']:.2f}", f"{rt['compiled']:.2f}", f"{rt['compiled'] / rt['python']:.1f}"]]
    lines = [render(["measure", "python", "compiled", "speed-up"], rows)]
    ratios = solver_ratios()
    if ratios:
        lines.append("   our solver vs the best solve_ivp at equal accuracy (contact, unloaded start; stored by "
                     "`spurdiff accuracy --only-ivp`, >= 10 wanted):")
        lines.append(render(["ours", "solve_ivp variants", "ratio, tolerance 1e-3 ... 1e-8", "at 1e-6"],
                            [[r["ours"], "restarted every 1 ms" if r["against"] == "restarted" else "any (one call too)",
                              f"{_ratio(r['worst'])} to {_ratio(r['best'])}",
                              "-" if r["at_1e-6"] is None else _ratio(r["at_1e-6"])] for r in ratios]))
    return lines


def run(full: bool, sections, repeats: int = 3) -> None:
    """The ``sections`` ("kernel", "paper", "tolerance", "ivp", "step-bound"), printed; ``full``: also
    cornering with all effects; ``repeats``: timing repeats of the kernel section. "step-bound" is
    :func:`step_bound` as built and with both quadrature-state experiments."""
    if "kernel" in sections:
        print("\n".join(kernel_report(repeats)))
    if "paper" in sections:
        paper(full)
    if "tolerance" in sections:
        tolerance()
    if "ivp" in sections:
        ivp()
    if "step-bound" in sections:
        for variant in (None, "zero row", "gradient"):
            step_bound(quadrature_state=variant)
    if "methods" in sections:
        methods()
    if "tight" in sections:
        tight_tolerances()
