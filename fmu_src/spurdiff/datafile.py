"""Parameter data files (TOML) shared by the wheel-load and vehicle models.

The default data is ``spurdiff/data/passenger_car.toml``, bundled with the package (and so inside
every FMU, which carries the whole ``spurdiff`` package as a resource). Section and key names are
the models' structured parameter names (``halfShaft.c``, ``vehicle.m``, ...).
"""
from __future__ import annotations

import tomllib
from dataclasses import fields
from importlib import resources
from pathlib import Path

from .errors import ParameterError

DEFAULT_DATA = "passenger_car.toml"


def read_data(path: str | Path | None = None) -> dict:
    """The default-parameter TOML (``spurdiff/data/passenger_car.toml``) or ``path`` as a dict."""
    if path is None:
        return tomllib.loads(resources.files("spurdiff.data").joinpath(DEFAULT_DATA).read_text())
    return tomllib.loads(Path(path).read_text())


def section(cls, data: dict, name: str):
    """Build dataclass ``cls`` from ``data[name]``; unknown keys raise ParameterError."""
    values = dict(data.get(name, {}))
    known = {f.name for f in fields(cls)}
    for key in values:
        if key not in known:
            raise ParameterError(f"{name}.{key}", values[key], "one of " + ", ".join(sorted(known)),
                                 "unknown parameter")
    return cls(**values)


__all__ = ["read_data", "section", "DEFAULT_DATA"]
