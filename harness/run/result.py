"""The result of a run, whoever ran it (our master, the variable-step controller, the direct
physics, libcosim): recorded trajectories (``time`` plus one array per variable) and run facts."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


class NotRecorded(KeyError, ValueError):
    """A variable that was not recorded (a KeyError, and a ValueError as ``list.index`` raises)."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


@dataclass
class Result:
    """Recorded trajectories and run facts. ``failure`` is None for a complete run, else why it
    stopped (a :class:`harness.run.master.RunFailure`, an ``Interrupted``, or a text)."""

    scene: Any                           # the Scene that ran (None when only an SSP file was run)
    names: list[str]
    data: np.ndarray                     # shape (n_samples, 1 + len(names)), column 0 is time
    wall_time: float = float("nan")      # s spent stepping (after initialization)
    steps: int = 0
    failure: Any = None
    coupling_energy: dict[str, dict[str, float]] = field(default_factory=dict)
    messages: list[str] = field(default_factory=list)
    chosen: dict[str, Any] = field(default_factory=dict)
    setup_time: float = 0.0              # s to load, instantiate and initialize the FMUs
    step: float | None = None            # s, the communication step (when the runner reports it)

    @property
    def time(self) -> np.ndarray:
        return self.data[:, 0]

    def __getitem__(self, name: str) -> np.ndarray:
        if name == "time":
            return self.time
        try:
            return self.data[:, 1 + self.names.index(name)]
        except ValueError:
            raise NotRecorded(f"{name!r} was not recorded; recorded: {', '.join(self.names)}") from None

    @property
    def ok(self) -> bool:
        return self.failure is None
