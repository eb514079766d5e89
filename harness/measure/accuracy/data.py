"""The accuracy grid (``harness/measure/accuracy/accuracy_grid.toml``, data), the stored points
(``harness/measure/accuracy/accuracy_data.csv``) and facts (``harness/measure/accuracy/accuracy_facts.json``): where they are, how
they are read and written.

The stored files stay beside the package (``harness/``, shipped as package data). Other modules
look ``DATA_FILE`` and ``FACTS_FILE`` up here at call time (``data.FACTS_FILE``), so there is one
place that names them.
"""
from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from harness.common.paths import checkout_root, results_dir

_HERE = Path(__file__).resolve().parent   # harness/measure/accuracy/
GRID_FILE = _HERE / "accuracy_grid.toml"
DATA_FILE = _HERE / "accuracy_data.csv"
FACTS_FILE = _HERE / "accuracy_facts.json"   # references, solve_ivp points
STATS = ("mean", "max", "min")


@dataclass(frozen=True)
class Fidelity:
    """A named set of structural parameters of the differential (meshModel and effects)."""

    name: str
    effects: dict = field(default_factory=dict, hash=False, compare=False)


@dataclass
class Point:
    scene: str
    fidelity: str
    effects: dict
    step: float
    tolerance: float | None
    wall: float = math.nan
    error: float = math.nan
    metric_errors: dict = field(default_factory=dict)
    ok: bool = True
    reason: str = ""


def load_grid(path: Path = GRID_FILE) -> dict:
    from harness.scene.schema import read_toml, unknown

    data = read_toml(path)
    allowed = {"scene", "fidelities", "steps", "tolerances", "reference", "duration", "repeats", "repeat_budget",
               "quick"}
    for s in data.get("scene", []):
        unknown(path.name, s, allowed)
    return {s["scene"]: s for s in data.get("scene", [])}


def write_csv(points: list[Point], path: Path) -> None:
    from harness.common.outputs import atomic_file

    with atomic_file(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["scene", "fidelity", "effects", "step", "tolerance", "wall_s", "error", "ok", "reason",
                    "metric_errors"])
        for p in points:
            w.writerow([p.scene, p.fidelity, json.dumps(p.effects, sort_keys=True), repr(p.step),
                        "" if p.tolerance is None else repr(p.tolerance), repr(p.wall), repr(p.error),
                        int(p.ok), p.reason, json.dumps(p.metric_errors, sort_keys=True)])


def read_csv(path: Path = DATA_FILE) -> list[Point]:
    if not path.exists():
        return []
    out = []
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            out.append(Point(r["scene"], r["fidelity"], json.loads(r["effects"]), float(r["step"]),
                             float(r["tolerance"]) if r["tolerance"] else None, float(r["wall_s"]),
                             float(r["error"]), json.loads(r["metric_errors"]), bool(int(r["ok"])), r["reason"]))
    return out


def stored_files() -> tuple[Path, Path]:
    """The stored data and facts a run writes: the package's own in a checkout; an installed
    package is never written, there a run's data go to ./results/accuracy/ (fidelity = auto keeps
    reading the shipped data)."""
    installed = checkout_root() is None
    return (results_dir("accuracy", DATA_FILE.name) if installed else DATA_FILE,
            results_dir("accuracy", FACTS_FILE.name) if installed else FACTS_FILE)
