"""A scene's container FMU (:mod:`harness.interop.container`) run in fmpy beside our own master's run of the
same scene: per recorded output the mean over a window of each run and their difference (for
``spurdiff export-container --compare`` and the tests)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from harness.scene.spec import Scene


@dataclass
class Row:
    name: str
    master: float
    container: float

    @property
    def diff(self) -> float:
        return self.container - self.master

    @property
    def rel(self) -> float:
        scale = max(abs(self.master), abs(self.container))
        return abs(self.diff) / scale if scale > 0 else 0.0


def run_container(container: Path, scene: Scene):
    """The container in fmpy at the scene's step from 0 to its duration (a structured array)."""
    from fmpy import simulate_fmu
    return simulate_fmu(str(container), stop_time=scene.duration, step_size=scene.step,
                        output_interval=scene.output_interval, validate=True)


def compare(scene: Scene, fmu_files: dict[str, Path], container: Path, t_from: float | None = None) -> list[Row]:
    """Means of every output the container exposes over [t_from, duration] (default: the second
    half), from our master and from the container in fmpy."""
    from harness.run.master import run_scene

    ours = run_scene(scene, fmu_files)
    if ours.failure is not None:
        raise RuntimeError(f"our master failed on {scene.name}: {ours.failure}")
    theirs = run_container(container, scene)
    t0 = 0.5 * scene.duration if t_from is None else t_from
    rows = []
    m_ours = ours.time >= t0 - 1e-12
    m_theirs = theirs["time"] >= t0 - 1e-12
    for name in theirs.dtype.names[1:]:
        if name not in ours.names:
            continue
        rows.append(Row(name, float(np.mean(ours[name][m_ours])), float(np.mean(theirs[name][m_theirs]))))
    return rows


def table(rows: list[Row], t_from: float, duration: float) -> str:
    """A Markdown table of ``rows``."""
    lines = [f"| output (mean {t_from:g} to {duration:g} s) | our master | container in fmpy | difference | relative |",
             "|---|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r.name} | {r.master:.6g} | {r.container:.6g} | {r.diff:.3g} | {r.rel:.2g} |")
    return "\n".join(lines)


__all__ = ["Row", "compare", "run_container", "table"]
