"""Parameter data files (TOML): the car's (wheel-load and vehicle models) and the differential's.

The default data are ``spurdiff/data/passenger_car.toml`` and ``spurdiff/data/differential.toml``,
bundled with the package (and so inside every FMU, which carries the whole ``spurdiff`` package as
a resource). Section and key names are the models' structured parameter names (``halfShaft.c``,
``vehicle.m``, ``sunA.z``, ``meshA1.backlash``...).
"""
from __future__ import annotations

import tomllib
from dataclasses import fields
from functools import lru_cache
from importlib import resources
from pathlib import Path

from .errors import ParameterError

DEFAULT_DATA = "passenger_car.toml"
DIFFERENTIAL_DATA = "differential.toml"


def read_data(path: str | Path | None = None, bundled: str = DEFAULT_DATA) -> dict:
    """The bundled default-parameter TOML ``spurdiff/data/<bundled>`` or ``path`` as a dict."""
    if path is None:
        return tomllib.loads(resources.files("spurdiff.data").joinpath(bundled).read_text())
    return tomllib.loads(Path(path).read_text())


@lru_cache(maxsize=None)
def _differential() -> dict:
    return read_data(bundled=DIFFERENTIAL_DATA)


def differential_default(key: str):
    """The differential's default for the structured name ``key`` (``mu_pin``, ``gearing.m``,
    ``sunA`` (a table as a dict), ``meshA1.backlash``) from ``spurdiff/data/differential.toml``."""
    value = _differential()
    for part in key.split("."):
        value = value[part]
    return dict(value) if isinstance(value, dict) else value


def section(cls, data: dict, name: str):
    """Build dataclass ``cls`` from ``data[name]``; unknown keys raise ParameterError."""
    values = dict(data.get(name, {}))
    known = {f.name for f in fields(cls)}
    for key in values:
        if key not in known:
            raise ParameterError(f"{name}.{key}", values[key], "one of " + ", ".join(sorted(known)),
                                 "unknown parameter")
    return cls(**values)


__all__ = ["read_data", "section", "differential_default", "DEFAULT_DATA", "DIFFERENTIAL_DATA"]
