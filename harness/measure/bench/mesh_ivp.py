"""Our mesh solver and scipy's solve_ivp on the same differential ODE: the two cases
(:data:`IVP_CASES`), our solver's variants (:data:`OURS`), solve_ivp's sweep and the work-precision
points of both (:func:`ivp_points`), printed by :func:`ivp` (``python -m harness.cli.tools.mesh_bench
--section ivp``) and stored by ``spurdiff accuracy --only-ivp`` (:mod:`harness.measure.accuracy.ivp`).
Times (CPU time of this thread, :data:`CLOCK`: what one core spends, whatever else a shared machine
runs; every run single-threaded) are measured and printed, never asserted."""
from __future__ import annotations

import time

import numpy as np

from harness.measure.bench.mesh_cases import SCALE, paper_case, sample, trajectory
from harness.run.metrics import metric_error
from spurdiff.differential.mesh import MeshDifferential, MeshParams
from spurdiff.differential.mesh.params import METHODS
from spurdiff.differential.params import DifferentialParams


# the paper-straight case (its loads, carrier speed) started unloaded, and reversed
IVP_CASES = {
    "contact, unloaded start": (dict(level="contact", preload=False, pinFriction=False), 1.0),
    "compliant + backlash, reversal": (dict(level="compliant", backlash=True, pinFriction=False), -1.0),
}
IVP_METHODS = ("Radau", "BDF", "LSODA")
CLOCK = time.thread_time


def ivp_model(case: str, tol: float = 1e-6, kernel: str = "auto", method: str | None = None) -> MeshDifferential:
    """A model of one of IVP_CASES: paper-straight's carrier speed and loads (default locking
    law; pin friction off), initialized with the loads, then the case's loads applied from t = 0
    (the same loads from unloaded meshes, or reversed); ``method``: solver.method."""
    mesh, sign = IVP_CASES[case]
    spec = paper_case("paper-straight")
    m = MeshDifferential(DifferentialParams(), MeshParams(tolerance=tol, maxInternalSteps=10 ** 7, kernel=kernel,
                                                         method=method or "auto", **mesh))
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
    """States at the communication points, the time (:data:`CLOCK`) and the solver counts of our solver
    (``impl`` a key of OURS, or a way alone: "compiled", "python", "one call", "states only", the
    default method)."""
    first, _, rest = impl.partition(" ")
    method, impl = (first, rest) if first in METHODS else ("auto", impl)
    m = ivp_model(case, tol, "python" if impl == "python" else "compiled", method)
    if impl in ("compiled", "python"):
        ys, wall = trajectory(m, t_end, h, clock=CLOCK)
        return ys, wall, m.solver_counts()
    if impl == "states only":
        m.states_only()
    n = int(round(t_end / h))
    times = np.arange(1, n + 1) * h
    y0 = m.state_vector()
    t0 = CLOCK()
    ys = m.run_dense(t_end, times)
    return np.vstack([y0, ys]), CLOCK() - t0, m.solver_counts()


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

    from spurdiff.differential.mesh.layout import constant_jacobian

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
            walls = [wall]      # the fastest of repeated runs, by the rule of best_of (the set-up is not timed)
            while more_runs(walls):
                walls.append(ours_trajectory(case, tol, impl)[1])
            wall = min(walls)
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


def more_runs(walls: list[float], least: int = 5, most: int = 1000, budget: float = 0.25,
              slow: float = 0.5) -> bool:
    """Whether to time another run after ``walls``: none after a run slower than ``slow`` s; else
    at least ``least`` runs, and more while they have taken less than ``budget`` s in all, up to
    ``most`` (a run of a millisecond is timed 250 times, one of 50 ms five times). The fastest of
    many is the run the machine's noise touched least (noise only ever adds time), and every
    variant, short or long, is sampled over the same span of machine time: a shared machine's
    speed changes in bursts of many runs, and 25 runs of a short solver fit inside one burst where
    those of a long one do not."""
    if walls and walls[-1] > slow:
        return False
    n = len(walls)
    return n < least or (n < most and sum(walls) < budget)


def best_of(fn):
    """(result, s) of ``fn`` by :data:`CLOCK`: the fastest of the runs :func:`more_runs` asks for."""
    walls, res = [], None
    while more_runs(walls):
        t0 = CLOCK()
        res = fn()
        walls.append(CLOCK() - t0)
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
