"""Parameter data files (TOML): the car's (wheel-load and vehicle models) and the differential's.

The default data are ``spurdiff/data/passenger_car.toml`` and ``spurdiff/data/differential.toml``,
bundled with the package (and so inside every FMU, which carries the whole ``spurdiff`` package as
a resource, in one archive: ``resources/spurdiff.zip``). They are read once, when this module is
imported, from the ``data/`` folder beside this file, by the package's own loader
(:func:`package_bytes`: a file of a folder, or a member of the archive): never through the
package's global name (an FMU loads its copy of the package under a private name) and never later
(a host may delete an FMU's extraction folder while its instances live on). Section and key names are the models' structured parameter names (``halfShaft.c``,
``vehicle.m``, ``sunA.z``, ``meshA1.backlash``...).

Every bundled data file is parsed by :func:`parse_bundled`: from ``data/parsed_toml.json`` (the
files parsed beforehand: each one's size, CRC-32 and what ``tomllib`` made of it, written by
:func:`write_parsed`) when the file's text is the one that was parsed, else by ``tomllib`` as the
file is. So an FMU starts without importing ``tomllib`` (its parser, regular expressions and
``datetime``: some 5 ms of a start, docs/performance.md), and an edited data file is still read as
it is; ``tests/physics/test_parsed_toml.py`` fails until :func:`write_parsed` (run from a checkout)
brought the parsed copy up to date.
"""
from __future__ import annotations

import copy
import os
import zlib
from dataclasses import fields
from functools import lru_cache
from pathlib import Path

from spurdiff.errors import ParameterError

DEFAULT_DATA = "passenger_car.toml"
DIFFERENTIAL_DATA = "differential.toml"
# a checkout's or an installation's data/ (write_parsed, the tests); the models read through package_bytes
DATA_FOLDER = Path(__file__).resolve().parent / "data"     # this package's own data/, whatever its name
PARSED_FILE = DATA_FOLDER / "parsed_toml.json"    # the bundled files parsed (write_parsed)
_HERE = os.path.dirname(__file__)   # the package's folder (in an FMU: <resources>/spurdiff.zip/spurdiff)


def package_bytes(rel: str) -> bytes:
    """The package's file ``rel`` ('/'-separated, relative to the package's folder), read by the
    package's loader: from a folder, or from the archive an FMU carries the package in (zipimport:
    its ``get_data`` takes the path inside the archive). OSError when it is not there."""
    return __loader__.get_data(os.path.join(_HERE, *rel.split("/")))


def bundled_text(name: str) -> str:
    """The bundled data file ``data/<name>`` as text (:func:`package_bytes`)."""
    return package_bytes(f"data/{name}").decode("utf-8")


# the bundled files' text, read at import from this package's own folder
_BUNDLED = {name: bundled_text(name) for name in (DEFAULT_DATA, DIFFERENTIAL_DATA)}


def read_data(path: str | Path | None = None, bundled: str = DEFAULT_DATA) -> dict:
    """The bundled default-parameter TOML ``spurdiff/data/<bundled>`` (one of :data:`DEFAULT_DATA`,
    :data:`DIFFERENTIAL_DATA`, as read at import) or the file ``path`` as a dict."""
    if path is None:
        if bundled not in _BUNDLED:
            raise ValueError(f"bundled = {bundled!r}: the bundled data files are {', '.join(_BUNDLED)}")
        return copy.deepcopy(_parsed(bundled))     # the caller's own copy: it may change it
    import tomllib
    return tomllib.loads(Path(path).read_text())


@lru_cache(maxsize=None)
def _parsed(bundled: str) -> dict:
    """A bundled file parsed once per process (a run's setup asked for them about 15 times: 1.3 ms
    a parse, 0.05 ms a copy)."""
    return parse_bundled(bundled, _BUNDLED[bundled])


def parse_bundled(name: str, text: str | None = None) -> dict:
    """``tomllib.loads(text)`` of the bundled data file ``data/<name>`` whose text is ``text`` (read
    now when None): the parsed copy's data when it was made of this very text (size and CRC-32 of
    its UTF-8), else the text parsed; a new dict at each call either way (the caller may change it)."""
    if text is None:
        text = bundled_text(name)
    entry = _parsed_files().get(name)
    if entry is not None:
        raw = text.encode("utf-8")
        if entry["size"] == len(raw) and entry["crc32"] == zlib.crc32(raw):
            return copy.deepcopy(entry["data"])
    import tomllib      # (a data file edited since write_parsed)
    return tomllib.loads(text)


@lru_cache(maxsize=None)
def _parsed_files() -> dict:
    """The entries of :data:`PARSED_FILE` by file name ({} without a readable one: every file parsed)."""
    import json
    try:
        files = json.loads(package_bytes(f"data/{PARSED_FILE.name}").decode("utf-8"))["files"]
    except (OSError, ValueError, KeyError, TypeError):
        return {}
    return files if isinstance(files, dict) else {}


def parsed_entries() -> dict:
    """What :data:`PARSED_FILE` holds for the data files as they are now: name -> size, CRC-32 (of
    the UTF-8 text) and ``tomllib``'s data, for every ``data/*.toml``."""
    import tomllib
    out = {}
    for path in sorted(DATA_FOLDER.glob("*.toml")):
        text = path.read_text(encoding="utf-8")
        raw = text.encode("utf-8")
        out[path.name] = {"size": len(raw), "crc32": zlib.crc32(raw), "data": tomllib.loads(text)}
    return out


def write_parsed() -> Path:
    """Write :data:`PARSED_FILE` from the data files as they are (after one changed); its path. (A
    ``nan`` of a file is written as JSON's ``NaN``, which :mod:`json` reads back.)"""
    import json
    doc = {"about": "spurdiff/data/*.toml parsed by tomllib, each with the size and CRC-32 of its UTF-8 text: "
                    "written by write_parsed() of the package's datafile module (do not edit; the TOML files are "
                    "the sources)",
           "files": parsed_entries()}
    PARSED_FILE.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    return PARSED_FILE


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


__all__ = ["read_data", "section", "differential_default", "parse_bundled", "write_parsed", "bundled_text",
           "package_bytes", "DEFAULT_DATA",
           "DIFFERENTIAL_DATA"]
