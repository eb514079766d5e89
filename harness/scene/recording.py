"""How much a run records, and the refusal of a run whose recorded samples would not fit in memory."""
from __future__ import annotations

import os

from typing import TYPE_CHECKING

from harness.scene.schema import MAX_STEPS, STEP_CAP, SceneError

if TYPE_CHECKING:
    from harness.scene.spec import Scene


def _available_memory() -> float:
    """Bytes of memory available to new allocations (MemAvailable), or the physical memory."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 8e9


MEMORY_SHARE = 0.5   # recorded samples may take at most this share of the available memory


def _count(x: float, where: str) -> int:
    if not (x < STEP_CAP):
        raise SceneError(f"{where}: {x:.3g} communication steps; allowed: at most {MAX_STEPS:,} steps "
                         "(--max-steps N raises the limit)")
    return int(round(x))


def recording_size(scene: Scene) -> tuple[int, int, int]:
    """(communication steps, recorded samples, values per sample) of a run of ``scene``."""
    where = f"scene {scene.name}: duration = {scene.duration:g} s at step = {scene.step:g} s"
    n_steps = _count(scene.duration / scene.step, where)
    rec_every = max(1, _count(scene.output_interval / scene.step, where.replace("duration", "output_interval", 1)))
    return n_steps, n_steps // rec_every + 2, 1 + len(scene.record)


def check_recording(scene: Scene, where: str = "", max_steps: int | None = None) -> None:
    """Refuse a run of more than ``max_steps`` communication steps (None: no limit), with the
    estimate of its steps and recorded rows; and one whose recorded samples would not fit in memory
    (``duration = 1e300``)."""
    n_steps, n_samples, width = recording_size(scene)
    if max_steps is not None and n_steps > max_steps:
        raise SceneError(f"{where or 'scene ' + scene.name}: duration = {scene.duration:g} s at step = "
                         f"{scene.step:g} s is {n_steps:,} communication steps recording {n_samples:,} samples (CSV rows) "
                         f"of {width} values; allowed: at most {max_steps:,} steps (--max-steps N raises the limit)")
    need, avail = 8.0 * n_samples * width, _available_memory()
    if need > MEMORY_SHARE * avail:
        most = MEMORY_SHARE * avail / (8.0 * width)
        raise SceneError(f"{where or 'scene ' + scene.name}: duration = {scene.duration:g} s at output_interval = "
                         f"{scene.output_interval:g} s records {n_samples:.3g} samples of {width} values "
                         f"({need / 1e9:.3g} GB); allowed: at most {most:.3g} samples ({100 * MEMORY_SHARE:g} % of "
                         f"the {avail / 1e9:.3g} GB available): shorten the duration or lengthen output_interval")
