"""Named gear sets and the loader option that picks one: ``paper`` (the paper's gear table, the
defaults of ``spurdiff/data/differential.toml``; the paper scenes use it and reproduce the paper's
tables) and ``designed`` (``spurdiff/data/gear_set_designed.toml``, written by ``spurdiff design``:
no undercut, no tip interference, usable contact ratio >= 1.2 on every mesh; docs/capacity.md).

:func:`gear_set` gives the :class:`GearTable` of a set, :func:`fmu_parameters` the SpurDifferential
parameters that select it (``sunA.x``, ``sunA.da``, ...), for a scene's ``[fmus.<diff>.parameters]``.
"""
from __future__ import annotations

from dataclasses import fields, replace

from spurdiff.datafile import bundled_text, parse_bundled
from spurdiff.errors import ParameterError
from spurdiff.gears.geometry import Gear, GearTable

DESIGNED_FILE = "gear_set_designed.toml"
GEAR_NAMES = ("sunA", "planet1", "sunB", "planet2")
GEARING_KEYS = ("m", "alpha", "ha", "hf", "haP0", "rhoaP0")
CARRIER_KEYS = ("wallB", "axialClearance")   # the axial layout's walls (spurdiff.gears.axial)
# read once at import, from this package's own data folder (see spurdiff.datafile)
_DESIGNED_TEXT = bundled_text(DESIGNED_FILE)
SETS = ("paper", "designed")


def table_from_data(data: dict, base: GearTable | None = None) -> GearTable:
    """A gear table from data with differential.toml's keys (``nPairs``, ``[gearing]``, ``[sunA]``...),
    missing keys from ``base``; an unknown key is a ParameterError naming it."""
    t = base or GearTable()
    gearing = dict(data.get("gearing", {}))
    for k in gearing:
        if k not in GEARING_KEYS:
            raise ParameterError(f"gearing.{k}", gearing[k], "one of " + ", ".join(GEARING_KEYS), "unknown key")
    t = replace(t, **gearing)
    if "nPairs" in data:
        t = replace(t, nPairs=data["nPairs"])
    carrier = dict(data.get("carrier", {}))
    for k in carrier:
        if k not in CARRIER_KEYS:
            raise ParameterError(f"carrier.{k}", carrier[k], "one of " + ", ".join(CARRIER_KEYS), "unknown key")
    t = replace(t, carrier=replace(t.carrier, **carrier))
    known = {f.name for f in fields(Gear)}
    for n in GEAR_NAMES:
        sec = dict(data.get(n, {}))
        for k in sec:
            if k not in known:
                raise ParameterError(f"{n}.{k}", sec[k], "one of " + ", ".join(sorted(known)), "unknown key")
        t = t.with_gear(n, **sec)
    return t


def gear_set(name: str = "paper") -> GearTable:
    """The gear table of the named set (``paper`` | ``designed``)."""
    if name == "paper":
        return GearTable.paper()
    if name == "designed":
        return table_from_data(parse_bundled(DESIGNED_FILE, _DESIGNED_TEXT))
    raise ParameterError("gearSet", name, " | ".join(SETS))


def fmu_parameters(table: GearTable | str) -> dict:
    """The SpurDifferential parameters (structured names) that give ``table`` (or the named set)."""
    t = gear_set(table) if isinstance(table, str) else table
    out = {f"gearing.{k}": getattr(t, k) for k in GEARING_KEYS}
    out["nPairs"] = t.nPairs
    for n in GEAR_NAMES:
        g = getattr(t, n)
        out.update({f"{n}.z": g.z, f"{n}.x": g.x, f"{n}.b": g.b, f"{n}.da": g.da})
        if g.axialStart is not None:
            out[f"{n}.axialStart"] = g.axialStart
    out.update({f"carrier.{k}": getattr(t.carrier, k) for k in CARRIER_KEYS})
    return out


__all__ = ["SETS", "gear_set", "fmu_parameters", "table_from_data", "DESIGNED_FILE"]
