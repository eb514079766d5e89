"""Scenes: TOML files that say which FMUs run, how they are connected and what to check.

A scene is data (``harness/scenes/*.toml``), read with :mod:`tomllib` and validated here: every
unknown key is rejected with a message that names it and lists the allowed ones.

Top-level keys::

    name, description             text
    duration                      simulated time, s
    step                          communication step, s
    output_interval               recording interval, s (default: step)
    algorithm                     "gauss-seidel" (default) | "jacobi"
    order                         list of instance names: Gauss-Seidel order (default: as declared)
    effects                       table of structural parameters of the differential (meshModel, ...)
    [fmus.<instance>]             fmu = "SpurDifferential" | ..., parameters = {name = value}
    inputs                        {"inst.var" = number | {table = [[t, v], ...]} | {step = {...}}}
    connections                   {"to_inst.var" = "from_inst.var"}
    couplings                     [[couplings]]: power bonds to monitor (name, torque, w_from, w_to)
    record                        list of "inst.var" to record (default: every connected/profiled var)
    table                         [[table]] rows of the results table (label, var, scale, unit, paper, theory, window)
    checks                        [[checks]] physical checks (name, stat, var, window, expect/rtol/atol/below/above)
    fidelity                      "fixed" (default) | {mode = "auto", outputs = ["inst.var", ...], tolerance = 0.01,
                                  data = "scene"}: pick the cheapest measured fidelity and step (harness/accuracy.py)
    extends                       name of a scene this one starts from: its tables are merged key by key,
                                  every other value (lists included) is replaced

A quantity (``var``, ``expect_var``, a string ``theory``) is a recorded variable ``"inst.var"`` or an
expression over them in braces, e.g. ``"{wheelR.wheel.w} / {wheelL.wheel.w}"`` (numpy arithmetic,
``abs``, ``sqrt``, ``maximum``, ``minimum``; evaluated sample by sample).
"""
from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

SCENE_DIR = Path(__file__).resolve().parent / "scenes"

TOP_KEYS = {"name", "description", "duration", "step", "output_interval", "algorithm", "order", "effects",
            "fmus", "inputs", "connections", "couplings", "record", "table", "checks", "fidelity",
            "extends"}
FIDELITY_KEYS = {"mode", "outputs", "tolerance", "data"}
FMU_KEYS = {"fmu", "parameters"}
TABLE_KEYS = {"label", "var", "scale", "unit", "paper", "theory", "paper_max", "paper_min", "window"}
CHECK_KEYS = {"name", "stat", "var", "window", "expect", "rtol", "atol", "below", "above", "expect_var"}
COUPLING_KEYS = {"name", "torque", "w_from", "w_to", "sign"}
STATS = {"mean", "max", "min", "final", "absmax", "span"}
ALGORITHMS = {"gauss-seidel", "jacobi"}


class SceneError(ValueError):
    """A scene file that cannot be run (bad key, bad value, unknown FMU or variable)."""


_REF = re.compile(r"\{([^{}]+)\}")


def refs_of(quantity: str) -> list[str]:
    """Variables a quantity needs: 'inst.var' itself, or every {inst.var} in an expression."""
    if not isinstance(quantity, str):
        return []
    return _REF.findall(quantity) if "{" in quantity else [quantity]


@dataclass
class Profile:
    """An input profile: constant, piecewise-linear table, or a step."""

    kind: str
    value: float = 0.0
    times: tuple[float, ...] = ()
    values: tuple[float, ...] = ()

    def __call__(self, t: float) -> float:
        if self.kind == "constant":
            return self.value
        ts, vs = self.times, self.values
        if t <= ts[0]:
            return vs[0]
        if t >= ts[-1]:
            return vs[-1]
        for i in range(1, len(ts)):
            if t <= ts[i]:
                t0, t1 = ts[i - 1], ts[i]
                if t1 == t0:
                    return vs[i]
                return vs[i - 1] + (vs[i] - vs[i - 1]) * (t - t0) / (t1 - t0)
        return vs[-1]


@dataclass
class FmuInstance:
    name: str
    fmu: str
    parameters: dict[str, Any] = field(default_factory=dict)


@dataclass
class Scene:
    name: str
    description: str
    duration: float
    step: float
    output_interval: float
    algorithm: str
    instances: list[FmuInstance]
    inputs: dict[str, Profile]
    connections: dict[str, str]
    couplings: list[dict]
    record: list[str]
    table: list[dict]
    checks: list[dict]
    effects: dict[str, Any]
    fidelity: dict[str, Any]
    source: Path | None = None

    def instance(self, name: str) -> FmuInstance:
        for inst in self.instances:
            if inst.name == name:
                return inst
        raise SceneError(f"scene {self.name}: no FMU instance named {name!r}")


def _unknown(where: str, keys, allowed) -> None:
    bad = sorted(set(keys) - set(allowed))
    if bad:
        raise SceneError(f"{where}: unknown key{'s' if len(bad) > 1 else ''} {', '.join(repr(b) for b in bad)}; "
                         f"allowed: {', '.join(sorted(allowed))}")


def _positive(where: str, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SceneError(f"{where} = {value!r}: allowed a number > 0") from None
    if not (v > 0.0 and math.isfinite(v)):
        raise SceneError(f"{where} = {value!r}: allowed a finite number > 0")
    return v


def _profile(where: str, spec) -> Profile:
    if isinstance(spec, bool):
        raise SceneError(f"{where}: allowed a number, {{table = [[t, v], ...]}} or {{step = ...}}")
    if isinstance(spec, (int, float)):
        if not math.isfinite(float(spec)):
            raise SceneError(f"{where} = {spec!r}: allowed a finite number")
        return Profile("constant", float(spec))
    if isinstance(spec, dict):
        _unknown(where, spec, {"table", "step"})
        if "table" in spec:
            rows = spec["table"]
            try:
                ts = tuple(float(r[0]) for r in rows)
                vs = tuple(float(r[1]) for r in rows)
            except (TypeError, ValueError, IndexError):
                raise SceneError(f"{where}.table: allowed a list of [time, value] pairs") from None
            if not ts or any(b < a for a, b in zip(ts, ts[1:])) or not all(map(math.isfinite, ts + vs)):
                raise SceneError(f"{where}.table: times must be finite and non-decreasing, values finite")
            return Profile("table", times=ts, values=vs)
        st = spec["step"]
        _unknown(f"{where}.step", st, {"time", "before", "after", "rise"})
        t0, rise = float(st.get("time", 0.0)), float(st.get("rise", 0.0))
        b, a = float(st.get("before", 0.0)), float(st.get("after", 0.0))
        return Profile("table", times=(t0, t0 + rise), values=(b, a))
    raise SceneError(f"{where}: allowed a number, {{table = [[t, v], ...]}} or {{step = {{time, before, after}}}}")


def _split(where: str, ref: str, names: set[str]) -> tuple[str, str]:
    if not isinstance(ref, str) or "." not in ref:
        raise SceneError(f"{where}: {ref!r} is not of the form 'instance.variable'")
    inst, var = ref.split(".", 1)
    if inst not in names:
        raise SceneError(f"{where}: {ref!r} names unknown FMU instance {inst!r}; allowed: {', '.join(sorted(names))}")
    return inst, var


def parse_scene(data: dict, source: Path | None = None) -> Scene:
    where = str(source.name) if source else "scene"
    _unknown(where, data, TOP_KEYS)
    for req in ("name", "duration", "step", "fmus"):
        if req not in data:
            raise SceneError(f"{where}: missing required key {req!r}")
    duration = _positive(f"{where}: duration", data["duration"])
    step = _positive(f"{where}: step", data["step"])
    if step > duration:
        raise SceneError(f"{where}: step = {step} s is longer than duration = {duration} s")
    out = _positive(f"{where}: output_interval", data.get("output_interval", step))
    algorithm = data.get("algorithm", "gauss-seidel")
    if algorithm not in ALGORITHMS:
        raise SceneError(f"{where}: algorithm = {algorithm!r}; allowed: {', '.join(sorted(ALGORITHMS))}")
    instances = []
    if not isinstance(data["fmus"], dict) or not data["fmus"]:
        raise SceneError(f"{where}: [fmus.<instance>] tables required")
    for name, spec in data["fmus"].items():
        _unknown(f"{where}: fmus.{name}", spec, FMU_KEYS)
        if "fmu" not in spec:
            raise SceneError(f"{where}: fmus.{name}: missing key 'fmu'")
        instances.append(FmuInstance(name, spec["fmu"], dict(spec.get("parameters", {}))))
    names = {i.name for i in instances}
    order = data.get("order")
    if order is not None:
        if sorted(order) != sorted(names):
            raise SceneError(f"{where}: order must list each instance once: {', '.join(sorted(names))}")
        instances.sort(key=lambda i: order.index(i.name))
    inputs = {}
    for ref, spec in data.get("inputs", {}).items():
        _split(f"{where}: inputs", ref, names)
        inputs[ref] = _profile(f"{where}: inputs.{ref!r}", spec)
    connections = {}
    for to, frm in data.get("connections", {}).items():
        _split(f"{where}: connections", to, names)
        _split(f"{where}: connections", frm, names)
        if to in inputs:
            raise SceneError(f"{where}: {to!r} is both connected and given an input profile")
        connections[to] = frm
    couplings = []
    for c in data.get("couplings", []):
        _unknown(f"{where}: couplings", c, COUPLING_KEYS)
        for k in ("name", "torque", "w_from", "w_to"):
            if k not in c:
                raise SceneError(f"{where}: couplings: missing key {k!r}")
            if k != "name":
                _split(f"{where}: couplings.{k}", c[k], names)
        couplings.append(dict(c))
    record = list(data.get("record", []))
    for r in record:
        _split(f"{where}: record", r, names)
    table = []
    for row in data.get("table", []):
        _unknown(f"{where}: table", row, TABLE_KEYS)
        for ref in refs_of(row.get("var", "")) + refs_of(row.get("theory")):
            _split(f"{where}: table {row.get('label', '')!r}", ref, names)
        table.append(dict(row))
    checks = []
    for c in data.get("checks", []):
        _unknown(f"{where}: checks", c, CHECK_KEYS)
        if c.get("stat") not in STATS:
            raise SceneError(f"{where}: checks.stat = {c.get('stat')!r}; allowed: {', '.join(sorted(STATS))}")
        for ref in refs_of(c.get("var", "")) + refs_of(c.get("expect_var")):
            _split(f"{where}: checks {c.get('name', '')!r}", ref, names)
        checks.append(dict(c))
    quantities = ([t["var"] for t in table] + [t.get("theory") for t in table] + [c["var"] for c in checks]
                  + [c.get("expect_var") for c in checks])
    for q in quantities:
        for r in refs_of(q):
            if r not in record:
                record.append(r)
    effects = dict(data.get("effects", {}))
    fidelity = data.get("fidelity", {})
    if isinstance(fidelity, str):
        fidelity = {"mode": fidelity}
    _unknown(f"{where}: fidelity", fidelity, FIDELITY_KEYS)
    if fidelity.get("mode", "fixed") not in ("fixed", "auto"):
        raise SceneError(f"{where}: fidelity mode = {fidelity['mode']!r}; allowed: fixed | auto")
    if fidelity.get("mode") == "auto":
        outs = fidelity.get("outputs")
        if not isinstance(outs, list) or not outs or not all(isinstance(o, str) for o in outs):
            raise SceneError(f"{where}: fidelity auto needs outputs = a non-empty list of quantities")
        tol = fidelity.get("tolerance", 0.01)
        if not isinstance(tol, (int, float)) or not 0 < tol < 1e3:
            raise SceneError(f"{where}: fidelity tolerance = {tol!r}; allowed: a number > 0 (relative error)")
        fidelity.setdefault("data", data.get("extends", data["name"]))
    return Scene(name=str(data["name"]), description=str(data.get("description", "")), duration=duration,
                 step=step, output_interval=out, algorithm=algorithm, instances=instances, inputs=inputs,
                 connections=connections, couplings=couplings, record=record, table=table, checks=checks,
                 effects=effects, fidelity=dict(fidelity), source=source)


def scene_path(name_or_path: str) -> Path:
    p = Path(name_or_path)
    if p.suffix == ".toml" and p.exists():
        return p
    q = SCENE_DIR / f"{name_or_path}.toml"
    if q.exists():
        return q
    raise SceneError(f"unknown scene {name_or_path!r}; available: {', '.join(available())}")


def merge(base: dict, over: dict) -> dict:
    """``over`` on top of ``base``: tables merge key by key, any other value replaces."""
    out = dict(base)
    for k, v in over.items():
        out[k] = merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def read_scene_data(name_or_path: str, _seen: tuple[str, ...] = ()) -> dict:
    """The scene's TOML data with ``extends`` resolved (its parent's tables merged underneath)."""
    path = scene_path(name_or_path)
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise SceneError(f"{path.name}: not valid TOML: {e}") from None
    parent = data.get("extends")
    if parent is None:
        return data
    if not isinstance(parent, str):
        raise SceneError(f"{path.name}: extends = {parent!r}; allowed: a scene name")
    if parent in _seen + (path.stem,):
        raise SceneError(f"{path.name}: extends {parent!r} makes a cycle")
    base = read_scene_data(parent, _seen + (path.stem,))
    base.pop("fidelity", None)
    return merge(base, data)


def load_scene(name_or_path: str) -> Scene:
    path = scene_path(name_or_path)
    return parse_scene(read_scene_data(name_or_path), path)


def available() -> list[str]:
    return sorted(p.stem for p in SCENE_DIR.glob("*.toml"))


def describe_all() -> list[tuple[str, str]]:
    out = []
    for name in available():
        try:
            out.append((name, load_scene(name).description.split("\n")[0]))
        except SceneError as e:
            out.append((name, f"INVALID: {e}"))
    return out
