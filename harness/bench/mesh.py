"""Measurements behind docs/mesh-dynamics.md: the paper's two cases at each mesh level, the
tolerance sweep that chose the default tolerance, and the comparison with scipy's solve_ivp on the
same differential ODE.

Run ``python -m harness.bench.mesh [--full] [--section paper|tolerance|ivp]``. The paper's cases
are read from the scenes ``paper-straight`` and ``paper-cornering`` (carrier speed, sun loads,
locking law, duration, step). Wall times are measured here and printed, never asserted.
"""
from __future__ import annotations

import math
import time

import numpy as np

from harness.metrics import metric_error
from harness.scene import load_scene
from spurdiff.mesh import MeshDifferential, MeshParams
from spurdiff.errors import StepError
from spurdiff.mesh.params import METHODS
from spurdiff.params import DifferentialParams
from spurdiff.rigid import RigidDifferential

PAPER_SCENES = ("paper-straight", "paper-cornering")
SCALE = np.array([1.0, 1e-5, 1e-5, 1e-5, 1.0, 1.0, 1.0, 1.0])  # state units for error norms


def paper_case(scene_name: str) -> dict:
    """Carrier speed, sun loads, locking law, duration and step of a paper scene (its differential
    instance ``diff`` with constant inputs)."""
    sc = load_scene(scene_name)
    inp = sc.inputs
    params = next(i.parameters for i in sc.instances if i.name == "diff")
    return {"w0": inp["diff.carrier.w_ref"].value, "loads": (inp["diff.left.tau"].value, inp["diff.right.tau"].value),
            "lockingLaw": params.get("lockingLaw", "pinFriction"), "duration": sc.duration, "step": sc.step}


def make(level: str, case: dict, **mesh):
    """A model of the paper case ``case`` (:func:`paper_case`) at ``level``, initialized."""
    p = DifferentialParams(lockingLaw=case["lockingLaw"])
    if level == "rigid":
        m = RigidDifferential(p)
    else:
        m = MeshDifferential(p, MeshParams(level=level, **mesh))
    m.w_ref, m.w_start_carrier = case["w0"], case["w0"]
    m.tau_L, m.tau_R = case["loads"]
    m.initialize()
    return m


def sample(m) -> list[float]:
    f = m.mesh_forces
    return [m.tau_drive, m.tau_mesh_L, m.tau_mesh_R, f.F_A1, f.F_B2, f.F_12, m.w_L, m.w_R]


def simulate(m, t_end=0.3, h=1e-3):
    """Step with the paper's 1 ms output step; returns (time averages, final sample, wall s)."""
    n = int(round(t_end / h))
    rows = [sample(m)]
    t0 = time.perf_counter()
    for k in range(n):
        m.do_step(k * h, h)
        rows.append(sample(m))
    wall = time.perf_counter() - t0
    rows = np.array(rows)
    return np.trapezoid(rows, dx=h, axis=0) / t_end, rows[-1], wall


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
    ``python -m harness.bench.mesh --section methods``."""
    rows = []
    for scene, mesh in METHOD_CASES:
        spec = paper_case(scene)
        ref = make(mesh["level"], spec, **{k: v for k, v in mesh.items() if k != "level"}, tolerance=1e-10)
        simulate(ref, 0.3)
        scale = np.maximum(np.abs(ref.y), SCALE)
        for tol in tols:
            for method in METHODS:
                walls = []
                for _ in range(repeats):
                    m = make(mesh["level"], spec, **{k: v for k, v in mesh.items() if k != "level"},
                             tolerance=tol, method=method)
                    walls.append(simulate(m, 0.3)[2])
                rows.append({"case": f"{scene}, {', '.join(f'{k}={v}' for k, v in mesh.items())}",
                             "tolerance": tol, "method": method, "steps": m.n_internal_steps, "wall": min(walls),
                             "error": float(np.max(np.abs(m.y - ref.y) / scale)),
                             "loss_error": abs(m.energy_loss - ref.energy_loss), "loss": ref.energy_loss})
    print("## The two methods in the do_step loop (1 ms, 0.3 s; errors against tolerance 1e-10, ROS34PW2)\n")
    print("| case | tolerance | method | internal steps | wall s | state error | loss error J (of loss J) |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['case']} | {r['tolerance']:g} | {r['method']} | {r['steps']} | {r['wall']:.4f} | "
              f"{r['error']:.1e} | {r['loss_error']:.1e} ({r['loss']:.4g}) |")
    print()
    return rows


def tight_tolerances(tols=(1e-8, 1e-9, 1e-10), t_end: float = 0.02) -> list[dict]:
    """Where tight tolerances end: paper-cornering at the contact level from unloaded meshes,
    every effect and each phase effect alone, 1 ms steps over ``t_end``, both methods; per case
    the internal steps or the failure (StepError: the internal step fell below 1e-13 s at a mesh
    phase boundary). Printed and returned. Command: ``python -m harness.bench.mesh --section
    tight``."""
    spec = paper_case("paper-cornering")
    cases = {"all effects": dict(backlash=True, meshStiffnessVariation=True, flankFriction=True),
             "stiffness wave": dict(meshStiffnessVariation=True), "flank friction": dict(flankFriction=True),
             "backlash": dict(backlash=True)}
    rows = []
    for name, eff in cases.items():
        for method in METHODS:
            for tol in tols:
                m = make("contact", spec, preload=False, tolerance=tol, method=method, maxInternalSteps=10 ** 6,
                         **eff)
                try:
                    for k in range(int(round(t_end / 1e-3))):
                        m.do_step(k * 1e-3, 1e-3)
                    how = f"{m.n_internal_steps} steps"
                except StepError as e:
                    how = f"fails: {e}"
                rows.append({"case": name, "method": method, "tolerance": tol, "result": how})
    print(f"## Tight tolerances (paper-cornering, contact, unloaded, {t_end:g} s at 1 ms)\n")
    print("| effects | method | tolerance | result |\n|---|---|---|---|")
    for r in rows:
        print(f"| {r['case']} | {r['method']} | {r['tolerance']:g} | {r['result']} |")
    print()
    return rows


def trajectory(m, t_end=0.3, h=1e-3, events=None):
    """States at the communication points of a do_step loop, and the wall time."""
    n = int(round(t_end / h))
    ys = [m.state_vector()]
    t0 = time.perf_counter()
    for k in range(n):
        if events and k in events:
            events[k](m)
        m.do_step(k * h, h)
        ys.append(m.state_vector())
    return np.array(ys), time.perf_counter() - t0


# the paper-straight case (its loads, carrier speed) started unloaded, and reversed
IVP_CASES = {
    "contact, unloaded start": (dict(level="contact", preload=False, pinFriction=False), 1.0),
    "compliant + backlash, reversal": (dict(level="compliant", backlash=True, pinFriction=False), -1.0),
}
IVP_METHODS = ("Radau", "BDF", "LSODA")


def ivp_model(case: str, tol: float = 1e-6, kernel: str = "auto", method: str = "ros34pw2") -> MeshDifferential:
    """A model of one of IVP_CASES: paper-straight's carrier speed and loads (default locking
    law; pin friction off), initialized with the loads, then the case's loads applied from t = 0
    (the same loads from unloaded meshes, or reversed); ``method``: solver.method."""
    mesh, sign = IVP_CASES[case]
    spec = paper_case("paper-straight")
    m = MeshDifferential(DifferentialParams(), MeshParams(tolerance=tol, maxInternalSteps=10 ** 7, kernel=kernel,
                                                         method=method, **mesh))
    m.w_ref, m.w_start_carrier = spec["w0"], spec["w0"]
    m.tau_L, m.tau_R = spec["loads"]
    m.initialize()
    m.tau_L, m.tau_R = sign * spec["loads"][0], sign * spec["loads"][1]   # applied from t = 0
    return m


# our solver with each of its methods (solver.method: ROS34PW2, RODAS5P) as the FMU runs it (a do_step
# per 1 ms communication step, compiled kernel or the Python reference: the same numbers), and over the
# whole run in one call as solve_ivp's one call with t_eval (MeshDifferential.run_dense: internal steps
# not cut at the communication points, the states there by the dense output), with the loss quadrature
# as the FMU integrates it and without (the states alone, the same outputs as solve_ivp's); keys
# "<method> <how>"
OURS = {f"{meth} {how}": f"ours {name}, {label}"
        for meth, name in (("ros34pw2", "ROS34PW2"), ("rodas5p", "RODAS5P"))
        for how, label in (("compiled", "compiled (do_step loop)"), ("python", "Python (do_step loop)"),
                           ("one call", "compiled, one call"), ("states only", "compiled, one call, states only"))}


def ours_trajectory(case: str, tol: float, impl: str, t_end: float = 0.3, h: float = 1e-3):
    """States at the communication points, the wall time and the solver counts of our solver
    (``impl`` a key of OURS, or a way alone: "compiled", "python", "one call", "states only", the
    default method)."""
    first, _, rest = impl.partition(" ")
    method, impl = (first, rest) if first in METHODS else ("ros34pw2", impl)
    m = ivp_model(case, tol, "python" if impl == "python" else "compiled", method)
    if impl in ("compiled", "python"):
        ys, wall = trajectory(m, t_end, h)
        return ys, wall, m.solver_counts()
    if impl == "states only":
        m.states_only()
    n = int(round(t_end / h))
    times = np.arange(1, n + 1) * h
    y0 = m.state_vector()
    t0 = time.perf_counter()
    ys = m.run_dense(t_end, times)
    return np.vstack([y0, ys]), time.perf_counter() - t0, m.solver_counts()


OUTPUT_NAMES = ("tau_drive", "tau_mesh_L", "tau_mesh_R", "F_A1", "F_B2", "F_12")


def output_metrics(m: MeshDifferential, ys: np.ndarray, h: float = 1e-3) -> dict[str, float]:
    """The paper scenes' table metrics along a trajectory of states at the communication points:
    time mean (trapezoid), max and min of the carrier torque, the two sun torques and the three
    mesh forces (the outputs evaluated at each state)."""
    rows = []
    for y in ys:
        m.load_state_vector(y)
        rows.append(sample(m)[:6])
    rows = np.array(rows)
    mean = np.trapezoid(rows, dx=h, axis=0) / (h * (len(rows) - 1))
    out = {}
    for j, q in enumerate(OUTPUT_NAMES):
        out[f"mean({q})"], out[f"max({q})"], out[f"min({q})"] = mean[j], rows[:, j].max(), rows[:, j].min()
    return out


def ivp_functions(m: MeshDifferential):
    """The right-hand side and Jacobian for solve_ivp as lean as a user would write them: the
    compiled kernel's evaluation called directly (a ctypes call into the model's packed state, no
    per-call packing), else the Python reference's (``m.rhs``/``m.jac``). The same numbers."""
    if m._kernel is None:
        return m.rhs, m.jac
    import ctypes

    from spurdiff.mesh.layout import constant_jacobian

    k = m._kernel
    k.evaluate(m, m.state_vector(), np.zeros(m._N), None)     # packs the model's inputs and modes once
    ev, pP, pS, N = k.lib.mk_evaluate, k._pP, k._pS, m._N
    sv = (ctypes.c_double * 13)()      # (kept alive by the closures: they hold sv itself)
    psv, fbuf = ctypes.addressof(sv), np.zeros(N)
    J0 = np.zeros((N, N))
    constant_jacobian(J0, m.rbA, m.rb1, m.rbB, m.rb2, m.speed_drive)

    def rhs(t, y, _keep=(sv, k)):
        y = np.ascontiguousarray(y)
        f = np.empty(N)
        ev(pP, pS, y.ctypes.data, f.ctypes.data, None, psv)
        return f

    def jac(t, y, _keep=(sv, k)):
        y = np.ascontiguousarray(y)
        J = J0.copy()
        ev(pP, pS, y.ctypes.data, fbuf.ctypes.data, J.ctypes.data, psv)
        return J
    return rhs, jac


# solve_ivp's sweep: rtol = tol, atol = SCALE * tol * factor; LSODA (the best of the three here) also
# with atol 100 times smaller and larger and down to tol 1e-10, so that it gets its best setting
IVP_TOLS = {"Radau": (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8), "BDF": (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8),
            "LSODA": (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)}
IVP_ATOL_FACTORS = {"Radau": (1.0,), "BDF": (1.0,), "LSODA": (1.0, 1e-2, 1e2)}


def ivp_name(method: str, factor: float, restarted: bool) -> str:
    how = "restarted every 1 ms" if restarted else "one call"
    return f"solve_ivp {method}{'' if factor == 1.0 else f' (atol x{factor:g})'}, {how}"


def ivp_points(case: str, tols=(1e-4, 1e-6, 1e-8), methods=IVP_METHODS, restarted: bool = True,
               ivp_tols=None) -> list[dict]:
    """Work-precision points of one case: ours (OURS) and solve_ivp (analytic Jacobian, the lean
    callbacks of :func:`ivp_functions`, the states at the 301 output points by t_eval; one call over
    0.3 s and, as a co-simulation slave must, restarted at every 1 ms communication point, with
    atol = SCALE * tol); ``ivp_tols``: solve_ivp's tolerances per method (IVP_TOLS; one-call LSODA
    also with the atol factors of IVP_ATOL_FACTORS), default ``tols``. Errors against a
    tolerance-1e-11 run of ours: ``error``, the max scaled state error at the 301 output points;
    ``metric_error``, the paper scenes' table metrics along the trajectory (:func:`output_metrics`,
    :func:`metric_error`). Work: ours ``steps``, ``rejected``, ``njev`` (Jacobian evaluations),
    ``nlu`` (factorizations); solve_ivp ``nfev``, ``njev``, ``nlu``."""
    from scipy.integrate import solve_ivp

    ref, _ = trajectory(ivp_model(case, 1e-11))
    probe = ivp_model(case)            # evaluates the outputs along every trajectory
    ref_metrics = output_metrics(probe, ref)
    nan = float("nan")

    def errors(ys: np.ndarray) -> dict:
        if not np.all(np.isfinite(ys)):
            return {"error": nan, "metric_error": nan}
        return {"error": float(np.max(np.abs(ys - ref) / SCALE)),
                "metric_error": float(metric_error(output_metrics(probe, ys), ref_metrics))}

    out = []
    for tol in tols:
        for impl in OURS:
            ys, wall, cnt = ours_trajectory(case, tol, impl)
            if wall < 0.5:      # the fastest of five, as best_of (the set-up is not timed)
                wall = min([wall] + [ours_trajectory(case, tol, impl)[1] for _ in range(4)])
            out.append({"case": case, "integrator": OURS[impl], "tolerance": tol, "atol_factor": 1.0, **errors(ys),
                        "wall": wall, "nfev": None, "steps": cnt["steps"], "rejected": cnt["rejected"],
                        "njev": cnt["jacobians"], "nlu": cnt["factorizations"]})
    for method in methods:
        for factor in (IVP_ATOL_FACTORS.get(method, (1.0,)) if ivp_tols else (1.0,)):
            for tol in (ivp_tols or {}).get(method, tols):
                m = ivp_model(case)      # its rhs and jac: the compiled kernel's evaluation where it loads
                m._ac = 0.0
                y0 = m.state_vector()
                rhs, jac = ivp_functions(m)
                atol = SCALE * tol * factor
                sol, w1 = best_of(lambda: solve_ivp(rhs, (0.0, 0.3), y0, method=method, rtol=tol, atol=atol,
                                                    jac=jac, t_eval=np.linspace(0.0, 0.3, 301)))
                e1 = errors(sol.y.T) if sol.success else {"error": nan, "metric_error": nan}
                out.append({"case": case, "integrator": ivp_name(method, factor, False), "tolerance": tol,
                            "atol_factor": factor, **e1, "wall": w1, "nfev": sol.nfev, "steps": None,
                            "rejected": None, "njev": int(sol.njev), "nlu": int(sol.nlu)})
                if not restarted or factor != 1.0 or tol < min(tols):
                    continue

                def restarts():
                    y, ys, cnt = y0.copy(), [y0], [0, 0, 0]
                    for k in range(300):
                        st = solve_ivp(rhs, (k * 1e-3, (k + 1) * 1e-3), y, method=method, rtol=tol, atol=atol,
                                       jac=jac)
                        y = st.y[:, -1]
                        ys.append(y)
                        cnt = [cnt[0] + st.nfev, cnt[1] + int(st.njev), cnt[2] + int(st.nlu)]
                    return ys, cnt
                (ys, cnt), w2 = best_of(restarts)
                out.append({"case": case, "integrator": ivp_name(method, factor, True), "tolerance": tol,
                            "atol_factor": factor, **errors(np.array(ys)), "wall": w2, "nfev": cnt[0],
                            "steps": None, "rejected": None, "njev": cnt[1], "nlu": cnt[2]})
    return out


def best_of(fn, repeats: int = 5, budget: float = 0.5):
    """(result, wall s) of ``fn``: the fastest of ``repeats`` runs while a run takes less than
    ``budget`` s (machine noise only ever adds time), else of one run."""
    walls, res = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = fn()
        walls.append(time.perf_counter() - t0)
        if walls[-1] > budget:
            break
    return res, min(walls)


def ivp() -> None:
    """The same ODE integrated by our do_step loop and by solve_ivp: see :func:`ivp_points`.
    Two cases without friction-mode switches (pin friction off): the contact level from unloaded
    meshes (a ms transient, then static) and the compliant level with backlash, preloaded,
    reversed at t = 0 (impacts, rattle, then static)."""
    print("## Against scipy solve_ivp on the same ODE (0.3 s, 1 ms outputs)\n")
    print("| case | integrator | tolerance | max scaled error at the outputs | wall s | RHS evaluations |")
    print("|---|---|---|---|---|---|")
    for case in IVP_CASES:
        for p in ivp_points(case):
            print(f"| {case} | {p['integrator']} | {p['tolerance']:g} | {p['error']:.1e} | {p['wall']:.3f} "
                  f"| {'-' if p['nfev'] is None else p['nfev']} |")
    print()


def step_bound(tols=(1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8), case: str = "contact, unloaded start",
               quadrature_state: str | None = None, t_end: float = 0.3, h: float = 1e-3,
               ref_tol: float = 1e-11) -> list[dict]:
    """Which error estimate sets the step of our solver over ``case`` in one call (run_dense, the
    states at the 1 ms points), measured on the Python reference (the kernel's arithmetic bit for
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
    returned. Command: ``python -m harness.bench.mesh --section step-bound`` (all three)."""
    if quadrature_state not in (None, "zero row", "gradient"):
        raise ValueError(f"quadrature_state = {quadrature_state!r}: allowed None, 'zero row', 'gradient'")
    import statistics

    import spurdiff.mesh.stepper as stepper
    from spurdiff.mesh.integrator import METHOD, RosenbrockW

    times = np.arange(1, int(round(t_end / h)) + 1) * h
    ref = ivp_model(case, ref_tol)
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
            g, F = np.zeros(y.size), np.zeros(y.size)
            for k in range(y.size):
                d = 1e-6 * max(abs(y[k]), SCALE[k] if k < SCALE.size else 1.0)
                yp, ym = y.copy(), y.copy()
                yp[k] += d
                ym[k] -= d
                g[k] = (ev(yp, F, None).P - ev(ym, F, None).P) / (2.0 * d)
            grad[0] = (g, self.U)
        return ok

    def loss_quadrature(P0, Pm, P1, hs, rtol):
        if quadrature_state:
            u: list[float] = []
            for i, Pi in enumerate([P0] + stage_P):
                s = Pi + (float(grad[0][0] @ grad[0][1][i]) if quadrature_state == "gradient" else 0.0)
                for j in range(i):
                    s += METHOD.c_lists[i][j] / hs * u[j]
                u.append(METHOD.gamma * hs * s)
            d = sum(w * x for w, x in zip(METHOD.m_list, u))
            e = abs(sum(w * x for w, x in zip(METHOD.e_list, u))) / (rtol * (stepper.E_REF + abs(d)))
        else:
            d, e = keep[1](P0, Pm, P1, hs, rtol)
        trials.append(("loss", e))
        return d, e

    rows = []
    stepper.error_norm, stepper.loss_quadrature, RosenbrockW.step = error_norm, loss_quadrature, step
    try:
        for tol in tols:
            trials.clear()
            m = ivp_model(case, tol, "python")
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

    from harness.master import run_scene
    from harness.runner import fmu_files_for, prepare_scene

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

    from harness.accuracy import FACTS_FILE, equal_accuracy_ratios, ivp_error_key

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
    from harness.report import render

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


if __name__ == "__main__":   # the command line is harness/cli/mesh_bench.py
    from harness.cli.mesh_bench import main

    main()
