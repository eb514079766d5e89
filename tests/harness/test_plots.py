"""The structure of the figures the project writes: panels per kind and scale, axis labels with
units, legends outside the data, distinct styles (issue 31). Synthetic data, no FMU runs."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")

from harness.run import plots  # noqa: E402
from harness.run.result import Result  # noqa: E402


def _result() -> Result:
    t = np.linspace(0.0, 3.0, 301)
    cols = {
        "diff.carrier.w": 30.7 + 0 * t, "diff.left.w": 29.5 + 0 * t, "wheelL.wheel.w": 29.5 + 0 * t,  # two equal lines
        "car.driveTorque": 150 + t, "diff.leftShaft.tau": 90 + 0 * t, "diff.rightShaft.tau": 63 + 0 * t,
        "diff.lockingTorque": 27 + 0.1 * np.sin(t),
        "car.rearLeft.Fz": 2270 + 0 * t, "car.rearRight.Fz": 3830 + 0 * t, "wheelL.Fx": 240 + t, "wheelR.Fx": 134 + t,
    }
    names = list(cols)
    return Result(SimpleNamespace(name="synthetic"), names, np.column_stack([t] + [cols[n] for n in names]))


def _legend_outside(ax) -> bool:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    fig = ax.figure
    canvas = fig.canvas if hasattr(fig.canvas, "get_renderer") else FigureCanvasAgg(fig)   # a closed figure too
    canvas.draw()
    r = canvas.get_renderer()
    return ax.get_legend().get_window_extent(r).x0 >= ax.get_window_extent(r).x1 - 1.0


def _styles(ax) -> list[tuple]:
    return [(ln.get_color(), str(ln.get_linestyle()), ln.get_marker()) for ln in ax.get_lines() if ln.get_label()[0] != "_"]


@pytest.mark.parametrize("key, panels", [
    ("speeds", ["speed [rad/s]"]),
    ("torques", ["drive torque [N m]", "sun and shaft torque [N m]", "locking torque [N m]"]),
    ("forces", ["wheel load [N]", "tyre force [N]"]),
])
def test_run_figures_have_a_panel_per_kind_units_outside_legends_and_distinct_styles(key, panels):
    res = _result()
    names = [n for n in res.names if plots._panel_of(n) == key]
    fig = plots.figure_for(res, key, names)
    axes = fig.axes
    assert [ax.get_ylabel() for ax in axes] == panels
    assert axes[-1].get_xlabel() == "time [s]"
    plotted = []
    for ax in axes:
        assert _legend_outside(ax), f"{key}: the legend overlaps the data of {ax.get_ylabel()}"
        st = _styles(ax)
        assert len(set(st)) == len(st), f"{key}: two lines share colour, dashes and marker"
        widths = [ln.get_linewidth() for ln in ax.get_lines()]
        assert widths == sorted(widths, reverse=True)   # widest first: a line on another still shows
        plotted += [ln.get_label() for ln in ax.get_lines()]
    assert sorted(plotted) == sorted(names)             # every variable once
    matplotlib.pyplot.close(fig)


def test_a_variable_ten_times_smaller_gets_its_own_panel():
    t = np.linspace(0, 1, 11)
    res = Result(SimpleNamespace(name="s"), ["a.Fx", "b.Fx"], np.column_stack([t, 1000 + t, 50 + t]))
    assert [g for _, g in plots.panels_of(res, "forces", ["a.Fx", "b.Fx"])] == [["a.Fx"], ["b.Fx"]]
    res = Result(SimpleNamespace(name="s"), ["a.Fx", "b.Fx"], np.column_stack([t, 1000 + t, 200 + t]))
    assert [g for _, g in plots.panels_of(res, "forces", ["a.Fx", "b.Fx"])] == [["a.Fx", "b.Fx"]]


def test_plot_result_writes_one_png_per_quantity(tmp_path):
    paths = plots.plot_result(_result(), tmp_path)
    assert [p.name for p in paths] == ["synthetic_speeds.png", "synthetic_torques.png", "synthetic_forces.png"]
    assert all(p.stat().st_size > 10_000 for p in paths)


def test_accuracy_figure_distinct_fidelity_styles_and_lines_in_wall_time_order(tmp_path, monkeypatch):
    from harness.measure.accuracy import render
    from harness.measure.accuracy.data import Point

    captured = []
    monkeypatch.setattr(render, "save_figure", lambda fig, path, **kw: captured.append(fig))
    fids = [f"fidelity {i}" for i in range(12)]
    rng = np.random.default_rng(1)
    points = [Point("sceneA", f, {}, h, None, wall=float(w), error=float(e))
              for f in fids for h, w, e in zip((1e-2, 5e-3, 1e-3, 5e-4), rng.uniform(1e-3, 1, 4), rng.uniform(1e-6, 1, 4))]
    render.plot(points, tmp_path / "accuracy.png")
    (fig,) = captured
    ax = fig.axes[0]
    labelled = [ln for ln in ax.get_lines() if not ln.get_label().startswith("_")]
    assert len(labelled) == len(fids)
    assert len({ln.get_color() for ln in labelled}) == len(fids)     # no colour repeats
    assert len({ln.get_marker() for ln in labelled}) == len(fids)    # nor marker
    for ln in labelled:
        x, y = ln.get_xdata(), ln.get_ydata()
        assert list(x) == sorted(x), f"{ln.get_label()}: line not in wall-time order"
        assert all(b <= a for a, b in zip(y, y[1:])), f"{ln.get_label()}: the front must not zig-zag"
    assert "wall time [s]" == ax.get_xlabel() and ax.get_ylabel()
    assert _legend_outside(ax)


def test_sweep_plot_axes_carry_units_and_the_legend_is_outside(tmp_path, monkeypatch):
    import harness.common.outputs
    from harness.sweep.plots import column_units, plot_sweep
    from harness.sweep.spec import load_sweep

    sweep = load_sweep("split-mu-locking")
    units = column_units(sweep)
    assert units["diff.r_collar"] == "m" and units["diff.mu_pin"] == "1"
    assert units["lockingTorque_mean"] == "N.m" and units["K_measured"] == "1" and units["K_theory"] == "1"
    captured = []
    monkeypatch.setattr(harness.common.outputs, "save_figure", lambda fig, path, **kw: captured.append(fig))
    rows = [{"run": str(i), "status": "ok", "diff.mu_pin": str(mu), "diff.r_collar": str(rc),
             **{m.name: str(mu * rc * 1000 + j) for j, m in enumerate(sweep.metrics)}}
            for i, (mu, rc) in enumerate((mu, rc) for mu in (0.1, 0.2, 0.3) for rc in (0.008, 0.012))]
    plot_sweep(sweep, rows, tmp_path)
    assert captured
    for fig in captured:
        ax = fig.axes[0]
        assert ax.get_xlabel() == "diff.mu_pin [-]"
        assert ax.get_ylabel().endswith("]"), ax.get_ylabel()
        assert _legend_outside(ax)
    assert any("[N m]" in f.axes[0].get_ylabel() for f in captured)
