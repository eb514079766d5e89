"""The data a sweep sends to its workers: the job (scene, FMUs, metrics, time limit), one task
per run, and the statuses a run ends with."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from harness.scene.spec import Scene

STATUSES = ("ok", "failed", "timeout", "error", "crashed")


# ---------------------------------------------------------------------------------------- job data
@dataclass(frozen=True)
class FmuRef:
    """An FMU file as the driver sees it: name, sha256 of the bytes, path, and (for clusters) the bytes."""

    name: str
    digest: str
    path: str
    data: bytes | None = None


@dataclass(frozen=True)
class Metric:
    """One result column.

    kind ``stat``: ``harness.run.report.stat(result, var, stat, window)`` of a recorded quantity;
    kind ``expr``: arithmetic over earlier columns (``{name}`` or ``{inst.param}``);
    kind ``theory``: a closed-form value (:data:`THEORIES`) from the run's parameters of ``instance``.
    """

    name: str
    kind: str
    var: str = ""
    stat: str = "mean"
    window: tuple[float, float] | None = None
    expr: str = ""
    theory: str = ""
    instance: str = ""


@dataclass
class Job:
    """Everything a worker needs for every run of one sweep."""

    scene: Scene                      # with overrides and fixed parameters applied, metric vars recorded
    fmus: dict[str, FmuRef]           # FMU name -> file
    metrics: list[Metric]
    timeout: float | None = None      # s of wall time per run (checked between steps)


@dataclass(frozen=True)
class Task:
    """One run: its number in the sweep and the parameter values it sets ('inst.param' -> value)."""

    run: int
    params: dict[str, Any] = field(default_factory=dict)
