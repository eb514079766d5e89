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


THEORY_UNITS = {"locking_coefficient": "1", "torque_bias_ratio": "1"}   # the closed forms are ratios


def column_units(sweep: Sweep) -> dict[str, str]:
    """The unit of each column that has one: a parameter's from its FMU's declaration; a metric's
    from the variables it is made of (the same unit throughout, or a ratio of two of the same:
    1); a closed form's from THEORY_UNITS. Columns whose unit is not evident are left out."""
    import re
    from harness.build.fmu import FMUS
    from harness.scene.spec import load_scene
    import importlib

    try:
        scene = load_scene(sweep.scene)
        declared = {}
        for spec in scene.instances:
            for v in importlib.import_module(FMUS[spec.fmu]).VARIABLES:
                declared[f"{spec.name}.{v.name}"] = v.unit or "1"
    except Exception:   # a plot without units rather than no plot
        return {}
    units = {p.name: declared[p.name] for p in sweep.params if p.name in declared}

    def of(text: str) -> str | None:
        refs = re.findall(r"\{([^{}]+)\}", text) or [text]
        us = {units.get(r, declared.get(r)) for r in refs}
        if None in us or len(us) != 1:
            return None
        ops = re.sub(r"\{[^{}]+\}", "", text)
        if "*" in ops:
            return None
        if "/" in ops:
            return "1" if len(refs) == 2 and ops.count("/") == 1 else None
        return us.pop()

    for m in sweep.metrics:
        u = THEORY_UNITS.get(m.theory) if m.kind == "theory" else of(m.expr if m.kind == "expr" else m.var)
        if u is not None:
            units[m.name] = u
    return units


def _unit_text(names: list[str], units: dict[str, str]) -> str:
    """`` [unit]`` of columns that share a unit ([-] for a ratio), else nothing."""
    us = {units.get(n) for n in names}
    unit = us.pop() if len(us) == 1 else None
    return "" if unit is None else f" [{'-' if unit == '1' else unit.replace('.', ' ')}]"


def _label(names: list[str], units: dict[str, str], dashed: list[str] = ()) -> str:
    """Axis label: the column names (the dashed ones named as such) with their shared unit."""
    text = ", ".join(names) + (f" (dashed: {', '.join(dashed)})" if dashed else "")
    return text + _unit_text(list(names) + list(dashed), units)


def default_plots(sweep: Sweep) -> list[Plot]:
    x = sweep.params[0].name
    group = sweep.params[1].name if len(sweep.params) > 1 else None
    return [Plot(x, [m.name], [], group) for m in sweep.metrics if m.kind != "theory"]


def plot_sweep(sweep: Sweep, rows: list[dict], out_dir: Path) -> list[Path]:
    """PNG per plot: metrics over a parameter, a line (or coloured points) per value of ``group``,
    theory columns dashed in the same colour. Runs that did not finish ok are left out (counted in the title)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from harness.common.outputs import output_folder, save_figure
    from matplotlib.figure import Figure
    import matplotlib as mpl

    out_dir = Path(out_dir)
    output_folder(out_dir)
    ok = [r for r in rows if r["status"] == "ok"]
    skipped = len(rows) - len(ok)
    units = column_units(sweep)
    paths = []
    for k, pl in enumerate(sweep.plots or default_plots(sweep)):
        fig = Figure(figsize=(9.0, 4.8), layout="constrained")
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
            gu = _unit_text([pl.group], units).strip(" []").replace("-", "") if pl.group else ""
            label_g = f" ({pl.group} = {g}{' ' + gu if gu else ''})" if g is not None and not many else ""
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
            fig.colorbar(sm, ax=ax, label=_label([pl.group], units))
        ax.set_xlabel(_label([pl.x], units))
        ax.set_ylabel(_label(list(pl.y), units, list(pl.theory)))
        title = pl.title or f"{sweep.name}: {', '.join(pl.y)} over {pl.x}"
        if skipped:
            title += f"  ({skipped} run{'s' if skipped > 1 else ''} not ok, not shown)"
        ax.set_title(title, fontsize=10)
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:   # beside the data, never over it
            ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
        p = out_dir / f"{sweep.name}_{pl.file or '-'.join(pl.y) or k}.png"
        save_figure(fig, p, dpi=110)
        paths.append(p)
    return paths


def head(rows: list[dict], columns: list[str], n: int = 8) -> str:
    from harness.run.report import render

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
