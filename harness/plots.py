"""Time plots of a run (PNG), one panel per physical quantity."""
from __future__ import annotations

from pathlib import Path

from harness.outputs import output_folder, save_figure
from harness.result import Result

PANELS = [
    ("speeds", ("w",), "speed [rad/s]"),
    ("torques", ("tau", "tauDrive", "tauMesh", "lockingTorque", "driveTorque"), "torque [N m]"),
    ("forces", ("F_", "Fx", "Fz"), "force [N]"),
]


def _panel_of(name: str) -> str | None:
    leaf = name.split(".")[-1]
    for key, prefixes, _ in PANELS:
        if any(leaf == p or leaf.startswith(p) for p in prefixes):
            return key
    return None


def plot_result(result: Result, out_dir: Path) -> list[Path]:
    """Write one PNG per panel with data; returns the paths."""
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
    for key, _, ylabel in PANELS:
        names = groups.get(key)
        if not names:
            continue
        fig, ax = plt.subplots(figsize=(8, 4.5))
        for n in names:
            ax.plot(result.time, result[n], label=n)
        ax.set_xlabel("time [s]")
        ax.set_ylabel(ylabel)
        ax.set_title(f"{result.scene.name}: {key}")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        p = out_dir / f"{result.scene.name}_{key}.png"
        try:
            save_figure(fig, p, dpi=110)   # no link followed; a full disk is one line
        finally:
            plt.close(fig)
        paths.append(p)
    return paths
