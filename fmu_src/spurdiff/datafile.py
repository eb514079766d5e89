"""Parameter data files (TOML): the car's (wheel-load and vehicle models) and the differential's.

The default data are ``spurdiff/data/passenger_car.toml`` and ``spurdiff/data/differential.toml``,
bundled with the package (and so inside every FMU, which carries the whole ``spurdiff`` package as
a resource). They are read once, when this module is imported, from the ``data/`` folder beside
this file: never through the package's global name (an FMU loads its copy of the package under a
private name) and never later (a host may delete an FMU's extraction folder while its instances
live on). Section and key names are the models' structured parameter names (``halfShaft.c``,
``vehicle.m``, ``sunA.z``, ``meshA1.backlash``...).
"""
from __future__ import annotations

import copy
import tomllib
from dataclasses import fields
from functools import lru_cache
from pathlib import Path

from spurdiff.errors import ParameterError

DEFAULT_DATA = "passenger_car.toml"
DIFFERENTIAL_DATA = "differential.toml"
DATA_FOLDER = Path(__file__).resolve().parent / "data"     # this package's own data/, whatever its name
# the bundled files' text, read at import from this package's own folder
_BUNDLED = {name: (DATA_FOLDER / name).read_text(encoding="utf-8") for name in (DEFAULT_DATA, DIFFERENTIAL_DATA)}


def read_data(path: str | Path | None = None, bundled: str = DEFAULT_DATA) -> dict:
    """The bundled default-parameter TOML ``spurdiff/data/<bundled>`` (one of :data:`DEFAULT_DATA`,
    :data:`DIFFERENTIAL_DATA`, as read at import) or the file ``path`` as a dict."""
    if path is None:
        if bundled not in _BUNDLED:
            raise ValueError(f"bundled = {bundled!r}: the bundled data files are {', '.join(_BUNDLED)}")
        return copy.deepcopy(_parsed(bundled))     # the caller's own copy: it may change it
    return tomllib.loads(Path(path).read_text())


@lru_cache(maxsize=None)
def _parsed(bundled: str) -> dict:
    """A bundled file parsed once per process (a run's setup asked for them about 15 times: 1.3 ms
    a parse, 0.05 ms a copy)."""
    return tomllib.loads(_BUNDLED[bundled])


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
