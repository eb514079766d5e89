"""A scene's container FMU (:mod:`harness.interop.container`) run in other hosts beside our own master's run
of the same scene: per recorded output the mean over a window of each run and the differences (for
``spurdiff export-container --compare`` and the tests). Hosts: ``fmpy`` (``simulate_fmu`` in this
process) and ``libcosim`` (:mod:`harness.interop.container_libcosim`, FMI 2.0 containers only)."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from harness.scene.spec import Scene

HOSTS = ("fmpy", "libcosim")


@dataclass
class Row:
    name: str
    master: float
    hosts: dict[str, float] = field(default_factory=dict)   # host -> the container's mean there
    master_start: float = float("nan")                      # the values at t = 0 (after initialization)
    hosts_start: dict[str, float] = field(default_factory=dict)

    @property
    def container(self) -> float:
        """The container's mean in the first host compared (fmpy by default)."""
        return next(iter(self.hosts.values()))

    def diff(self, host: str | None = None) -> float:
        return (self.hosts[host] if host else self.container) - self.master

    def rel(self, host: str | None = None) -> float:
        """|container - master| over the larger magnitude of the two (0 when both are 0)."""
        value = self.hosts[host] if host else self.container
        scale = max(abs(self.master), abs(value))
        return abs(value - self.master) / scale if scale > 0 else 0.0


def run_container(container: Path, scene: Scene):
    """The container in fmpy at the scene's step from 0 to its duration (a structured array)."""
    from fmpy import simulate_fmu
    return simulate_fmu(str(container), stop_time=scene.duration, step_size=scene.step,
                        output_interval=scene.output_interval, validate=True)


def _host_run(host: str, container: Path, scene: Scene):
    """(time, {name: values}) of the container run by ``host``."""
    if host == "fmpy":
        r = run_container(container, scene)
        return r["time"], {n: np.asarray(r[n], dtype=float) for n in r.dtype.names[1:]}
    if host == "libcosim":
        from harness.interop.container_libcosim import run_container_libcosim
        r = run_container_libcosim(container, scene)
        if r.failure is not None:
            raise RuntimeError(f"libcosim failed on the container of {scene.name}: {r.failure}")
        return r.time, {n: r[n] for n in r.names}
    raise ValueError(f"host {host!r}: allowed {', '.join(HOSTS)}")


def compare(scene: Scene, fmu_files: dict[str, Path], container: Path, t_from: float | None = None,
            hosts: tuple[str, ...] = ("fmpy",)) -> list[Row]:
    """Means of every output the container exposes over [t_from, duration] (default: the second
    half), from our master and from the container in each of ``hosts``."""
    from harness.run.master import run_scene

    ours = run_scene(scene, fmu_files)
    if ours.failure is not None:
        raise RuntimeError(f"our master failed on {scene.name}: {ours.failure}")
    t0 = 0.5 * scene.duration if t_from is None else t_from
    m_ours = ours.time >= t0 - 1e-12
    runs = {h: _host_run(h, container, scene) for h in hosts}
    first = runs[hosts[0]][1]
    rows = []
    for name in first:
        if name not in ours.names:
            continue
        means = {h: float(np.mean(cols[name][t >= t0 - 1e-12])) for h, (t, cols) in runs.items()}
        starts = {h: float(cols[name][0]) for h, (t, cols) in runs.items()}
        rows.append(Row(name, float(np.mean(ours[name][m_ours])), means, float(ours[name][0]), starts))
    return rows


def start_differences(rows: list[Row], n: int = 3) -> str:
    """The ``n`` outputs whose values at t = 0 differ most (relative) between our master and the
    container in the first host, in one line."""
    def rel(r: Row) -> float:
        c = next(iter(r.hosts_start.values()))
        scale = max(abs(c), abs(r.master_start))
        return abs(c - r.master_start) / scale if scale > 0 else 0.0
    worst = sorted(rows, key=rel, reverse=True)[:n]
    differ = sum(rel(r) > 0 for r in rows)
    return (f"at t = 0, {differ} of {len(rows)} outputs differ; most: " + ", ".join(
        f"{r.name} {r.master_start:.6g} (master) / {next(iter(r.hosts_start.values())):.6g} (container)" for r in worst))


def table(rows: list[Row], t_from: float, duration: float) -> str:
    """A Markdown table of ``rows``: our master; the container in the first host and its relative
    difference from the master; each further host and its relative difference from the first."""
    hosts = list(rows[0].hosts) if rows else ["fmpy"]
    first = hosts[0]
    head = f"| output (mean {t_from:g} to {duration:g} s) | our master | container in {first} | relative |"
    head += "".join(f" container in {h} | {h} - {first}, relative |" for h in hosts[1:])
    lines = [head, "|---|---:|" + "---:|---:|" * len(hosts)]
    for r in rows:
        cells = [r.name, f"{r.master:.6g}", f"{r.hosts[first]:.6g}", f"{r.rel(first):.2g}"]
        for h in hosts[1:]:
            scale = max(abs(r.hosts[h]), abs(r.hosts[first]))
            cells += [f"{r.hosts[h]:.6g}", f"{abs(r.hosts[h] - r.hosts[first]) / scale if scale > 0 else 0.0:.2g}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


__all__ = ["HOSTS", "Row", "compare", "run_container", "start_differences", "table"]
