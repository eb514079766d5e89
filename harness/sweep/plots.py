"""Plots of a sweep's table, and its first rows as text."""
from __future__ import annotations

import math
from pathlib import Path

from harness.sweep.spec import Plot, Sweep

def _num(v: str) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")


def default_plots(sweep: Sweep) -> list[Plot]:
    x = sweep.params[0].name
    group = sweep.params[1].name if len(sweep.params) > 1 else None
    return [Plot(x, [m.name], [], group) for m in sweep.metrics if m.kind != "theory"]


def plot_sweep(sweep: Sweep, rows: list[dict], out_dir: Path) -> list[Path]:
    """PNG per plot: metrics over a parameter, a line (or coloured points) per value of ``group``,
    theory columns dashed in the same colour. Runs that did not finish ok are left out (counted in the title)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from harness.outputs import output_folder, save_figure
    from matplotlib.figure import Figure
    import matplotlib as mpl

    out_dir = Path(out_dir)
    output_folder(out_dir)
    ok = [r for r in rows if r["status"] == "ok"]
    skipped = len(rows) - len(ok)
    paths = []
    for k, pl in enumerate(sweep.plots or default_plots(sweep)):
        fig = Figure(figsize=(7.5, 4.8))
        FigureCanvasAgg(fig)
        ax = fig.add_subplot(1, 1, 1)
        groups = sorted({r[pl.group] for r in ok}, key=_num) if pl.group else [None]
        many = len(groups) > 8
        cmap = mpl.colormaps["viridis" if many else "tab10"]
        gv = [_num(g) for g in groups]
        for gi, g in enumerate(groups):
            sel = sorted((r for r in ok if g is None or r[pl.group] == g), key=lambda r: _num(r[pl.x]))
            xs = [_num(r[pl.x]) for r in sel]
            if many:
                span = (max(gv) - min(gv)) or 1.0
                color = cmap((gv[gi] - min(gv)) / span)
            else:
                color = cmap(gi % 10)
            label_g = f" ({pl.group} = {g})" if g is not None and not many else ""
            for j, y in enumerate(pl.y):
                ys = [_num(r[y]) for r in sel]
                ax.plot(xs, ys, ls="none" if many else "-", marker="os^vD"[j % 5], color=color, ms=5,
                        label=(y + label_g) if (not many or gi == 0) else None)
            for j, y in enumerate(pl.theory):
                ys = [_num(r[y]) for r in sel]
                ax.plot(xs, ys, ls="none" if many else "--", marker="x" if many else None, color=color,
                        label=(y + label_g) if (not many or gi == 0) else None)
        if many and pl.group:
            sm = mpl.cm.ScalarMappable(norm=mpl.colors.Normalize(min(gv), max(gv)), cmap=cmap)
            fig.colorbar(sm, ax=ax, label=pl.group)
        ax.set_xlabel(pl.x)
        ax.set_ylabel(", ".join(pl.y) + (f" (dashed: {', '.join(pl.theory)})" if pl.theory else ""))
        title = pl.title or f"{sweep.name}: {', '.join(pl.y)} over {pl.x}"
        if skipped:
            title += f"  ({skipped} run{'s' if skipped > 1 else ''} not ok, not shown)"
        ax.set_title(title, fontsize=10)
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="best")
        fig.tight_layout()
        p = out_dir / f"{sweep.name}_{pl.file or '-'.join(pl.y) or k}.png"
        save_figure(fig, p, dpi=110)
        paths.append(p)
    return paths


def head(rows: list[dict], columns: list[str], n: int = 8) -> str:
    from harness.report import render

    cols = [c for c in columns if c not in ("worker", "reason")]
    lines = []
    for r in rows[:n]:
        line = []
        for c in cols:
            v = r.get(c, "")
            x = _num(v)
            line.append(f"{x:.6g}" if c not in ("run", "status") and math.isfinite(x) and v not in ("true", "false") else v)
        lines.append(line)
    return render(cols, lines)
