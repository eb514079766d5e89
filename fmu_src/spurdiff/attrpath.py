"""Dotted attribute paths (``"mesh_forces.F_A1"``) read and written on a model: what an FMU
variable's ``bind`` names (:mod:`spurdiff.fmi.binding`) and a native step's slots
(:mod:`spurdiff.native_step`) address."""
from __future__ import annotations

from typing import Any


def resolve(obj: Any, path: str) -> Any:
    """The value at the dotted attribute ``path`` of ``obj``."""
    for part in path.split("."):
        obj = getattr(obj, part)
    return obj


def assign(obj: Any, path: str, value: Any) -> None:
    """Set the dotted attribute ``path`` of ``obj`` to ``value``."""
    head, _, last = path.rpartition(".")
    setattr(resolve(obj, head) if head else obj, last, value)
