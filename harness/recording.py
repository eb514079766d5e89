"""How much a run records, and the refusal of a run whose recorded samples would not fit in memory."""
from __future__ import annotations

import os

from typing import TYPE_CHECKING

from harness.schema import SceneError

if TYPE_CHECKING:
    from harness.scene import Scene


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


def recording_size(scene: Scene) -> tuple[int, int, int]:
    """(communication steps, recorded samples, values per sample) of a run of ``scene``."""
    n_steps = int(round(scene.duration / scene.step))
    rec_every = max(1, int(round(scene.output_interval / scene.step)))
    return n_steps, n_steps // rec_every + 2, 1 + len(scene.record)


def check_recording(scene: Scene, where: str = "") -> None:
    """Refuse a run whose recorded samples would not fit in memory (``duration = 1e300``)."""
    n_steps, n_samples, width = recording_size(scene)
    need, avail = 8.0 * n_samples * width, _available_memory()
    if need > MEMORY_SHARE * avail:
        most = MEMORY_SHARE * avail / (8.0 * width)
        raise SceneError(f"{where or 'scene ' + scene.name}: duration = {scene.duration:g} s at output_interval = "
                         f"{scene.output_interval:g} s records {n_samples:.3g} samples of {width} values "
                         f"({need / 1e9:.3g} GB); allowed: at most {most:.3g} samples ({100 * MEMORY_SHARE:g} % of "
                         f"the {avail / 1e9:.3g} GB available): shorten the duration or lengthen output_interval")
