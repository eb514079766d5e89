"""Sweep files (``harness/sweeps/*.toml``): their schema, read with :mod:`tomllib` and checked with
the helpers scene files use (:mod:`harness.scene.schema`); unknown keys are rejected, naming the allowed
ones. What needs the scene or the FMUs is checked later, by :func:`harness.sweep.plan.plan_sweep`.
The keys are listed in :mod:`harness.sweep`."""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from harness.scene import schema
from harness.scene.expressions import compile_expression, is_expression
from harness.common.messages import shown
from harness.scene.schema import SceneError
from harness.scene.spec import STATS
from harness.sweep.jobs import Metric
from harness.sweep.theory import THEORIES

SWEEP_DIR = Path(__file__).resolve().parents[1] / "sweeps"

TOP_KEYS = {"name", "description", "scene", "duration", "step", "mesh", "algorithm", "fixed", "timeout",
            "sample", "parameters", "metrics", "plots"}
SAMPLE_KEYS = {"method", "n", "seed"}
PARAM_KEYS = {"name", "values", "range", "n", "scale", "integer"}
METRIC_KEYS = {"name", "var", "stat", "window", "expr", "theory", "instance"}
PLOT_KEYS = {"x", "y", "theory", "group", "title", "file"}
METHODS = ("grid", "list", "random", "lhs")
SCALES = ("linear", "log")
BASE_COLUMNS = ["run", "status", "reason", "wall_time_s", "worker"]
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


class SweepError(SceneError):
    """A sweep file or request that cannot run (bad key, value, parameter or results table)."""


# ------------------------------------------------------------------------------- the sweep file
@dataclass
class Param:
    name: str
    values: list | None = None
    range: tuple[float, float] | None = None
    n: int | None = None
    scale: str = "linear"
    integer: bool = False


@dataclass
class Plot:
    x: str
    y: list[str]
    theory: list[str] = field(default_factory=list)
    group: str | None = None
    title: str = ""
    file: str = ""


@dataclass
class Sweep:
    name: str
    description: str
    scene: str
    overrides: dict[str, Any]            # duration, step, mesh, algorithm
    fixed: dict[str, Any]
    timeout: float | None
    method: str
    n: int | None
    seed: int | None
    params: list[Param]
    metrics: list[Metric]
    plots: list[Plot]
    source: Path | None = None

    @property
    def columns(self) -> list[str]:
        return BASE_COLUMNS + [p.name for p in self.params] + [m.name for m in self.metrics]


def _unknown(where: str, keys, allowed) -> None:
    schema.unknown(where, keys, allowed, SweepError)


def _table(where: str, value) -> dict:
    return schema.table(where, value, SweepError)


def _tables(where: str, value) -> list[dict]:
    return schema.tables(where, value, SweepError)


def _number(where: str, value, positive: bool = False) -> float:
    return schema.positive(where, value, SweepError) if positive else schema.number(where, value, error=SweepError)


def _count(where: str, value) -> int:
    return schema.count(where, value, SweepError)


def _param_name(where: str, name) -> str:
    if not isinstance(name, str) or not re.match(r"^[A-Za-z_]\w*\.\S+$", name):
        raise SweepError(f"{where} = {shown(name)}: allowed 'instance.parameter'")
    return name


def _parse_param(where: str, spec: dict, method: str) -> Param:
    _unknown(where, spec, PARAM_KEYS)
    if "name" not in spec:
        raise SweepError(f"{where}: missing key 'name'")
    p = Param(_param_name(f"{where}.name", spec["name"]))
    where = f"{where} {shown(p.name)}"
    p.scale = spec.get("scale", "linear")
    if p.scale not in SCALES:
        raise SweepError(f"{where}: scale = {shown(p.scale)}; allowed: {', '.join(SCALES)}")
    p.integer = spec.get("integer", False)
    if not isinstance(p.integer, bool):
        raise SweepError(f"{where}: integer = {shown(p.integer)}; allowed: true, false")
    if "values" in spec and "range" in spec:
        raise SweepError(f"{where}: give either 'values' or 'range', not both")
    if "values" in spec:
        vals = spec["values"]
        if not isinstance(vals, list) or not vals:
            raise SweepError(f"{where}: values = {shown(vals)}; allowed: a non-empty list")
        p.values = [schema.scalar(f"{where}.values", v, SweepError) for v in vals]
        if "n" in spec:
            raise SweepError(f"{where}: 'n' goes with 'range', not with 'values'")
        if method in ("random", "lhs"):
            raise SweepError(f"{where}: method = {shown(method)} samples a 'range = [lo, hi]', not 'values'")
    elif "range" in spec:
        r = spec["range"]
        if not (isinstance(r, list) and len(r) == 2):
            raise SweepError(f"{where}: range = {shown(r)}; allowed: [lo, hi]")
        lo, hi = (_number(f"{where}.range", v) for v in r)
        if not lo < hi:
            raise SweepError(f"{where}: range = {shown(r)}; allowed: lo < hi")
        if p.scale == "log" and lo <= 0:
            raise SweepError(f"{where}: scale = 'log' needs range > 0, got {shown(r)}")
        p.range = (lo, hi)
        if method == "list":
            raise SweepError(f"{where}: method = 'list' takes 'values', not 'range'")
        if method == "grid":
            if "n" not in spec:
                raise SweepError(f"{where}: a grid over a range needs 'n' (number of points)")
            p.n = _count(f"{where}.n", spec["n"])
        elif "n" in spec:
            raise SweepError(f"{where}: 'n' of method = {shown(method)} goes in [sample], not in the parameter")
    else:
        raise SweepError(f"{where}: missing 'values' or 'range'")
    return p


def _parse_metric(where: str, spec: dict, earlier: list[str]) -> Metric:
    _unknown(where, spec, METRIC_KEYS)
    name = spec.get("name")
    if not isinstance(name, str) or not _NAME.match(name):
        raise SweepError(f"{where}: name = {shown(name)}; allowed: a name of letters, digits and _")
    where = f"{where} {shown(name)}"
    kinds = [k for k in ("var", "expr", "theory") if k in spec]
    if len(kinds) != 1:
        raise SweepError(f"{where}: give exactly one of 'var' (with 'stat'), 'expr' or 'theory'")
    kind = kinds[0]
    extra = sorted(set(spec) - {"name", kind} - ({"stat", "window"} if kind == "var" else set())
                   - ({"instance"} if kind == "theory" else set()))
    if extra:
        raise SweepError(f"{where}: key {shown(extra[0])} does not go with {shown(kind)}")
    if kind == "var":
        if not isinstance(spec["var"], str):
            raise SweepError(f"{where}: var = {shown(spec['var'])}; allowed: 'inst.var' or an expression over {{inst.var}}")
        if is_expression(spec["var"]):
            try:
                compile_expression(spec["var"], f"{where}.var")
            except SceneError as e:
                raise SweepError(str(e)) from None
        st = spec.get("stat", "mean")
        if not isinstance(st, str) or st not in STATS:
            raise SweepError(f"{where}: stat = {shown(st)}; allowed: {', '.join(sorted(STATS))}")
        window = spec.get("window")
        if window is not None:
            schema.window(f"{where}.window", window, SweepError, start_at_zero=True)
            window = (float(window[0]), float(window[1]))
        return Metric(name, "stat", var=spec["var"], stat=st, window=window)
    if kind == "expr":
        if not isinstance(spec["expr"], str):
            raise SweepError(f"{where}: expr = {shown(spec['expr'])}; allowed: a string")
        try:
            compile_expression(spec["expr"], f"{where}.expr", earlier)
        except SceneError as e:
            raise SweepError(str(e)) from None
        return Metric(name, "expr", expr=spec["expr"])
    if not isinstance(spec["theory"], str) or spec["theory"] not in THEORIES:
        raise SweepError(f"{where}: theory = {shown(spec['theory'])}; allowed: {', '.join(sorted(THEORIES))}")
    inst = spec.get("instance", "")
    if not isinstance(inst, str):
        raise SweepError(f"{where}: instance = {shown(inst)}; allowed: an FMU instance name")
    return Metric(name, "theory", theory=spec["theory"], instance=inst)


def _parse_plot(where: str, spec: dict, params: list[str], columns: list[str]) -> Plot:
    _unknown(where, spec, PLOT_KEYS)
    for k in ("x", "y"):
        if k not in spec:
            raise SweepError(f"{where}: missing key {shown(k)}")
    as_list = lambda v: [v] if isinstance(v, str) else v  # noqa: E731
    y, th = as_list(spec["y"]), as_list(spec.get("theory", []))
    for key, names, allowed in (("x", [spec["x"]], params), ("group", [spec["group"]] if "group" in spec else [], params),
                                ("y", y, columns), ("theory", th, columns)):
        if not isinstance(names, list):
            raise SweepError(f"{where}.{key} = {shown(names)}; allowed: a name or a list of names")
        for n in names:
            if n not in allowed:
                raise SweepError(f"{where}.{key} = {shown(n)}; allowed: {', '.join(allowed)}")
    title, file = spec.get("title", ""), spec.get("file", "")
    if not isinstance(title, str):
        raise SweepError(f"{where}.title = {shown(title)}; allowed: a string")
    if file:
        schema.safe_name(f"{where}.file", file, SweepError)
    return Plot(spec["x"], y, th, spec.get("group"), title, file)


def parse_sweep(data: dict, source: Path | None = None) -> Sweep:
    """Validate a sweep file's data (what does not need the scene or the FMUs)."""
    where = source.name if source else "sweep"
    _unknown(where, data, TOP_KEYS)
    if "scene" not in data or not isinstance(data["scene"], str):
        raise SweepError(f"{where}: missing key 'scene' (a scene name or .toml path)")
    name = schema.safe_name(f"{where}: name", data.get("name", source.stem if source else "sweep"), SweepError)
    overrides = {}
    for k in ("duration", "step"):
        if k in data:
            overrides[k] = _number(f"{where}: {k}", data[k], positive=True)
    for k in ("mesh", "algorithm"):
        if k in data:
            if not isinstance(data[k], str):
                raise SweepError(f"{where}: {k} = {shown(data[k])}; allowed: a string")
            overrides[k] = data[k]
    fixed = {}
    for k, v in _table(f"{where}: fixed", data.get("fixed", {})).items():
        fixed[_param_name(f"{where}: fixed", k)] = schema.scalar(f"{where}: fixed.{k}", v, SweepError)
    timeout = data.get("timeout")
    if timeout is not None:
        timeout = _number(f"{where}: timeout", timeout, positive=True)
    sample = _table(f"{where}: sample", data.get("sample", {}))
    _unknown(f"{where}: sample", sample, SAMPLE_KEYS)
    method = sample.get("method", "grid")
    if method not in METHODS:
        raise SweepError(f"{where}: sample.method = {shown(method)}; allowed: {', '.join(METHODS)}")
    n = seed = None
    if method in ("random", "lhs"):
        for k in ("n", "seed"):
            if k not in sample:
                raise SweepError(f"{where}: sample.{k} is required for method = {shown(method)} (reproducible samples)")
        n = _count(f"{where}: sample.n", sample["n"])
        seed = sample["seed"]
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise SweepError(f"{where}: sample.seed = {shown(seed)}; allowed: an integer >= 0")
    else:
        extra = sorted(set(sample) & {"n", "seed"})
        if extra:
            raise SweepError(f"{where}: sample.{extra[0]} does not go with method = {shown(method)}; "
                             f"allowed with it: method")
    params = [_parse_param(f"{where}: parameters", p, method) for p in _tables(f"{where}: parameters",
                                                                                 data.get("parameters", []))]
    if not params:
        raise SweepError(f"{where}: [[parameters]] required (at least one parameter to vary)")
    pnames = [p.name for p in params]
    dup = sorted({x for x in pnames if pnames.count(x) > 1})
    if dup:
        raise SweepError(f"{where}: parameter {shown(dup[0])} is given twice")
    if method == "list":
        lengths = {p.name: len(p.values) for p in params}
        if len(set(lengths.values())) > 1:
            raise SweepError(f"{where}: method = 'list' needs equally long value lists, got "
                             + ", ".join(f"{k}: {v}" for k, v in lengths.items()))
    metrics: list[Metric] = []
    for spec in _tables(f"{where}: metrics", data.get("metrics", [])):
        m = _parse_metric(f"{where}: metrics", spec, pnames + [x.name for x in metrics])
        if m.name in [x.name for x in metrics] or m.name in BASE_COLUMNS:
            raise SweepError(f"{where}: metric name {shown(m.name)} is used twice or is a standard column "
                             f"({', '.join(BASE_COLUMNS)})")
        metrics.append(m)
    if not metrics:
        raise SweepError(f"{where}: [[metrics]] required (at least one)")
    mnames = [m.name for m in metrics]
    plots = [_parse_plot(f"{where}: plots", p, pnames, mnames) for p in _tables(f"{where}: plots", data.get("plots", []))]
    return Sweep(name=name, description=str(data.get("description", "")), scene=data["scene"], overrides=overrides,
                 fixed=fixed, timeout=timeout, method=method, n=n, seed=seed, params=params, metrics=metrics,
                 plots=plots, source=source)


def sweep_path(name_or_path: str) -> Path:
    p = Path(name_or_path)
    if p.suffix == ".toml" and p.is_file():
        return p
    q = SWEEP_DIR / f"{name_or_path}.toml"
    if q.is_file():
        return q
    raise SweepError(f"unknown sweep {shown(name_or_path)}; allowed: a .toml file or one of {', '.join(available())}")


def load_sweep(name_or_path: str) -> Sweep:
    path = sweep_path(name_or_path)
    return parse_sweep(schema.read_toml(path, SweepError), path)


def available() -> list[str]:
    return sorted(p.stem for p in SWEEP_DIR.glob("*.toml"))


