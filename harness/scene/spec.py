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
    [fmus.<instance>]             fmu = "SpurDifferential" | ..., parameters = {name = value},
                                  gearSet = "paper" | "designed" (SpurDifferential only: the named gear set's
                                  parameters, spurdiff.gears.design_sets.fmu_parameters, under its own parameters)
    inputs                        {"inst.var" = number | {table = [[t, v], ...]} | {step = {...}}}
    connections                   {"to_inst.var" = "from_inst.var"}
    couplings                     [[couplings]]: power bonds to monitor (name, torque, w_from, w_to)
    record                        list of "inst.var" to record (default: every connected/profiled var;
                                  each once; at most MAX_RECORD = 10,000 entries)
    table                         [[table]] rows of the results table (label, var, scale, unit, paper, theory, window;
                                  accuracy = false: a flag, not one of the quantities `spurdiff accuracy` compares)
    checks                        [[checks]] physical checks (name, stat, var, window, expect/rtol/atol/below/above,
                                  fidelity: the mesh models it holds at, others report it as not checked)
    fidelity                      "fixed" (default) | {mode = "auto", outputs = ["inst.var", ...], tolerance = 0.01,
                                  data = "scene"}: pick the cheapest measured fidelity and step (harness/measure/accuracy/auto.py)
    extends                       name of a scene this one starts from: its tables are merged key by key,
                                  every other value (lists included) is replaced

A quantity (``var``, ``expect_var``, a string ``theory``) is a recorded variable ``"inst.var"`` or an
expression over them in braces, e.g. ``"{wheelR.wheel.w} / {wheelL.wheel.w}"``: arithmetic,
comparisons and a few named functions, checked when the scene is read and evaluated sample by
sample without ``eval`` (:mod:`harness.scene.expressions`).

A scene's ``name`` becomes a file and folder name: letters, digits, ``_``, ``-`` and ``.``, no ``..``.
Values must have the types above; a wrong type is refused with one line naming the key. Parameter
values are converted by the FMU variable's type (:func:`parameter_value`) before they are set.

(Over 400 lines: about 35 are the key reference above; the rest is one scene, read, its ``extends``
resolved and each table checked; the shared checks are :mod:`harness.scene.schema`, the expressions
:mod:`harness.scene.expressions`.)
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from harness.scene import theory
from harness.common.messages import shown
from harness.scene.schema import (SceneError, is_safe_name, number as _number, parameter_value, positive as _positive,  # noqa: F401
                                  read_toml, safe_name, strings as _strings, table as _table_of, tables as _tables,
                                  text as _text, unknown as _unknown, window as _window)
from harness.scene.schema import MAX_STEPS, STEP_CAP
from harness.scene.profiles import Profile, parse_profile

SCENE_DIR = Path(__file__).resolve().parents[1] / "scenes"
MAX_RECORD = 10_000   # entries of a scene's record list (a model has a few hundred variables)

TOP_KEYS = {"name", "description", "duration", "step", "output_interval", "algorithm", "order", "effects",
            "fmus", "inputs", "connections", "couplings", "record", "table", "checks", "fidelity",
            "extends"}
FIDELITY_KEYS = {"mode", "outputs", "tolerance", "data"}
FMU_KEYS = {"fmu", "parameters", "gearSet"}
TABLE_KEYS = {"label", "var", "scale", "unit", "paper", "theory", "paper_max", "paper_min", "window", "accuracy"}
CHECK_KEYS = {"name", "stat", "var", "window", "expect", "rtol", "atol", "below", "above", "expect_var", "fidelity"}
COUPLING_KEYS = {"name", "torque", "w_from", "w_to", "sign"}
STATS = {"mean", "max", "min", "final", "absmax", "span"}
EXPECTATIONS = ("expect", "expect_var", "below", "above")   # what makes a check able to fail
ALGORITHMS = {"gauss-seidel", "jacobi"}


EFFECTS_FMU = "SpurDifferential"   # the FMU whose structural parameters a scene's [effects] table sets


_REF = re.compile(r"\{([^{}]+)\}")


def refs_of(quantity: str) -> list[str]:
    """Variables a quantity needs: 'inst.var' itself, or every {inst.var} in an expression."""
    if not isinstance(quantity, str):
        return []
    return [r.strip() for r in _REF.findall(quantity)] if "{" in quantity else [quantity]


@dataclass
class FmuInstance:
    name: str
    fmu: str
    parameters: dict[str, Any] = field(default_factory=dict)
    gear_set: str | None = None          # the named gear set (``gearSet``), SpurDifferential only
    gear_parameters: dict[str, Any] = field(default_factory=dict)   # its parameters (fmu_parameters)


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
        raise SceneError(f"scene {self.name}: no FMU instance named {shown(name)}")

    def parameter_sources(self, instance: str) -> list[tuple[str, dict[str, Any]]]:
        """Where an instance's parameter values come from, lowest priority first, as (prefix for
        messages, table): the scene's ``effects`` for the differential, then its named gear set's
        parameters (``gearSet``), then its own parameters."""
        spec = self.instance(instance)
        own = (f"{spec.name}.", spec.parameters)
        if spec.fmu != EFFECTS_FMU:
            return [own]
        gear = [(f"{spec.name}.gearSet = {spec.gear_set}: ", spec.gear_parameters)] if spec.gear_set else []
        return [("effects.", self.effects), *gear, own]

    def parameters_of(self, instance: str) -> dict[str, Any]:
        """The parameter values an instance is given (its own over the scene's effects)."""
        out: dict[str, Any] = {}
        for _, values in self.parameter_sources(instance):
            out.update(values)
        return out

    def check_wiring(self, variables: dict[str, dict[str, Any]]) -> list[tuple[str, Any, str, Any]]:
        """Check the scene against its FMUs' variables (instance -> {name: fmpy model variable}),
        with one line naming what does not fit: each input profile sets an input; each connection
        takes a Real output to a Real input of the same unit; each coupling and recorded quantity
        is a numeric variable; each parameter is a parameter (or an input). Returns the
        connections as (to instance, to variable, from instance, from variable)."""
        def var(inst: str, name: str):
            try:
                return variables[inst][name]
            except KeyError:
                raise SceneError(f"{inst}: FMU has no variable {shown(name)}") from None

        for ref in self.inputs:
            v = var(*ref.split(".", 1))
            if v.causality != "input":
                raise SceneError(f"inputs: {shown(ref)} is a {v.causality}, not an input (parameters go in "
                                 "[fmus.<instance>.parameters])")
        links = []
        for to, frm in self.connections.items():
            (ti, tv), (fi, fv) = to.split(".", 1), frm.split(".", 1)
            tvar, fvar = var(ti, tv), var(fi, fv)
            if tvar.causality != "input":
                raise SceneError(f"connections: {shown(to)} is a {tvar.causality}, not an input")
            if fvar.causality != "output":
                raise SceneError(f"connections: {shown(frm)} is a {fvar.causality}, not an output")
            if tvar.unit != fvar.unit:
                raise SceneError(f"connections: {shown(frm)} [{fvar.unit}] -> {shown(to)} [{tvar.unit}]: units differ")
            if tvar.type != "Real" or fvar.type != "Real":
                raise SceneError(f"connections: {shown(frm)} -> {shown(to)}: only Real variables can be connected")
            links.append((ti, tvar, fi, fvar))
        for ref in [c[k] for c in self.couplings for k in ("torque", "w_from", "w_to")] + list(self.record):
            inst, name = ref.split(".", 1)
            v = var(inst, name)
            if v.type not in ("Real", "Integer", "Boolean", "Enumeration"):
                raise SceneError(f"{inst}.{name} is a {v.type}: only numeric variables can be recorded")
        for spec in self.instances:
            for name in self.parameters_of(spec.name):
                v = var(spec.name, name)
                if v.causality not in ("parameter", "input"):
                    raise SceneError(f"{spec.name}.{name} is a {v.causality}, not a parameter")
        return links


def divides(where: str, step: float, duration: float) -> None:
    """Refuse a communication step that does not divide the duration (the run would end elsewhere)."""
    n = duration / step
    if not n < STEP_CAP:   # inf or more than any run could make (round(inf) would raise)
        raise SceneError(f"{where}: duration = {duration:g} s at step = {step:g} s is {n:.3g} communication steps "
                         f"(up to as many recorded samples); allowed: at most {MAX_STEPS:,} steps (--max-steps N "
                         "raises the limit)")
    if abs(n - round(n)) > 1e-9 * max(1.0, n) or round(n) < 1:
        k = max(1, math.ceil(n - 1e-9))
        raise SceneError(f"{where}: step = {step:g} s does not divide duration = {duration:g} s ({n:.4g} steps); "
                         f"allowed: a step that divides it, e.g. {duration / k:.6g} s")


def _split(where: str, ref: str, names: set[str]) -> tuple[str, str]:
    if not isinstance(ref, str) or "." not in ref:
        raise SceneError(f"{where}: {shown(ref)} is not of the form 'instance.variable'")
    inst, var = ref.split(".", 1)
    if inst not in names:
        raise SceneError(f"{where}: {shown(ref)} names unknown FMU instance {shown(inst)}; allowed: {', '.join(sorted(names))}")
    return inst, var


def _quantity(where: str, q, names: set[str]) -> list[str]:
    """Variables a quantity reads, after checking it: 'inst.var' or an expression over {inst.var}."""
    from harness.scene.expressions import compile_expression, is_expression

    if is_expression(q):
        refs = list(compile_expression(q, where).refs)
    else:
        refs = [_text(where, q)]
    out = []
    for r in refs:
        if r.startswith(theory.PREFIX):     # computed from the run's parameters (harness.scene.theory)
            out += theory.needed(theory.parse(where, r, names)[0])
            continue
        _split(where, r, names)
        out.append(r)
    return out


_INSTANCE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]{0,63}$")


def _gear_set(where: str, fmu: str, spec: dict) -> tuple[str | None, dict[str, Any]]:
    """An instance's ``gearSet`` and the SpurDifferential parameters that select it (None, {}
    without one); a gear set on another FMU or an unknown set's name is one line."""
    if "gearSet" not in spec:
        return None, {}
    from spurdiff.gears.design_sets import SETS, fmu_parameters
    name = _text(where, spec["gearSet"])
    if fmu != EFFECTS_FMU:
        raise SceneError(f"{where} = {shown(name)}: only a {EFFECTS_FMU} instance has a gear set")
    if name not in SETS:
        raise SceneError(f"{where} = {shown(name)}; allowed: {' | '.join(SETS)}")
    return name, fmu_parameters(name)


def parse_scene(data: dict, source: Path | None = None) -> Scene:
    where = str(source.name) if source else "scene"
    _table_of(where, data)
    _unknown(where, data, TOP_KEYS)
    for req in ("name", "duration", "step", "fmus"):
        if req not in data:
            raise SceneError(f"{where}: missing required key {shown(req)}")
    name = safe_name(f"{where}: name", data["name"])
    description = _text(f"{where}: description", data.get("description", ""))
    duration = _positive(f"{where}: duration", data["duration"])
    step = _positive(f"{where}: step", data["step"])
    if step > duration:
        raise SceneError(f"{where}: step = {step} s is longer than duration = {duration} s")
    divides(where, step, duration)
    out = _positive(f"{where}: output_interval", data.get("output_interval", step))
    algorithm = data.get("algorithm", "gauss-seidel")
    if not isinstance(algorithm, str) or algorithm not in ALGORITHMS:
        raise SceneError(f"{where}: algorithm = {shown(algorithm)}; allowed: {', '.join(sorted(ALGORITHMS))}")
    instances = []
    if not isinstance(data["fmus"], dict) or not data["fmus"]:
        raise SceneError(f"{where}: [fmus.<instance>] tables required")
    for iname, spec in data["fmus"].items():
        if not _INSTANCE.match(iname):
            raise SceneError(f"{where}: fmus.{shown(iname)}: allowed an instance name of letters, digits and _")
        _table_of(f"{where}: fmus.{iname}", spec)
        _unknown(f"{where}: fmus.{iname}", spec, FMU_KEYS)
        if "fmu" not in spec:
            raise SceneError(f"{where}: fmus.{iname}: missing key 'fmu'")
        fmu = _text(f"{where}: fmus.{iname}.fmu", spec["fmu"])
        params = _table_of(f"{where}: fmus.{iname}.parameters", spec.get("parameters", {}))
        gear_set, gear_params = _gear_set(f"{where}: fmus.{iname}.gearSet", fmu, spec)
        instances.append(FmuInstance(iname, fmu, dict(params), gear_set, gear_params))
    names = {i.name for i in instances}
    order = data.get("order")
    if order is not None:
        _strings(f"{where}: order", order)
        if sorted(order) != sorted(names):
            raise SceneError(f"{where}: order must list each instance once: {', '.join(sorted(names))}")
        instances.sort(key=lambda i: order.index(i.name))
    inputs = {}
    for ref, spec in _table_of(f"{where}: inputs", data.get("inputs", {})).items():
        _split(f"{where}: inputs", ref, names)
        inputs[ref] = parse_profile(f"{where}: inputs.{shown(ref)}", spec)
    connections = {}
    for to, frm in _table_of(f"{where}: connections", data.get("connections", {})).items():
        _split(f"{where}: connections", to, names)
        _split(f"{where}: connections.{shown(to)}", frm, names)
        if to in inputs:
            raise SceneError(f"{where}: {shown(to)} is both connected and given an input profile")
        connections[to] = frm
    couplings = []
    for c in _tables(f"{where}: couplings", data.get("couplings", [])):
        _unknown(f"{where}: couplings", c, COUPLING_KEYS)
        for k in ("name", "torque", "w_from", "w_to"):
            if k not in c:
                raise SceneError(f"{where}: couplings: missing key {shown(k)}")
            _text(f"{where}: couplings.{k}", c[k])
            if k != "name":
                _split(f"{where}: couplings.{k}", c[k], names)
        if "sign" in c:
            _number(f"{where}: couplings {shown(c['name'])}.sign", c["sign"])
        couplings.append(dict(c))
    raw = data.get("record", [])
    if isinstance(raw, list) and len(raw) > MAX_RECORD:
        raise SceneError(f"{where}: record has {len(raw):,} entries; allowed: at most {MAX_RECORD:,} (each a variable "
                         f"'instance.variable', recorded once)")
    record = list(dict.fromkeys(_strings(f"{where}: record", raw)))   # each once, in order
    for r in record:
        _split(f"{where}: record", r, names)
    needed: list[str] = []
    table = []
    for i, row in enumerate(_tables(f"{where}: table", data.get("table", []))):
        _unknown(f"{where}: table", row, TABLE_KEYS)
        at = f"{where}: table[{i}]"
        for k in ("label", "var"):
            if k not in row:
                raise SceneError(f"{at}: missing key {shown(k)}")
        _text(f"{at}.label", row["label"])
        at = f"{where}: table {shown(row['label'])}"
        needed += _quantity(f"{at}.var", row["var"], names)
        for k in ("scale", "paper", "paper_max", "paper_min"):
            if k in row:
                _number(f"{at}.{k}", row[k])
        if "unit" in row:
            _text(f"{at}.unit", row["unit"])
        if isinstance(row.get("theory"), str):
            needed += _quantity(f"{at}.theory", row["theory"], names)
        elif "theory" in row:
            _number(f"{at}.theory", row["theory"])
        if "window" in row:
            _window(f"{at}.window", row["window"])
        if "accuracy" in row and not isinstance(row["accuracy"], bool):
            raise SceneError(f"{at}.accuracy = {shown(row['accuracy'])}: allowed true or false")
        table.append(dict(row))
    checks = []
    for i, c in enumerate(_tables(f"{where}: checks", data.get("checks", []))):
        _unknown(f"{where}: checks", c, CHECK_KEYS)
        at = f"{where}: checks {shown(c['name'])}" if isinstance(c.get("name"), str) else f"{where}: checks[{i}]"
        if "name" in c:
            _text(f"{at}.name", c["name"])
        if not isinstance(c.get("stat"), str) or c["stat"] not in STATS:
            raise SceneError(f"{at}.stat = {shown(c.get('stat'))}; allowed: {', '.join(sorted(STATS))}")
        if "var" not in c:
            raise SceneError(f"{at}: missing key 'var'")
        needed += _quantity(f"{at}.var", c["var"], names)
        if "expect_var" in c:
            needed += _quantity(f"{at}.expect_var", c["expect_var"], names)
        for k in ("expect", "below", "above"):
            if k in c:
                _number(f"{at}.{k}", c[k])
        for k in ("rtol", "atol"):
            if k in c:
                _number(f"{at}.{k}", c[k], minimum=0.0)
        if not any(k in c for k in EXPECTATIONS):   # a check that cannot fail is no check
            raise SceneError(f"{at}: no expectation, so it cannot fail; allowed: one of {', '.join(EXPECTATIONS)}")
        if ("rtol" in c or "atol" in c) and not ("expect" in c or "expect_var" in c):
            raise SceneError(f"{at}: rtol/atol without expect or expect_var; allowed: a tolerance of an expectation")
        if "window" in c:
            _window(f"{at}.window", c["window"])
        if "fidelity" in c and not (isinstance(c["fidelity"], list) and c["fidelity"]
                                    and all(f in ("rigid", "compliant", "contact") for f in c["fidelity"])):
            raise SceneError(f"{at}.fidelity = {shown(c['fidelity'])}; allowed: a list of rigid, compliant, contact")
        checks.append(dict(c))
    record = list(dict.fromkeys(record + needed))
    effects = dict(_table_of(f"{where}: effects", data.get("effects", {})))
    fidelity = data.get("fidelity", {})
    if isinstance(fidelity, str):
        fidelity = {"mode": fidelity}
    _table_of(f"{where}: fidelity", fidelity)
    _unknown(f"{where}: fidelity", fidelity, FIDELITY_KEYS)
    if fidelity.get("mode", "fixed") not in ("fixed", "auto"):
        raise SceneError(f"{where}: fidelity mode = {shown(fidelity['mode'])}; allowed: fixed | auto")
    if fidelity.get("mode") == "auto":
        outs = fidelity.get("outputs")
        if not isinstance(outs, list) or not outs or not all(isinstance(o, str) for o in outs):
            raise SceneError(f"{where}: fidelity auto needs outputs = a non-empty list of quantities")
        for o in outs:
            _quantity(f"{where}: fidelity.outputs", o, names)
        tol = fidelity.get("tolerance", 0.01)
        if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not 0 < tol < 1e3:
            raise SceneError(f"{where}: fidelity tolerance = {shown(tol)}; allowed: a number > 0 (relative error)")
        fidelity.setdefault("data", data.get("extends", data["name"]))
        _text(f"{where}: fidelity.data", fidelity["data"])
    scene = Scene(name=name, description=description, duration=duration,
                  step=step, output_interval=out, algorithm=algorithm, instances=instances, inputs=inputs,
                  connections=connections, couplings=couplings, record=record, table=table, checks=checks,
                  effects=effects, fidelity=dict(fidelity), source=source)
    check_windows(where, scene)
    return scene


def check_windows(where: str, scene: Scene) -> None:
    """Refuse a check or table window outside the run, starting after its duration or ending before
    0: it holds no sample, so its check could only say nan. (A window the run ends inside is
    evaluated over the part run and says so: :func:`harness.run.report.evaluate_checks`.)"""
    for kind, rows, key in (("checks", scene.checks, "name"), ("table", scene.table, "label")):
        for i, row in enumerate(rows):
            w = row.get("window")
            if w is None:
                continue
            lo, hi = float(w[0]), float(w[1])
            if lo > scene.duration * (1 + 1e-9) or hi < 0:
                label = shown(row[key]) if key in row else f"[{i}]"
                raise SceneError(f"{where}: {kind} {label}.window = [{lo:g}, {hi:g}] s is outside the run; "
                                 f"allowed: a window within 0 .. {scene.duration:g} s (the duration)")


def scene_path(name_or_path: str, base: Path | None = None) -> Path:
    """The file of a scene name, or of a path to a .toml file (relative paths from ``base``, the
    folder of the scene that names it, else the working directory)."""
    if not isinstance(name_or_path, str) or not name_or_path or "\0" in name_or_path:
        raise SceneError(f"scene {shown(name_or_path)}: allowed a scene name or a path to a .toml file")
    p = Path(name_or_path)
    if p.suffix == ".toml":
        if base is not None and not p.is_absolute():
            p = base / p
        if p.is_file():
            return p
        raise SceneError(f"scene file {shown(str(p))} not found")
    if is_safe_name(name_or_path):
        # a name: a scene beside the one that names it, then the packaged scenes
        for folder in ([base] if base is not None else []) + [SCENE_DIR]:
            q = folder / f"{name_or_path}.toml"
            if q.is_file():
                return q
    raise SceneError(f"unknown scene {shown(name_or_path)}; available: {', '.join(available())} (or a .toml file)")


def merge(base: dict, over: dict) -> dict:
    """``over`` on top of ``base``: tables merge key by key, any other value replaces."""
    out = dict(base)
    for k, v in over.items():
        out[k] = merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


MAX_EXTENDS = 16


def within_run(data: dict) -> dict:
    """``data`` (scene TOML data whose ``duration`` a caller shortened) without the checks and table
    rows whose window lies beyond the run: they cannot be evaluated, and a scene read with them is
    refused. Rows without a window stay."""
    end = data.get("duration")
    if isinstance(end, (int, float)):
        for key in ("checks", "table"):
            rows = data.get(key)
            if isinstance(rows, list):
                data[key] = [r for r in rows if not (isinstance(r, dict) and isinstance(r.get("window"), list)
                                                     and len(r["window"]) == 2 and r["window"][1] > end)]
    return data


def read_scene_data(name_or_path: str, _seen: tuple[Path, ...] = (), _base: Path | None = None) -> dict:
    """The scene's TOML data with ``extends`` resolved (its parent's tables merged underneath).

    A parent given as a path is read relative to the folder of the scene that names it."""
    path = scene_path(name_or_path, _base)
    real = path.resolve()
    if real in _seen:
        chain = " -> ".join(p.name for p in _seen + (real,))
        raise SceneError(f"{_seen[-1].name}: extends makes a cycle: {chain}")
    if len(_seen) >= MAX_EXTENDS:
        raise SceneError(f"{path.name}: extends chain longer than {MAX_EXTENDS} scenes")
    data = read_toml(path)
    parent = data.get("extends")
    if parent is None:
        return data
    if not isinstance(parent, str):
        raise SceneError(f"{path.name}: extends = {shown(parent)}; allowed: a scene name or a path to a .toml file")
    base = read_scene_data(parent, _seen + (real,), path.parent)
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
