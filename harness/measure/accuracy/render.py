"""``docs/accuracy.md`` and its figures (``accuracy.png``, ``accuracy_solvers.png``) from the
measured or stored points."""
from __future__ import annotations

import math
from pathlib import Path

from harness.measure.accuracy.auto import REFERENCE_FRACTION, SANE_ERROR, choose
from harness.measure.accuracy.data import Point
from harness.measure.accuracy.ivp import equal_accuracy_ratios, front, ivp_error_key, variant
from harness.common.outputs import output_folder, save_figure, write_text
from harness.scene.spec import SceneError


def _legend_outside(ax, n: int) -> None:
    """The legend to the right of the panel, so it never hides a curve."""
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
              ncol=2 if n > 12 else 1, frameon=False)


# distinct colours (no repeat within 14 fidelities) and markers for the work-precision panels
_FIDELITY_COLOURS = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
                     "#bcbd22", "#17becf", "#000000", "#393b79", "#637939", "#843c39"]
_FIDELITY_MARKERS = ["o", "s", "^", "v", "D", "P", "X", "*", "h", "<", ">", "p", "d", "8"]


def fidelity_style(i: int) -> dict:
    """Colour, marker and line of the i-th fidelity of the work-precision figure."""
    return {"color": _FIDELITY_COLOURS[i % len(_FIDELITY_COLOURS)], "marker": _FIDELITY_MARKERS[i % len(_FIDELITY_MARKERS)],
            "ls": ("-", "--", "-.")[(i // len(_FIDELITY_COLOURS)) % 3], "lw": 1.4}


_METHOD_COLOURS = {"ROS34PW2": "tab:blue", "RODAS5P": "tab:red", "Radau": "tab:olive", "BDF": "tab:purple",
                   "LSODA": "tab:green"}


def _solver_style(name: str) -> dict:
    """Line style of a curve of the solver comparison: the colour names the method (ours: ROS34PW2
    blue, RODAS5P red), the marker and line how ours runs (do_step loop compiled o solid, Python D
    dotted, one call * dashed, states only P dash-dot), the line solve_ivp's kind (dotted: one call,
    dashed: restarted every 1 ms)."""
    colour = next((c for m, c in _METHOD_COLOURS.items() if m in name), "black")
    if name.startswith("ours"):
        marker = "P" if "states only" in name else "*" if "one call" in name else "o" if "compiled" in name else "D"
        ls = ":" if "Python" in name else "-." if "states only" in name else "--" if "one call" in name else "-"
        return {"color": colour, "marker": marker, "ls": ls, "lw": 2.0, "ms": 6, "label": name}
    return {"color": colour, "marker": "s" if "restarted" in name else "^", "ls": "--" if "restarted" in name else ":",
            "lw": 1.0, "ms": 4, "alpha": 0.8, "label": name}


def plot(points: list[Point], path: Path, ivp: list[dict] | None = None) -> list[Path]:
    """Work-precision figures: ``path`` has one panel per scene (two columns, legends outside
    the data); the solver comparison against solve_ivp is its own figure beside it
    (``<stem>_solvers.png``), one panel per case. Returns the files written."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    output_folder(path.parent)
    written = []
    scenes = sorted({p.scene for p in points})
    if scenes:
        ncol = 2 if len(scenes) > 1 else 1
        nrow = -(-len(scenes) // ncol)
        fig, axes = plt.subplots(nrow, ncol, figsize=(7.2 * ncol, 3.9 * nrow), squeeze=False)
        # one style per fidelity, the same in every panel: its own colour and marker
        fids = list(dict.fromkeys(p.fidelity for p in points))
        style = {f: fidelity_style(i) for i, f in enumerate(fids)}
        for ax, sc in zip(axes.flat, scenes):
            curves: dict[str, list[Point]] = {}
            for p in points:
                if p.scene == sc and p.ok and math.isfinite(p.error) and p.wall > 0:
                    curves.setdefault(p.fidelity, []).append(p)
            for fname, ps in curves.items():
                # every run a marker; the line joins, in wall-time order, the runs no cheaper run
                # beats in error (the work-precision front), so it never zig-zags between settings
                st = style[fname]
                ax.loglog([p.wall for p in ps], [max(p.error, 1e-16) for p in ps], ls="none", marker=st["marker"],
                          color=st["color"], ms=4, alpha=0.55)
                fr = sorted(front([{"wall": p.wall, "error": max(p.error, 1e-16)} for p in ps]), key=lambda q: q["wall"])
                ax.loglog([q["wall"] for q in fr], [q["error"] for q in fr], label=fname, ms=5, **st)
            failed = sorted({p.step for p in points if p.scene == sc and not p.ok})
            if failed:
                ax.text(0.02, 0.02, "coupled run fails at steps " + ", ".join(f"{h:g}" for h in failed) + " s",
                        transform=ax.transAxes, fontsize=7)
            ax.set_xlabel("wall time [s]")
            ax.set_ylabel("max relative error of the metrics")
            ax.set_title(sc, fontsize=10)
            ax.grid(True, which="both", alpha=0.3)
            _legend_outside(ax, len(curves))
        for ax in list(axes.flat)[len(scenes):]:
            ax.set_visible(False)
        fig.suptitle("markers: every run (steps, tolerances); lines: per fidelity, the cheapest run for each error "
                     "(work-precision front), in wall-time order", fontsize=9)
        fig.tight_layout()
        save_figure(fig, path, dpi=100)
        plt.close(fig)
        written.append(path)
    cases = list(dict.fromkeys(p["case"] for p in ivp or []))
    if cases:
        key = ivp_error_key(ivp)
        # one wide panel per case, one legend for all beside them; ours: colour by method, marker
        # by how it runs; solve_ivp: colour by method, dotted in one call, dashed restarted
        fig, axes = plt.subplots(len(cases), 1, figsize=(9.0, 4.4 * len(cases)), squeeze=False)
        handles: dict[str, object] = {}
        for ax, case in zip(axes[:, 0], cases):
            curves: dict[str, list[dict]] = {}
            for p in ivp:
                if p["case"] == case and math.isfinite(p.get(key, math.nan)) and p.get(key, 0.0) > 0.0:
                    curves.setdefault(variant(p["integrator"]), []).append(p)
            for name, ps in curves.items():
                # every setting a marker; the line: the front over the settings (tolerances, and for
                # solve_ivp rtol/atol: what the ratios use) in time order, so it never zig-zags
                st = _solver_style(name)
                ax.loglog([p["wall"] for p in ps], [max(p[key], 1e-16) for p in ps], ls="none", marker=st["marker"],
                          color=st["color"], ms=st["ms"], alpha=0.4)
                ps = sorted(front([{**p, "error": p[key]} for p in ps]), key=lambda p: p["wall"])
                (line,) = ax.loglog([p["wall"] for p in ps], [max(p[key], 1e-16) for p in ps], **st)
                handles.setdefault(name, line)
            ax.set_xlabel("CPU time of the run's thread [s]")
            ax.set_ylabel("max relative error of the metrics" if key == "metric_error"
                          else "max scaled state error at 1 ms outputs")
            ax.set_title(f"{case}: ours against solve_ivp (same ODE, 0.3 s)", fontsize=10)
            ax.grid(True, which="both", alpha=0.3)
        fig.legend(list(handles.values()), list(handles), loc="center left", bbox_to_anchor=(1.0, 0.5),
                   fontsize=8, frameon=False)
        fig.tight_layout()
        solvers = path.with_name(f"{path.stem}_solvers.png")
        save_figure(fig, solvers, dpi=100, bbox_inches="tight")
        plt.close(fig)
        written.append(solvers)
    return written


def markdown_ivp(ivp: list[dict], command: str = "spurdiff accuracy") -> list[str]:
    has_metrics = ivp_error_key(ivp) == "metric_error"
    lines = ["## Our internal solver against scipy's solve_ivp", "", f"Measured by `{command}`.", "",
             "The same differential ODE (`MeshDifferential.rhs`/`.jac`, pin friction off so no mode switches), "
             "0.3 s, states at the 301 points of a 1 ms grid, compared with a tolerance-1e-11 run of ours "
             "(`harness.measure.bench.mesh_ivp.ivp_points`) on two errors: the paper scenes' metrics (mean, max and min of the "
             "carrier and sun torques and the three mesh forces along the trajectory, each relative to its "
             "quantity's scale, as the scenes above are measured; plotted) and the scaled states at the "
             "1 ms points (stricter). solve_ivp (analytic Jacobian; right-hand side and Jacobian the compiled "
             "kernel's evaluation called straight through ctypes, as lean as a user would write them) runs once "
             "over the whole interval with the 1 ms points by `t_eval` (\"one call\") and, as a co-simulation "
             "slave whose inputs may change at every communication point must, restarted every 1 ms; rtol = tol, "
             "atol = tol times the state scale, LSODA also with atol 100 times smaller and larger and down to "
             "tol 1e-10, and each variant is taken at the front of its settings (the cheapest setting that reaches "
             "an error). Ours, with each of its two methods (`solver.method`: ROS34PW2, order 3, the compliant level's default; "
             "RODAS5P, order 5, the contact level's default): the compiled kernel and the Python reference as the FMU runs them, a do_step per "
             "1 ms communication step (the same numbers, so the same errors: the horizontal distance between their "
             "curves is what the interpreter costs), and the compiled kernel over the whole run in one call as "
             "solve_ivp's one call (`MeshDifferential.run_dense`: internal steps not cut at the 1 ms points, the "
             "states there by the method's dense output), with the loss quadrature the FMU integrates and, the "
             "same outputs as solve_ivp's, without it (\"states only\"). "
             "Ratio: the time the best solve_ivp variant needs for our error (log-log interpolation along its "
             "front) over ours; above 1 we are faster. Times: CPU time of the measuring thread (every run is "
             "single-threaded; what one core spends, whatever else a shared machine runs), the fastest of 5 to 1000 "
             "runs spanning a quarter of a second of CPU time (`harness.measure.bench.mesh_ivp.more_runs`: a run of a "
             "millisecond is timed 250 times, one of 50 ms five times, one over 0.5 s once), so that short and "
             "long runs sample a shared machine's bursts of speed alike.", ""]

    def ratio_table(title: str, pts: list[dict], key: str, who: str) -> list[str]:
        out = [title, "", f"| case | ours | tolerance | our error | our CPU s | best {who} at equal error | its CPU s "
               "| ratio |", "|---|---|---|---|---|---|---|---|"]
        for r in equal_accuracy_ratios(pts, key):
            bw = "" if r["best_wall"] is None else f"{r['best_wall']:.4f}"
            ra = "" if r["ratio"] is None else f"{r['ratio']:.2f}"
            out.append(f"| {r['case']} | {r.get('ours', 'ours')} | {r['tolerance']:g} | {r['error']:.2e} | {r['wall']:.4f} | "
                       f"{r['best'] or 'none in range'} | {bw} | {ra} |")
        return out + [""]

    restarted = [p for p in ivp if "one call" not in p["integrator"]]
    for key, what in ((("metric_error", "the scenes' metrics"),) if has_metrics else ()) + (("error", "the states"),):
        lines += ratio_table(f"Error on {what}, against every solve_ivp variant:", ivp, key, "solve_ivp")
        lines += ratio_table(f"Error on {what}, against solve_ivp restarted at every communication point "
                             "(what an FMU must do):", restarted, key, "restarted solve_ivp")
    lines += ["All points, with the work: ours internal steps (rejected ones apart), Jacobian evaluations and "
              "factorizations of W; solve_ivp right-hand side evaluations, Jacobian evaluations and LU "
              "factorizations (nfev, njev, nlu):", "",
              "| case | integrator | tolerance | metrics error | state error | CPU s | steps (rejected) | f evaluations "
              "| Jacobians | LU |", "|---|---|---|---|---|---|---|---|---|---|"]

    def cell(v) -> str:
        return "" if v is None else str(v)
    for p in ivp:
        me = f"{p['metric_error']:.2e}" if "metric_error" in p else ""
        st = f"{p['steps']} ({p['rejected']})" if p.get("steps") is not None else ""
        lines.append(f"| {p['case']} | {p['integrator']} | {p['tolerance']:g} | {me} | {p['error']:.2e} | {p['wall']:.4f} "
                     f"| {st} | {cell(p.get('nfev'))} | {cell(p.get('njev'))} | {cell(p.get('nlu'))} |")
    return lines + [""]


def _convergence_text(f: dict, points: list[Point], scene: str) -> str:
    errs = [p.error for p in points if p.scene == scene and p.ok and p.fidelity != f["reference"]]
    conv = f["convergence"]
    text = f"The same fidelity one refinement coarser differs from it by {conv:.2e} (relative): "
    if conv < 1e-9:
        return text + "converged (below 1e-9)."
    if not errs or conv <= 0.1 * min(errs):
        return text + "converged, well below the errors of the other fidelities."
    return text + (f"NOT converged below that level: errors of {conv:.1e} or less in the table below are not "
                   "resolved by this reference.")


def markdown_auto(data: list[Point]) -> list[str]:
    """What every `fidelity = "auto"` scene chooses from the stored data, and why."""
    from harness.scene.spec import available, load_scene

    lines = ["## `fidelity = \"auto\"`: what the scenes choose", "",
             "The rule (`harness.measure.accuracy.choose`; errors on the scene's requested outputs, relative to their "
             "scales, against the grid's reference):", "",
             f"1. The reference must resolve the tolerance: its difference from its own run one refinement coarser, "
             f"on the requested outputs, must be at most {REFERENCE_FRACTION:g} of the tolerance, else the choice is "
             "refused (`spurdiff run` exits non-zero with a one-line message naming the scene, the tolerance and the "
             "reference's resolution). An error measured against the reference is known only to within the "
             "reference's own error, which the next-coarser run bounds; with a quarter, a point accepted at the "
             "tolerance is within 1.25 times it of the converged answer, while against a reference worse than the "
             "tolerance a coarse step can land \"within the tolerance\" by chance.",
             "2. A setting (fidelity, internal tolerance, step) qualifies only if its error and the errors of every "
             "finer stored step of the same fidelity and internal tolerance meet the tolerance (every one of those "
             f"runs succeeded, none with any metric off by more than {SANE_ERROR:g} times its scale): convergence shown, "
             "not a cancellation of errors at one coarse step.",
             "3. Of the qualifying settings, the one with the least stored wall time.", ""]
    for name in available():
        sc = load_scene(name)
        if sc.fidelity.get("mode") != "auto":
            continue
        try:
            _, why = choose(sc, data)
        except SceneError as e:
            why = f"no choice: {e}"
        lines += [f"* `{name}` (outputs {', '.join(sc.fidelity['outputs'])}, tolerance {sc.fidelity.get('tolerance', 0.01):g}): "
                  + why, ""]
    return lines


def markdown(points: list[Point], facts: dict[str, dict], command: str) -> str:
    lines = ["# Accuracy versus cost", "",
             f"Generated by `{command}`; do not edit by hand. Errors are the largest relative error over "
             "the scene's metrics (mean, max and min of every results-table quantity, over the row's window) against the "
             "reference run, each relative to the quantity's scale (its largest reference magnitude); wall time is the median stepping time of repeated runs (fewer for runs of tens of seconds, see the grid file) on the machine that ran "
             "the command.", "", "![work-precision](accuracy.png)", ""]
    for sc, f in facts.items():
        lines += [f"## {sc}", "", f"Measured by `{f.get('command', command)}`.", "",
                  f"Reference: `{f['reference']}`, step {f['ref_step']:g} s, tolerance {f['ref_tolerance']}, "
                  f"{f['duration']:g} s simulated in {f['ref_wall']:.2f} s. " + _convergence_text(f, points, sc), ""]
        lines += _summary(points, sc, f["duration"])
        lines += ["All points:", "",
                  "| fidelity | step s | tolerance | wall s | real-time factor | max rel. error |",
                  "|---|---|---|---|---|---|"]
        for p in points:
            if p.scene != sc:
                continue
            rtf = f["duration"] / p.wall if p.ok and p.wall > 0 else math.nan
            err = f"{p.error:.2e}" if p.ok else f"failed: {p.reason[:60]}"
            lines.append(f"| {p.fidelity} | {p.step:g} | {'' if p.tolerance is None else f'{p.tolerance:g}'} | "
                         f"{p.wall:.4f} | {rtf:.1f} | {err} |")
        lines.append("")
    return "\n".join(lines) + "\n"


def _summary(points: list[Point], scene: str, duration: float) -> list[str]:
    """Per fidelity: its fastest run, its most accurate run, and the steps at which it failed."""
    by_fid: dict[str, list[Point]] = {}
    for p in points:
        if p.scene == scene:
            by_fid.setdefault(p.fidelity, []).append(p)
    lines = ["Per fidelity (the fastest and the most accurate of its runs; steps where the coupled run failed):", "",
             "| fidelity | fastest: step s, tolerance | wall s | error | most accurate: step s, tolerance | wall s | error | failed at steps s |",
             "|---|---|---|---|---|---|---|---|"]
    for fid, ps in by_fid.items():
        ok = [p for p in ps if p.ok]
        failed = sorted({p.step for p in ps if not p.ok})
        if not ok:
            lines.append(f"| {fid} | | | | | | | {', '.join(f'{h:g}' for h in failed)} |")
            continue
        fast, best = min(ok, key=lambda p: p.wall), min(ok, key=lambda p: (p.error, p.wall))

        def setting(p: Point) -> str:
            return f"{p.step:g}" + ("" if p.tolerance is None else f", {p.tolerance:g}")
        lines.append(f"| {fid} | {setting(fast)} | {fast.wall:.4f} | {fast.error:.2e} | {setting(best)} | "
                     f"{best.wall:.4f} | {best.error:.2e} | {', '.join(f'{h:g}' for h in failed) or 'none'} |")
    return lines + [""]


def _write_docs(points, facts, ivp, out: Path, cmd: str, data, ivp_cmd: str | None = None) -> int:
    output_folder(out)
    figures = plot(data, out / "accuracy.png", ivp)
    text = markdown(points, facts, cmd)
    if ivp:
        text += "\n".join(markdown_ivp(ivp, ivp_cmd or cmd) + ["", "![ours against solve_ivp](accuracy_solvers.png)", "", ""])
    text += "\n".join(markdown_auto(data))
    write_text(out / "accuracy.md", text)
    print(f"wrote {out / 'accuracy.md'}, " + ", ".join(str(f) for f in figures))
    return 0
