"""Our internal solver against scipy's ``solve_ivp`` on the differential ODE: the measured points
(:mod:`harness.measure.bench.mesh_ivp`) and the wall-time ratios at equal error."""
from __future__ import annotations

import math
import re


def ivp_error_key(ivp: list[dict]) -> str:
    """The solve_ivp error that is plotted and compared: the scene metrics' where every point has
    it (stored by the current ``ivp_points``), else the states'."""
    return "metric_error" if ivp and all("metric_error" in p for p in ivp) else "error"


def equal_accuracy_ratios(ivp: list[dict], key: str = "error") -> list[dict]:
    """For each of our points: the wall time the best solve_ivp variant needs for the same error
    (log-log interpolation along its tolerance curve; None outside its measured range), as a
    ratio to ours (> 1: ours is faster). ``key``: which error, ``error`` (scaled states at the
    communication points) or ``metric_error`` (the paper scenes' table metrics)."""
    out = []
    ivp = [{**p, "error": p.get(key, math.nan)} for p in ivp]
    for case in dict.fromkeys(p["case"] for p in ivp):
        pts = [p for p in ivp if p["case"] == case and math.isfinite(p["error"]) and p["error"] > 0]
        ours = [p for p in pts if p["integrator"].startswith("ours")]
        curves: dict[str, list[dict]] = {}
        for p in pts:
            if not p["integrator"].startswith("ours"):
                curves.setdefault(variant(p["integrator"]), []).append(p)
        for o in ours:
            best, best_name = math.inf, None
            for name, c in curves.items():
                w = _wall_at(c, o["error"])
                if w is not None and w < best:
                    best, best_name = w, name
            out.append({"case": case, "ours": o["integrator"], "tolerance": o["tolerance"], "error": o["error"],
                        "wall": o["wall"], "best": best_name, "best_wall": best if best_name else None,
                        "ratio": best / o["wall"] if best_name else None})
    return out


def variant(name: str) -> str:
    """A solve_ivp variant's name without its atol setting: the points of all its rtol/atol
    settings form one curve, whose front is the variant's best."""
    return re.sub(r" \(atol x[^)]*\)", "", name)


def front(curve: list[dict]) -> list[dict]:
    """The work-precision front of a variant's points: by error, those cheaper than every point
    of a smaller error (a user wanting an error takes the cheapest setting that reaches it)."""
    out: list[dict] = []
    for p in sorted(curve, key=lambda p: (p["error"], p["wall"])):
        if not out or p["wall"] < out[-1]["wall"]:
            out.append(p)
    return out


def _wall_at(curve: list[dict], err: float) -> float | None:
    """Wall time of a solve_ivp variant at error ``err``: log-log interpolation along the front of
    its measured points (every rtol/atol setting; clamped within a factor 1.5 outside their range,
    None further out)."""
    c = front(curve)
    if not c or err < c[0]["error"] / 1.5 or err > max(p["error"] for p in curve) * 1.5:
        return None
    import numpy as np
    return float(np.exp(np.interp(math.log(err), [math.log(p["error"]) for p in c],
                                  [math.log(p["wall"]) for p in c])))


def ivp_baseline(log=print) -> list[dict]:
    """Our internal solver against scipy's solve_ivp on the same differential ODE
    (:mod:`harness.measure.bench.mesh_ivp`: contact level from unloaded meshes, compliant level with
    backlash through a torque reversal)."""
    from harness.measure.bench.mesh_ivp import IVP_CASES, IVP_TOLS, ivp_points

    out = []
    for case in IVP_CASES:
        pts = ivp_points(case, tols=(1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8), ivp_tols=IVP_TOLS)
        for p in pts:
            log(f"  ivp {case:32s} {p['integrator']:50s} tol {p['tolerance']:6.0e} error {p['error']:9.2e} "
                f"metrics {p['metric_error']:9.2e} wall {p['wall']:8.4f} s")
        out += pts
    return out
