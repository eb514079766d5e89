"""Time plots of a run (PNG): one figure per physical quantity (speeds, torques, forces), inside it
one panel per kind and scale, so no line is flattened by a larger one on the same axis.

How a figure is laid out (:func:`figure_for`):

* the recorded variables go to a figure by their name (``PANELS``); within it, to a panel by their
  kind (forces: wheel loads ``Fz``, tyre forces ``Fx``, mesh forces ``F_...`` each get their own)
  and then by scale: a variable more than ``SCALE_SPLIT`` times smaller than the largest of its
  panel starts a panel of its own;
* every line of a panel has its own colour, line style and marker, the wider solid lines drawn
  first, so a line lying on another (a sun speed equal to its wheel speed) still shows;
* every axis is labelled with its quantity and unit, the legend sits beside the panel, outside the
  data.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from harness.common.outputs import output_folder, save_figure
from harness.run.result import Result

# figure key, leaf-name prefixes, quantity, unit; then the kinds of a figure (label, leaf prefixes)
PANELS = [
    ("speeds", ("w",), "speed", "rad/s"),
    ("torques", ("tau", "tauDrive", "tauMesh", "lockingTorque", "driveTorque"), "torque", "N m"),
    ("forces", ("F_", "Fx", "Fz"), "force", "N"),
]
KINDS = {   # None: every variable of the figure that no other kind takes
    "torques": [("drive torque", ("driveTorque", "tauDrive")), ("sun and shaft torque", None),
                ("locking torque", ("lockingTorque",))],
    "forces": [("wheel load", ("Fz",)), ("tyre force", ("Fx",)), ("mesh force", ("F_",))],
}
SCALE_SPLIT = 10.0         # a variable this many times smaller than its panel's largest gets its own panel

# line styles: colour, dash pattern, width and marker all change from one line to the next
COLOURS = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#17becf", "#7f7f7f"]
DASHES = ["-", "--", "-.", ":", (0, (5, 1, 1, 1, 1, 1)), (0, (8, 2))]
MARKERS = ["o", "s", "^", "v", "D", "x", "+", "*"]
WIDTHS = [3.0, 2.2, 1.8, 1.5, 1.3, 1.2, 1.1, 1.0]


def _leaf_matches(name: str, prefixes) -> bool:
    leaf = name.split(".")[-1]
    return any(leaf == p or leaf.startswith(p) for p in prefixes)


def _panel_of(name: str) -> str | None:
    for key, prefixes, _, _ in PANELS:
        if _leaf_matches(name, prefixes):
            return key
    return None


def line_style(i: int) -> dict:
    """The i-th line's style in a panel: distinct colour, dashes, marker; widest first."""
    return {"color": COLOURS[i % len(COLOURS)], "linestyle": DASHES[i % len(DASHES)],
            "marker": MARKERS[i % len(MARKERS)], "linewidth": WIDTHS[min(i, len(WIDTHS) - 1)],
            "markersize": 5, "markerfacecolor": "none"}


def _by_scale(result: Result, names: list[str]) -> list[list[str]]:
    """Split ``names`` into groups of one scale (largest first)."""
    size = {n: float(np.nanmax(np.abs(result[n]))) if len(result[n]) else 0.0 for n in names}
    groups: list[list[str]] = []
    for n in sorted(names, key=lambda n: -size[n]):
        if groups and size[groups[-1][0]] <= SCALE_SPLIT * max(size[n], 1e-300):
            groups[-1].append(n)
        elif groups and size[groups[-1][0]] == 0.0:
            groups[-1].append(n)
        else:
            groups.append([n])
    return [sorted(g, key=names.index) for g in groups]


def panels_of(result: Result, key: str, names: list[str]) -> list[tuple[str, list[str]]]:
    """The panels of figure ``key``: (title, variables), by kind, then by scale."""
    kinds = KINDS.get(key, [(None, None)])
    claimed = {n for _, prefixes in kinds if prefixes is not None for n in names if _leaf_matches(n, prefixes)}
    out = []
    for label, prefixes in kinds:
        members = [n for n in names if (n not in claimed if prefixes is None else _leaf_matches(n, prefixes))]
        if not members:
            continue
        groups = _by_scale(result, members)
        for g in groups:
            out.append((label or "", g))
    return out


def figure_for(result: Result, key: str, names: list[str]):
    """The figure of quantity ``key`` (a matplotlib Figure; the caller saves and closes it)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    quantity, unit = next((q, u) for k, _, q, u in PANELS if k == key)
    panels = panels_of(result, key, names)
    fig, axes = plt.subplots(len(panels), 1, figsize=(10, 1.0 + 2.6 * len(panels)), sharex=True,
                             squeeze=False, layout="constrained")
    n = len(result.time)
    for ax, (label, members) in zip(axes[:, 0], panels):
        for i, name in enumerate(members):
            st = line_style(i)
            every = max(1, n // 12)
            ax.plot(result.time, result[name], label=name, markevery=(min(n - 1, i * every // len(members)), every),
                    **st)
        ax.set_ylabel(f"{label or quantity} [{unit}]")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, handlelength=3.5)
    axes[-1, 0].set_xlabel("time [s]")
    fig.suptitle(f"{result.scene.name}: {quantity}s")
    return fig


def plot_result(result: Result, out_dir: Path) -> list[Path]:
    """Write one PNG per figure with data; returns the paths."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    output_folder(out_dir)
    groups: dict[str, list[str]] = {}
    for name in result.names:
        p = _panel_of(name)
        if p:
            groups.setdefault(p, []).append(name)
    paths = []
    for key, _, _, _ in PANELS:
        names = groups.get(key)
        if not names:
            continue
        fig = figure_for(result, key, names)
        p = out_dir / f"{result.scene.name}_{key}.png"
        try:
            save_figure(fig, p, dpi=110)   # no link followed; a full disk is one line
        finally:
            plt.close(fig)
        paths.append(p)
    return paths
