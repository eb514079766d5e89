"""Parameter sweeps over a scene: one command from a laptop to a Dask cluster, nothing lost.

A sweep file (``harness/sweeps/*.toml``, read with :mod:`tomllib`; unknown keys are rejected)
names a scene, the parameters to vary and the metrics to collect::

    name, description          text (name defaults to the file name)
    scene                      a scene name (``spurdiff scenes``) or a path to a scene file
    duration, step, mesh, algorithm   scene overrides, as for ``spurdiff run``
    fixed                      {"inst.param" = value}: set in every run
    timeout                    s of wall time per run (checked between steps); default none
    [sample]                   method = "grid" (default) | "list" | "random" | "lhs"; n, seed (random, lhs)
    [[parameters]]             name = "inst.param"; values = [...] (grid, list) or range = [lo, hi]
                               (grid with n; random, lhs); scale = "linear" | "log"; integer = true
    [[metrics]]                name plus one of:
                                 var = quantity, stat = mean|max|min|final|absmax|span, window = [t0, t1]
                                 expr = arithmetic over earlier columns, e.g. "{a} / abs({b})"
                                 theory = "locking_coefficient" | "torque_bias_ratio" (instance = "diff")
    [[plots]]                  x, y = [...], theory = [...] (dashed), group, title, file

Runs go to a Dask cluster: by default a local one of worker processes (pythonfmu FMUs run in
their host's interpreter, so parallelism comes from processes), ``scheduler`` = an existing
cluster, ``workers = 0`` = in this process. Every finished run is appended to one CSV table at
once (a row per run: run, status, reason, wall_time_s, worker, parameters, metrics); a failed run
is a row with its reason; ``resume`` reruns only the runs missing from the table.
"""
from __future__ import annotations

import argparse
import csv
import hashlib
import itertools
import logging
import math
import os
import re
import socket
import sys
import time
import tomllib
import uuid
from dataclasses import dataclass, field, replace
from pathlib import Path

from harness.paths import results_dir
from typing import Any, Callable, Iterable, Iterator

from harness.expressions import compile_expression, is_expression
from harness.scene import STATS, SceneError, parameter_value, refs_of, safe_name
from harness.sweep_worker import STATUSES, THEORIES, FmuRef, Job, Metric, Task, compile_expr, evaluate_metrics, \
    run_one, scene_for, snapshot

SWEEP_DIR = Path(__file__).resolve().parent / "sweeps"

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
    bad = sorted(set(keys) - set(allowed))
    if bad:
        raise SweepError(f"{where}: unknown key{'s' if len(bad) > 1 else ''} {', '.join(map(repr, bad))}; "
                         f"allowed: {', '.join(sorted(allowed))}")


def _table(where: str, value) -> dict:
    if not isinstance(value, dict):
        raise SweepError(f"{where}: allowed a table {{key = value, ...}}, got {value!r}")
    return value


def _tables(where: str, value) -> list[dict]:
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise SweepError(f"{where}: allowed an array of tables [[{where.rsplit(' ', 1)[-1]}]]")
    return value


def _number(where: str, value, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SweepError(f"{where} = {value!r}: allowed a finite number")
    if positive and value <= 0:
        raise SweepError(f"{where} = {value!r}: allowed a number > 0")
    return float(value)


def _count(where: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise SweepError(f"{where} = {value!r}: allowed an integer >= 1")
    return value


def _param_name(where: str, name) -> str:
    if not isinstance(name, str) or not re.match(r"^[A-Za-z_]\w*\.\S+$", name):
        raise SweepError(f"{where} = {name!r}: allowed 'instance.parameter'")
    return name


def _scalar(where: str, v):
    if isinstance(v, (bool, int, str)) or (isinstance(v, float) and math.isfinite(v)):
        return v
    raise SweepError(f"{where}: {v!r} is not allowed; allowed: a finite number, a string or a boolean")


def _parse_param(where: str, spec: dict, method: str) -> Param:
    _unknown(where, spec, PARAM_KEYS)
    if "name" not in spec:
        raise SweepError(f"{where}: missing key 'name'")
    p = Param(_param_name(f"{where}.name", spec["name"]))
    where = f"{where} {p.name!r}"
    p.scale = spec.get("scale", "linear")
    if p.scale not in SCALES:
        raise SweepError(f"{where}: scale = {p.scale!r}; allowed: {', '.join(SCALES)}")
    p.integer = spec.get("integer", False)
    if not isinstance(p.integer, bool):
        raise SweepError(f"{where}: integer = {p.integer!r}; allowed: true, false")
    if "values" in spec and "range" in spec:
        raise SweepError(f"{where}: give either 'values' or 'range', not both")
    if "values" in spec:
        vals = spec["values"]
        if not isinstance(vals, list) or not vals:
            raise SweepError(f"{where}: values = {vals!r}; allowed: a non-empty list")
        p.values = [_scalar(f"{where}.values", v) for v in vals]
        if "n" in spec:
            raise SweepError(f"{where}: 'n' goes with 'range', not with 'values'")
        if method in ("random", "lhs"):
            raise SweepError(f"{where}: method = {method!r} samples a 'range = [lo, hi]', not 'values'")
    elif "range" in spec:
        r = spec["range"]
        if not (isinstance(r, list) and len(r) == 2):
            raise SweepError(f"{where}: range = {r!r}; allowed: [lo, hi]")
        lo, hi = (_number(f"{where}.range", v) for v in r)
        if not lo < hi:
            raise SweepError(f"{where}: range = {r!r}; allowed: lo < hi")
        if p.scale == "log" and lo <= 0:
            raise SweepError(f"{where}: scale = 'log' needs range > 0, got {r!r}")
        p.range = (lo, hi)
        if method == "list":
            raise SweepError(f"{where}: method = 'list' takes 'values', not 'range'")
        if method == "grid":
            if "n" not in spec:
                raise SweepError(f"{where}: a grid over a range needs 'n' (number of points)")
            p.n = _count(f"{where}.n", spec["n"])
        elif "n" in spec:
            raise SweepError(f"{where}: 'n' of method = {method!r} goes in [sample], not in the parameter")
    else:
        raise SweepError(f"{where}: missing 'values' or 'range'")
    return p


def _parse_metric(where: str, spec: dict, earlier: list[str]) -> Metric:
    _unknown(where, spec, METRIC_KEYS)
    name = spec.get("name")
    if not isinstance(name, str) or not _NAME.match(name):
        raise SweepError(f"{where}: name = {name!r}; allowed: a name of letters, digits and _")
    where = f"{where} {name!r}"
    kinds = [k for k in ("var", "expr", "theory") if k in spec]
    if len(kinds) != 1:
        raise SweepError(f"{where}: give exactly one of 'var' (with 'stat'), 'expr' or 'theory'")
    kind = kinds[0]
    extra = sorted(set(spec) - {"name", kind} - ({"stat", "window"} if kind == "var" else set())
                   - ({"instance"} if kind == "theory" else set()))
    if extra:
        raise SweepError(f"{where}: key {extra[0]!r} does not go with {kind!r}")
    if kind == "var":
        if not isinstance(spec["var"], str):
            raise SweepError(f"{where}: var = {spec['var']!r}; allowed: 'inst.var' or an expression over {{inst.var}}")
        if is_expression(spec["var"]):
            try:
                compile_expression(spec["var"], f"{where}.var")
            except SceneError as e:
                raise SweepError(str(e)) from None
        st = spec.get("stat", "mean")
        if st not in STATS:
            raise SweepError(f"{where}: stat = {st!r}; allowed: {', '.join(sorted(STATS))}")
        window = spec.get("window")
        if window is not None:
            if not (isinstance(window, list) and len(window) == 2):
                raise SweepError(f"{where}: window = {window!r}; allowed: [t0, t1] in s")
            lo, hi = (_number(f"{where}.window", v) for v in window)
            if not 0 <= lo < hi:
                raise SweepError(f"{where}: window = {window!r}; allowed: 0 <= t0 < t1")
            window = (lo, hi)
        return Metric(name, "stat", var=spec["var"], stat=st, window=window)
    if kind == "expr":
        if not isinstance(spec["expr"], str):
            raise SweepError(f"{where}: expr = {spec['expr']!r}; allowed: a string")
        try:
            compile_expr(spec["expr"], earlier, f"{where}.expr")
        except SceneError as e:
            raise SweepError(str(e)) from None
        return Metric(name, "expr", expr=spec["expr"])
    if spec["theory"] not in THEORIES:
        raise SweepError(f"{where}: theory = {spec['theory']!r}; allowed: {', '.join(sorted(THEORIES))}")
    inst = spec.get("instance", "")
    if not isinstance(inst, str):
        raise SweepError(f"{where}: instance = {inst!r}; allowed: an FMU instance name")
    return Metric(name, "theory", theory=spec["theory"], instance=inst)


def _parse_plot(where: str, spec: dict, params: list[str], columns: list[str]) -> Plot:
    _unknown(where, spec, PLOT_KEYS)
    for k in ("x", "y"):
        if k not in spec:
            raise SweepError(f"{where}: missing key {k!r}")
    as_list = lambda v: [v] if isinstance(v, str) else v  # noqa: E731
    y, th = as_list(spec["y"]), as_list(spec.get("theory", []))
    for key, names, allowed in (("x", [spec["x"]], params), ("group", [spec["group"]] if "group" in spec else [], params),
                                ("y", y, columns), ("theory", th, columns)):
        if not isinstance(names, list):
            raise SweepError(f"{where}.{key} = {names!r}; allowed: a name or a list of names")
        for n in names:
            if n not in allowed:
                raise SweepError(f"{where}.{key} = {n!r}; allowed: {', '.join(allowed)}")
    title, file = spec.get("title", ""), spec.get("file", "")
    if not isinstance(title, str):
        raise SweepError(f"{where}.title = {title!r}; allowed: a string")
    if file:
        try:
            safe_name(f"{where}.file", file)
        except SceneError as e:
            raise SweepError(str(e)) from None
    return Plot(spec["x"], y, th, spec.get("group"), title, file)


def parse_sweep(data: dict, source: Path | None = None) -> Sweep:
    """Validate a sweep file's data (what does not need the scene or the FMUs)."""
    where = source.name if source else "sweep"
    _unknown(where, data, TOP_KEYS)
    if "scene" not in data or not isinstance(data["scene"], str):
        raise SweepError(f"{where}: missing key 'scene' (a scene name or .toml path)")
    name = data.get("name", source.stem if source else "sweep")
    try:
        safe_name(f"{where}: name", name)
    except SceneError as e:
        raise SweepError(str(e)) from None
    overrides = {}
    for k in ("duration", "step"):
        if k in data:
            overrides[k] = _number(f"{where}: {k}", data[k], positive=True)
    for k in ("mesh", "algorithm"):
        if k in data:
            if not isinstance(data[k], str):
                raise SweepError(f"{where}: {k} = {data[k]!r}; allowed: a string")
            overrides[k] = data[k]
    fixed = {}
    for k, v in _table(f"{where}: fixed", data.get("fixed", {})).items():
        fixed[_param_name(f"{where}: fixed", k)] = _scalar(f"{where}: fixed.{k}", v)
    timeout = data.get("timeout")
    if timeout is not None:
        timeout = _number(f"{where}: timeout", timeout, positive=True)
    sample = _table(f"{where}: sample", data.get("sample", {}))
    _unknown(f"{where}: sample", sample, SAMPLE_KEYS)
    method = sample.get("method", "grid")
    if method not in METHODS:
        raise SweepError(f"{where}: sample.method = {method!r}; allowed: {', '.join(METHODS)}")
    n = seed = None
    if method in ("random", "lhs"):
        for k in ("n", "seed"):
            if k not in sample:
                raise SweepError(f"{where}: sample.{k} is required for method = {method!r} (reproducible samples)")
        n = _count(f"{where}: sample.n", sample["n"])
        seed = sample["seed"]
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise SweepError(f"{where}: sample.seed = {seed!r}; allowed: an integer >= 0")
    else:
        extra = sorted(set(sample) & {"n", "seed"})
        if extra:
            raise SweepError(f"{where}: sample.{extra[0]} does not go with method = {method!r}; "
                             f"allowed with it: method")
    params = [_parse_param(f"{where}: parameters", p, method) for p in _tables(f"{where}: parameters",
                                                                                 data.get("parameters", []))]
    if not params:
        raise SweepError(f"{where}: [[parameters]] required (at least one parameter to vary)")
    pnames = [p.name for p in params]
    dup = sorted({x for x in pnames if pnames.count(x) > 1})
    if dup:
        raise SweepError(f"{where}: parameter {dup[0]!r} is given twice")
    if method == "list":
        lengths = {p.name: len(p.values) for p in params}
        if len(set(lengths.values())) > 1:
            raise SweepError(f"{where}: method = 'list' needs equally long value lists, got "
                             + ", ".join(f"{k}: {v}" for k, v in lengths.items()))
    metrics: list[Metric] = []
    for spec in _tables(f"{where}: metrics", data.get("metrics", [])):
        m = _parse_metric(f"{where}: metrics", spec, pnames + [x.name for x in metrics])
        if m.name in [x.name for x in metrics] or m.name in BASE_COLUMNS:
            raise SweepError(f"{where}: metric name {m.name!r} is used twice or is a standard column "
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
    raise SweepError(f"unknown sweep {name_or_path!r}; allowed: a .toml file or one of {', '.join(available())}")


def load_sweep(name_or_path: str) -> Sweep:
    path = sweep_path(name_or_path)
    try:
        data = tomllib.loads(path.read_bytes().decode("utf-8"))
    except UnicodeDecodeError as e:
        raise SweepError(f"{path.name}: not UTF-8 text (byte {e.start}); allowed: a UTF-8 TOML file") from None
    except tomllib.TOMLDecodeError as e:
        raise SweepError(f"{path.name}: not valid TOML: {e}") from None
    return parse_sweep(data, path)


def available() -> list[str]:
    return sorted(p.stem for p in SWEEP_DIR.glob("*.toml"))


# -------------------------------------------------------------------------------------- samples
def _axis(p: Param) -> list:
    import numpy as np

    if p.values is not None:
        return list(p.values)
    lo, hi = p.range
    pts = np.geomspace(lo, hi, p.n) if p.scale == "log" else np.linspace(lo, hi, p.n)
    return [_cast(p, x) for x in pts]


def _cast(p: Param, x) -> Any:
    return int(round(float(x))) if p.integer else float(x)


def unit_samples(method: str, n: int, d: int, seed: int):
    """(n, d) points in [0, 1): independent uniform ("random") or Latin hypercube ("lhs")."""
    import numpy as np

    if method == "random":
        return np.random.default_rng(seed).random((n, d))
    from scipy.stats import qmc
    try:
        engine = qmc.LatinHypercube(d, rng=seed)
    except TypeError:  # scipy < 1.15
        engine = qmc.LatinHypercube(d, seed=seed)
    return engine.random(n)


def expand(sweep: Sweep) -> list[Task]:
    """The sweep's runs, numbered from 0, each with its parameter values."""
    names = [p.name for p in sweep.params]
    if sweep.method == "grid":
        rows = list(itertools.product(*(_axis(p) for p in sweep.params)))
    elif sweep.method == "list":
        rows = list(zip(*(p.values for p in sweep.params)))
    else:
        u = unit_samples(sweep.method, sweep.n, len(sweep.params), sweep.seed)
        rows = []
        for k in range(sweep.n):
            row = []
            for j, p in enumerate(sweep.params):
                lo, hi = p.range
                if p.scale == "log":
                    x = math.exp(math.log(lo) + u[k, j] * (math.log(hi) - math.log(lo)))
                else:
                    x = lo + u[k, j] * (hi - lo)
                row.append(_cast(p, x))
            rows.append(row)
    return [Task(i, dict(zip(names, r))) for i, r in enumerate(rows)]


# --------------------------------------------------------------------- plan: scene, FMUs, checks
@dataclass
class Plan:
    sweep: Sweep
    job: Job
    tasks: list[Task]
    fmu_files: dict[str, Path]


def _complete_fmu(data: bytes) -> bool:
    import io
    import zipfile

    try:
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            return "modelDescription.xml" in z.namelist() and z.testzip() is None
    except zipfile.BadZipFile:
        return False


def _fmu_ref(name: str, path: Path, wait: float = 20.0) -> FmuRef:
    """The FMU as it is now, copied to a snapshot named by its digest (see sweep_worker.snapshot).

    A file another process is still writing (a build is not atomic) is read again until complete."""
    t_end = time.monotonic() + wait
    while True:
        data = Path(path).read_bytes()
        if _complete_fmu(data):
            break
        if time.monotonic() > t_end:
            raise SweepError(f"{path}: not a complete FMU (a zip with modelDescription.xml) after {wait:g} s; "
                             "is a build writing it? rebuild with `spurdiff build --force`")
        time.sleep(0.5)
    digest = hashlib.sha256(data).hexdigest()
    return FmuRef(name, digest, str(snapshot(name, data, digest)))


def plan_sweep(sweep: Sweep, duration: float | None = None, timeout: float | None = None,
               build: bool = True) -> Plan:
    """Load the scene with the sweep's overrides, build the FMUs, check every name against them."""
    from fmpy import read_model_description

    from harness.runner import fmu_files_for, prepare_scene

    where = sweep.source.name if sweep.source else sweep.name
    ov = dict(sweep.overrides)
    if duration is not None:
        ov["duration"] = duration
    scene = prepare_scene(sweep.scene, mesh=ov.get("mesh"), step=ov.get("step"), duration=ov.get("duration"),
                          algorithm=ov.get("algorithm"))
    refs = {n: _fmu_ref(n, p) for n, p in fmu_files_for(scene, build_missing=build).items()}
    files = {n: Path(r.path) for n, r in refs.items()}
    variables = {}
    for spec in scene.instances:
        if spec.fmu not in variables:
            md = read_model_description(str(files[spec.fmu]))
            variables[spec.fmu] = {v.name: v for v in md.modelVariables}
    insts = {i.name: i for i in scene.instances}

    def parameter(label: str, key: str) -> None:
        inst, param = key.split(".", 1)
        if inst not in insts:
            raise SweepError(f"{where}: {label} {key!r}: scene {scene.name} has no instance {inst!r}; "
                             f"allowed: {', '.join(insts)}")
        vs = variables[insts[inst].fmu]
        if param not in vs or vs[param].causality != "parameter":
            allowed = sorted(n for n, v in vs.items() if v.causality == "parameter")
            raise SweepError(f"{where}: {label} {key!r}: {insts[inst].fmu} has no parameter {param!r}; "
                             f"allowed: {', '.join(allowed)}")
        return vs[param].type

    def typed(label: str, type_: str, value):
        try:
            return parameter_value(f"{where}: {label}", type_, value)
        except SceneError as e:
            raise SweepError(str(e)) from None

    for key, value in sweep.fixed.items():
        t = parameter("fixed", key)
        inst, param = key.split(".", 1)
        scene.instance(inst).parameters[param] = typed(f"fixed.{key}", t, value)
    params = []
    for p in sweep.params:
        t = parameter("parameters", p.name)
        if p.values is not None:
            p = replace(p, values=[typed(f"parameters {p.name!r}.values", t, v) for v in p.values])
        elif t in ("Boolean", "String") or (t in ("Integer", "Enumeration") and not p.integer):
            raise SweepError(f"{where}: parameters {p.name!r}: range = {list(p.range)} for a {t} parameter; allowed: "
                             + ("values = [...]" if t in ("Boolean", "String") else "integer = true with the range"))
        else:
            for x in p.range:
                typed(f"parameters {p.name!r}.range", t, int(round(x)) if p.integer else x)
        params.append(p)
    sweep = replace(sweep, params=params)
    metrics = []
    for m in sweep.metrics:
        if m.kind == "stat":
            for ref in refs_of(m.var):
                inst, _, var = ref.partition(".")
                if inst not in insts or var not in variables[insts[inst].fmu]:
                    raise SweepError(f"{where}: metrics {m.name!r}: {ref!r} is not a variable of the scene; "
                                     f"allowed: 'instance.variable' with instance one of {', '.join(insts)}")
                if variables[insts[inst].fmu][var].type not in ("Real", "Integer", "Boolean", "Enumeration"):
                    raise SweepError(f"{where}: metrics {m.name!r}: {ref!r} is a {variables[insts[inst].fmu][var].type}; "
                                     "allowed: numeric variables (Real, Integer, Boolean, Enumeration)")
                if ref not in scene.record:
                    scene.record.append(ref)
            if m.window and m.window[1] > scene.duration * (1 + 1e-9):
                raise SweepError(f"{where}: metrics {m.name!r}: window {list(m.window)} ends after the scene's "
                                 f"duration {scene.duration:g} s")
        elif m.kind == "theory":
            fmu = THEORIES[m.theory][1]
            fits = [i for i in scene.instances if i.fmu == fmu]
            if m.instance:
                if m.instance not in insts or insts[m.instance].fmu != fmu:
                    raise SweepError(f"{where}: metrics {m.name!r}: instance = {m.instance!r}; allowed: "
                                     f"{', '.join(i.name for i in fits) or 'none (no ' + fmu + ' in the scene)'}")
            elif len(fits) != 1:
                raise SweepError(f"{where}: metrics {m.name!r}: give instance = one of "
                                 f"{', '.join(i.name for i in fits) or 'none (no ' + fmu + ' in the scene)'}")
            else:
                m = replace(m, instance=fits[0].name)
        metrics.append(m)
    job = Job(scene=scene, fmus=refs, metrics=metrics,
              timeout=timeout if timeout is not None else sweep.timeout)
    return Plan(sweep, job, expand(sweep), files)


# ------------------------------------------------------------------------------ results table
def fmt(v) -> str:
    """A cell: exact round trip for floats (repr), TOML-like booleans."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float) or type(v).__name__.startswith("float"):
        return repr(float(v))
    return str(v)


def table_path(sweep: Sweep, out_dir: Path | None) -> Path:
    return Path(out_dir if out_dir else results_dir("sweeps", sweep.name)) / f"{sweep.name}.csv"


def read_table(path: Path) -> tuple[list[str], dict[int, dict[str, str]]]:
    """Header and rows by run (last row of a run wins); a torn last line or a malformed row is dropped."""
    text = Path(path).read_text()
    if not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]  # the last line was being written when the sweep died
    records = list(csv.reader(text.splitlines(keepends=True)))
    if not records:
        return [], {}
    header, rows = records[0], {}
    for rec in records[1:]:
        if len(rec) != len(header):
            continue
        row = dict(zip(header, rec))
        try:
            run = int(row["run"])
        except (KeyError, ValueError):
            continue
        if row.get("status") in STATUSES:
            rows[run] = row
    return header, rows


def write_table(path: Path, columns: list[str], rows: Iterable[dict]) -> None:
    """Write a whole table atomically (temporary file, then rename)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(columns)
        for row in rows:
            w.writerow([fmt(row.get(c, "")) for c in columns])
    os.replace(tmp, path)


class TableWriter:
    """Appends one row per finished run and flushes it, so a killed sweep keeps every finished run."""

    def __init__(self, path: Path, columns: list[str]):
        self.columns = columns
        self.fh = open(path, "a", newline="")
        self.w = csv.writer(self.fh)

    def append(self, row: dict) -> None:
        self.w.writerow([fmt(row.get(c, "")) for c in self.columns])
        self.fh.flush()

    def close(self) -> None:
        self.fh.close()


class FolderLock:
    """An exclusive lock on a sweep's results folder (``fcntl.flock`` on a hidden file in it): a
    second sweep writing the same folder is refused, told who holds it. The kernel drops the lock
    when its holder exits, however it exits, so a killed sweep leaves no stale lock behind."""

    NAME = ".spurdiff-sweep.lock"

    def __init__(self, folder: Path, what: str):
        self.path = Path(folder) / self.NAME
        self.what = what
        self.fd: int | None = None

    def acquire(self) -> "FolderLock":
        import fcntl

        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as e:
            raise SweepError(f"results folder {self.path.parent}: cannot write there: {e.strerror}") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = os.pread(fd, 500, 0).decode("utf-8", "replace").strip() or "another process"
            os.close(fd)
            raise SweepError(f"results folder {self.path.parent} is in use by {holder}; wait for it to finish "
                             "or give another --out") from None
        os.ftruncate(fd, 0)
        stamp = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime())
        os.pwrite(fd, f"sweep {self.what} (pid {os.getpid()} on {socket.gethostname()}, since {stamp})\n".encode(), 0)
        self.fd = fd
        return self

    def release(self) -> None:
        import fcntl

        if self.fd is not None:
            os.ftruncate(self.fd, 0)
            fcntl.flock(self.fd, fcntl.LOCK_UN)
            os.close(self.fd)
            self.fd = None

    def __enter__(self) -> "FolderLock":
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


# ------------------------------------------------------------------------------------ progress
class ProgressBar:
    """One line on stderr: runs done of total, failures, elapsed and estimated time left."""

    def __init__(self, total: int, done: int = 0, failed: int = 0, stream=None, enabled: bool = True):
        self.total, self.done, self.failed = total, done, failed
        self.start_done = done
        self.stream = stream or sys.stderr
        self.enabled = enabled and total > 0
        self.tty = getattr(self.stream, "isatty", lambda: False)()
        self.t0 = time.perf_counter()
        self._last_decile = -1

    def update(self, row: dict) -> None:
        self.done += 1
        self.failed += row["status"] != "ok"
        if not self.enabled:
            return
        decile = int(10 * self.done / self.total)
        if self.tty or decile != self._last_decile or self.done == self.total:
            self._last_decile = decile
            self.stream.write(("\r" if self.tty else "") + self.line() + ("" if self.tty else "\n"))
            if self.tty and self.done == self.total:
                self.stream.write("\n")
            self.stream.flush()

    def line(self) -> str:
        el = time.perf_counter() - self.t0
        ran = self.done - self.start_done
        left = (self.total - self.done) * el / ran if ran else float("nan")
        frac = self.done / self.total
        n = int(30 * frac)
        return (f"sweep [{'#' * n}{'.' * (30 - n)}] {self.done}/{self.total} runs, {self.failed} failed, "
                f"{el:6.1f} s, ~{left:5.1f} s left")


# ---------------------------------------------------------------------------------- executors
Runner = Callable[[Task, Job], dict]


def serial_rows(job: Job, tasks: list[Task], runner: Runner) -> Iterator[dict]:
    """Runs in this process, one after the other. Ctrl-C stops the running run at its next step
    (:func:`harness.master.stop_on_sigint`): it gives no row, and KeyboardInterrupt ends the sweep."""
    from harness.master import STOP, stop_on_sigint

    with stop_on_sigint():
        for t in tasks:
            if STOP.is_set():
                raise KeyboardInterrupt
            row = runner(t, job)
            yield row


def _broken_row(task: Task, job: Job, exc: BaseException) -> dict:
    """Row for a run whose worker died (or whose task Dask could not run)."""
    status = "crashed" if type(exc).__name__ == "KilledWorker" else "error"
    try:
        scene = scene_for(job, task)
    except Exception:
        scene = None
    row = {"run": task.run, "status": status, "reason": " ".join(f"{type(exc).__name__}: {exc}".split())[:500],
           "wall_time_s": float("nan"), "worker": ""}
    row.update(task.params)
    row.update(evaluate_metrics(job.metrics, task.params, None, scene))
    return row


def local_cluster(workers: int):
    """A local Dask cluster of ``workers`` single-threaded worker processes, and its client."""
    from dask.distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=workers, processes=True, threads_per_worker=1, dashboard_address=None,
                           silence_logs=logging.ERROR)
    return Client(cluster), cluster


def dask_rows(job: Job, tasks: list[Task], runner: Runner, client, in_flight: int = 1000) -> Iterator[dict]:
    """Runs on a Dask cluster, yielded as they finish; at most ``in_flight`` submitted at a time."""
    from dask.distributed import as_completed

    job = replace(job, fmus={n: _with_bytes(r) for n, r in job.fmus.items()})
    tag = uuid.uuid4().hex[:8]
    # The job (scene, metrics, FMU bytes) is a task of its own rather than scattered data: the
    # scheduler keeps its definition, so it is recomputed if every worker holding it dies.
    job_f = client.submit(_identity, job, key=f"sweep-job-{tag}", pure=False)
    pending = iter(tasks)
    futures: dict = {}
    ac = as_completed()

    def submit_next() -> None:
        t = next(pending, None)
        if t is not None:
            f = client.submit(runner, t, job_f, key=f"sweep-run{t.run}-{tag}", pure=False)
            futures[f] = t
            ac.add(f)

    try:
        for _ in range(in_flight):
            submit_next()
        for fut in ac:
            t = futures[fut]
            status = fut.status
            if status == "finished":
                try:
                    row = fut.result()
                except Exception as e:  # the result could not come back
                    row = _broken_row(t, job, e)
            elif status == "error":
                row = _broken_row(t, job, fut.exception())
            elif status == "cancelled":
                row = _broken_row(t, job, RuntimeError("the cluster cancelled the task"))
            else:  # finished, but its worker died before the result was fetched: Dask computes it again
                ac.add(fut)
                continue
            del futures[fut]
            fut.release()
            submit_next()
            yield row
    finally:
        if futures:
            client.cancel(list(futures))
        job_f.release()


def _identity(x):
    return x


def _with_bytes(ref: FmuRef) -> FmuRef:
    return ref if ref.data is not None else replace(ref, data=Path(ref.path).read_bytes())


# ------------------------------------------------------------------------------------ running
@dataclass
class Outcome:
    table: Path
    total: int
    ran: int                  # runs done by this call
    rows: list[dict]          # the whole table, by run (strings, as read back)
    wall: float               # s, this call (cluster start included when it started one)
    where: str

    @property
    def not_ok(self) -> list[dict]:
        return [r for r in self.rows if r["status"] != "ok"]


def _prepare_table(sweep: Sweep, tasks: list[Task], path: Path, resume: bool, overwrite: bool,
                   retry_failed: bool) -> dict[int, dict]:
    """Create or check the table; return the rows already done (kept by resume)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    cols = sweep.columns
    if path.exists() and path.stat().st_size > 0 and not (resume or overwrite):
        raise SweepError(f"results table {path} exists; --resume completes it, --overwrite starts again")
    if overwrite or not path.exists():
        write_table(path, cols, [])
        return {}
    header, rows = read_table(path)
    if header and header != cols:
        raise SweepError(f"{path}: columns {','.join(header)} differ from the sweep's {','.join(cols)}; "
                         "use --overwrite or another --out")
    by_run = {t.run: t for t in tasks}
    for run, row in rows.items():
        t = by_run.get(run)
        if t is None:
            raise SweepError(f"{path}: run {run} is not in the sweep (it has {len(tasks)} runs); "
                             "use --overwrite or another --out")
        for k, v in t.params.items():
            if row[k] != fmt(v):
                raise SweepError(f"{path}: run {run} has {k} = {row[k]} but the sweep now gives {fmt(v)}; "
                                 "use --overwrite or another --out")
    write_table(path, cols, [rows[r] for r in sorted(rows)])  # drops a torn last line
    if retry_failed:
        rows = {r: row for r, row in rows.items() if row["status"] == "ok"}
    return rows


def run_sweep(sweep: Sweep, out_dir: Path | None = None, *, workers: int | None = None, scheduler: str | None = None,
              client=None, resume: bool = False, overwrite: bool = False, retry_failed: bool = False,
              duration: float | None = None, timeout: float | None = None, progress: bool = True,
              runner: Runner = run_one, on_row: Callable[[dict], None] | None = None, plan: Plan | None = None) -> Outcome:
    """Run (or complete, with ``resume``) a sweep; every finished run is in the table at once.

    Where: ``client`` (a dask.distributed Client), else ``scheduler`` (address of a running
    cluster), else ``workers`` = 0 (this process) or N (a local cluster of N worker processes;
    default: one per CPU). ``on_row`` is called after each row is written."""
    t0 = time.perf_counter()
    if workers is not None and (workers < 0 or int(workers) != workers):
        raise SweepError(f"--workers = {workers!r}: allowed an integer >= 0 (0 = in this process)")
    if scheduler and workers is not None:
        raise SweepError("--workers and --scheduler: allowed one of them (the cluster at ADDRESS has its own workers)")
    if resume and overwrite:
        raise SweepError("--resume and --overwrite: allowed one of them")
    plan = plan or plan_sweep(sweep, duration=duration, timeout=timeout)
    path = table_path(sweep, out_dir)
    with FolderLock(path.parent, sweep.name):
        return _run_locked(sweep, plan, path, t0, workers=workers, scheduler=scheduler, client=client,
                           resume=resume, overwrite=overwrite, retry_failed=retry_failed, progress=progress,
                           runner=runner, on_row=on_row)


def _run_locked(sweep: Sweep, plan: Plan, path: Path, t0: float, *, workers, scheduler, client, resume, overwrite,
                retry_failed, progress, runner, on_row) -> Outcome:
    done = _prepare_table(sweep, plan.tasks, path, resume, overwrite, retry_failed)
    todo = [t for t in plan.tasks if t.run not in done]
    bar = ProgressBar(len(plan.tasks), len(done), sum(r["status"] != "ok" for r in done.values()), enabled=progress)
    own_client = own_cluster = None
    if client is not None:
        where = "the given Dask client"
    elif scheduler:
        where = f"Dask scheduler {scheduler}"
    elif workers == 0:
        where = "this process"
    else:
        workers = workers or os.cpu_count() or 1
        where = f"a local Dask cluster of {workers} worker processes"
    writer = TableWriter(path, sweep.columns)
    ran = 0
    try:
        if todo:
            if client is None and scheduler:
                from dask.distributed import Client
                client = own_client = Client(scheduler, timeout="30s")
            elif client is None and workers != 0:
                client, own_cluster = local_cluster(workers)
                own_client = client
            rows = serial_rows(plan.job, todo, runner) if client is None else dask_rows(plan.job, todo, runner, client)
            for row in rows:
                writer.append(row)
                ran += 1
                bar.update(row)
                if on_row is not None:
                    on_row(row)
    finally:
        writer.close()
        if own_client is not None:
            own_client.close()
        if own_cluster is not None:
            own_cluster.close()
    header, rows = read_table(path)
    ordered = [rows[r] for r in sorted(rows)]
    write_table(path, sweep.columns, ordered)  # final table: one row per run, in run order
    return Outcome(path, len(plan.tasks), ran, ordered, time.perf_counter() - t0, where)


# --------------------------------------------------------------------------------------- plots
def _num(v: str) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")


def default_plots(sweep: Sweep) -> list[Plot]:
    x = sweep.params[0].name
    group = sweep.params[1].name if len(sweep.params) > 1 else None
    return [Plot(x, [m.name], [], group) for m in sweep.metrics if m.kind != "theory"]


def plot_sweep(sweep: Sweep, rows: list[dict], out_dir: Path) -> list[Path]:
    """PNG per plot: metrics over a parameter, a line (or coloured points) per value of ``group``,
    theory columns dashed in the same colour. Runs that did not finish ok are left out (counted in the title)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    import matplotlib as mpl

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    ok = [r for r in rows if r["status"] == "ok"]
    skipped = len(rows) - len(ok)
    paths = []
    for k, pl in enumerate(sweep.plots or default_plots(sweep)):
        fig = Figure(figsize=(7.5, 4.8))
        FigureCanvasAgg(fig)
        ax = fig.add_subplot(1, 1, 1)
        groups = sorted({r[pl.group] for r in ok}, key=_num) if pl.group else [None]
        many = len(groups) > 8
        cmap = mpl.colormaps["viridis" if many else "tab10"]
        gv = [_num(g) for g in groups]
        for gi, g in enumerate(groups):
            sel = sorted((r for r in ok if g is None or r[pl.group] == g), key=lambda r: _num(r[pl.x]))
            xs = [_num(r[pl.x]) for r in sel]
            if many:
                span = (max(gv) - min(gv)) or 1.0
                color = cmap((gv[gi] - min(gv)) / span)
            else:
                color = cmap(gi % 10)
            label_g = f" ({pl.group} = {g})" if g is not None and not many else ""
            for j, y in enumerate(pl.y):
                ys = [_num(r[y]) for r in sel]
                ax.plot(xs, ys, ls="none" if many else "-", marker="os^vD"[j % 5], color=color, ms=5,
                        label=(y + label_g) if (not many or gi == 0) else None)
            for j, y in enumerate(pl.theory):
                ys = [_num(r[y]) for r in sel]
                ax.plot(xs, ys, ls="none" if many else "--", marker="x" if many else None, color=color,
                        label=(y + label_g) if (not many or gi == 0) else None)
        if many and pl.group:
            sm = mpl.cm.ScalarMappable(norm=mpl.colors.Normalize(min(gv), max(gv)), cmap=cmap)
            fig.colorbar(sm, ax=ax, label=pl.group)
        ax.set_xlabel(pl.x)
        ax.set_ylabel(", ".join(pl.y) + (f" (dashed: {', '.join(pl.theory)})" if pl.theory else ""))
        title = pl.title or f"{sweep.name}: {', '.join(pl.y)} over {pl.x}"
        if skipped:
            title += f"  ({skipped} run{'s' if skipped > 1 else ''} not ok, not shown)"
        ax.set_title(title, fontsize=10)
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="best")
        fig.tight_layout()
        p = out_dir / f"{sweep.name}_{pl.file or '-'.join(pl.y) or k}.png"
        fig.savefig(p, dpi=110)
        paths.append(p)
    return paths


# ------------------------------------------------------------------------------------ summary
def head(rows: list[dict], columns: list[str], n: int = 8) -> str:
    from harness.report import render

    cols = [c for c in columns if c not in ("worker", "reason")]
    lines = []
    for r in rows[:n]:
        line = []
        for c in cols:
            v = r.get(c, "")
            x = _num(v)
            line.append(f"{x:.6g}" if c not in ("run", "status") and math.isfinite(x) and v not in ("true", "false") else v)
        lines.append(line)
    return render(cols, lines)


# --------------------------------------------------------------------------------------- bench
def bench(sweep: Sweep, n_runs: int = 64, worker_counts=(1, 2), duration: float | None = None,
          out=print) -> dict:
    """Speed-up of an ``n_runs`` sweep with 1 versus 2 local workers (one run each, printed), and the
    per-run cost of the sweep machinery versus a bare scene run (``harness.master.run_scene``)."""
    import statistics
    import tempfile

    from harness.master import run_scene

    plan = plan_sweep(sweep, duration=duration)
    cyc = [plan.tasks[i % len(plan.tasks)] for i in range(n_runs)]
    listed = replace(sweep, method="list", n=None, seed=None,
                     params=[Param(p.name, values=[t.params[p.name] for t in cyc]) for p in sweep.params])
    plan = replace(plan, sweep=listed, tasks=expand(listed))
    res: dict[str, Any] = {"runs": n_runs, "scene": plan.job.scene.name, "duration": plan.job.scene.duration}
    run_scene(scene_for(plan.job, plan.tasks[0]), plan.fmu_files)  # warm-up: imports inside the FMU
    bare, stepping = [], []
    for t in plan.tasks:
        sc = scene_for(plan.job, t)
        t1 = time.perf_counter()
        r = run_scene(sc, plan.fmu_files)
        bare.append(time.perf_counter() - t1)
        stepping.append(r.wall_time)
    res["bare_per_run"] = statistics.mean(bare)
    res["stepping_per_run"] = statistics.mean(stepping)
    with tempfile.TemporaryDirectory() as tmp:
        o = run_sweep(listed, Path(tmp) / "serial", workers=0, plan=plan, progress=False)
        res["serial_per_run"] = o.wall / n_runs
        for w in worker_counts:
            t1 = time.perf_counter()
            client, cluster = local_cluster(w)
            start = time.perf_counter() - t1
            try:
                o = run_sweep(listed, Path(tmp) / f"w{w}", client=client, plan=plan, progress=False)
            finally:
                client.close()
                cluster.close()
            res[f"cluster{w}_start"] = start
            res[f"cluster{w}_wall"] = o.wall
            res[f"cluster{w}_ok"] = sum(r["status"] == "ok" for r in o.rows)
            inside = [float(r["wall_time_s"]) for r in o.rows]
            res[f"cluster{w}_inside_median"] = statistics.median(inside)
            res[f"cluster{w}_inside_sum"] = sum(inside)
    if len(worker_counts) == 2:
        a, b = worker_counts
        res["speedup"] = res[f"cluster{a}_wall"] / res[f"cluster{b}_wall"]
        res["speedup_with_start"] = ((res[f"cluster{a}_wall"] + res[f"cluster{a}_start"])
                                     / (res[f"cluster{b}_wall"] + res[f"cluster{b}_start"]))
    ms = 1e3
    out(f"sweep bench: {n_runs} runs of {res['scene']} ({res['duration']:g} s simulated each), "
        f"{os.cpu_count()} CPUs, python {sys.version.split()[0]}; one run of each, not repeated")
    out(f"  bare scene run (run_scene, instantiate per run): {res['bare_per_run'] * ms:.2f} ms per run "
        f"(of which stepping {res['stepping_per_run'] * ms:.2f} ms)")
    out(f"  sweep in this process (--workers 0, reused FMUs, table row per run): {res['serial_per_run'] * ms:.2f} ms "
        f"per run, overhead {(res['serial_per_run'] - res['bare_per_run']) * ms:+.2f} ms per run versus bare")
    for w in worker_counts:
        per = res[f"cluster{w}_wall"] / n_runs
        out(f"  local cluster, {w} worker process{'es' if w > 1 else ''}: {res[f'cluster{w}_wall']:.2f} s for the sweep "
            f"({per * ms:.2f} ms per run, overhead {(per - res['bare_per_run']) * ms:+.2f} ms versus bare), "
            f"cluster start {res[f'cluster{w}_start']:.2f} s, {res[f'cluster{w}_ok']} ok; inside the workers "
            f"{res[f'cluster{w}_inside_median'] * ms:.2f} ms per run (median), {res[f'cluster{w}_inside_sum']:.2f} s "
            f"in all (first run per process included)")
    if "speedup" in res:
        out(f"  speed-up {worker_counts[1]} versus {worker_counts[0]} workers: {res['speedup']:.2f}x "
            f"(sweep only), {res['speedup_with_start']:.2f}x (with cluster start)")
    return res


# ----------------------------------------------------------------------------------------- CLI
def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="spurdiff sweep", description="Run a parameter sweep over a scene "
                                 "(harness/sweeps/*.toml) on a local or remote Dask cluster; see docs/sweeps.md")
    ap.add_argument("sweep", nargs="?", help="sweep name (see --list) or path to a sweep .toml file")
    ap.add_argument("--list", action="store_true", help="list the sweeps in harness/sweeps")
    ap.add_argument("--workers", type=int, default=None,
                    help="local worker processes (default: one per CPU; 0 = run in this process)")
    ap.add_argument("--scheduler", metavar="ADDRESS", help="run on an existing dask.distributed cluster, "
                    "e.g. tcp://10.0.0.5:8786")
    ap.add_argument("--out", help="output directory (default results/sweeps/<name>)")
    ap.add_argument("--resume", action="store_true", help="complete an existing table: run only the missing runs")
    ap.add_argument("--retry-failed", action="store_true", help="with --resume: also rerun runs that did not finish ok")
    ap.add_argument("--overwrite", action="store_true", help="discard an existing table and start again")
    ap.add_argument("--duration", type=float, help="simulated time per run, s (overrides the sweep and scene)")
    ap.add_argument("--timeout", type=float, help="wall time limit per run, s (overrides the sweep file)")
    ap.add_argument("--plot", action="store_true", help="after the sweep, draw the metrics over the parameters (PNG)")
    ap.add_argument("--plot-only", action="store_true", help="draw the plots from the existing table, run nothing")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    ap.add_argument("--bench", action="store_true", help="measure: speed-up with 1 versus 2 local workers and the "
                    "per-run overhead versus a bare scene run (writes only to a temporary directory)")
    ap.add_argument("--bench-runs", type=int, default=64, help="runs in the bench sweep (default 64)")
    return ap


def _fail(msg: str, code: int = 2) -> int:
    print(f"spurdiff sweep: {msg}", file=sys.stderr)
    return code


def main(argv: list[str] | None = None) -> int:
    from spurdiff.errors import ParameterError

    try:
        args = build_parser().parse_args(argv)
    except SystemExit as e:
        return int(e.code or 0)
    try:
        return _main(args)
    except (SceneError, ParameterError) as e:
        return _fail(str(e))
    except KeyboardInterrupt:
        return _fail("interrupted; every finished run is in the table: --resume completes it", 130)


def _main(args) -> int:
    if args.list:
        for name in available():
            try:
                desc = load_sweep(name).description
                print(f"{name:28s} {desc.splitlines()[0] if desc else ''}")
            except SceneError as e:
                print(f"{name:28s} INVALID: {e}")
        return 0
    if not args.sweep:
        return _fail(f"give a sweep; allowed: a .toml file or one of {', '.join(available())}")
    if args.retry_failed and not args.resume:
        return _fail("--retry-failed goes with --resume")
    if args.duration is not None and not (args.duration > 0 and math.isfinite(args.duration)):
        return _fail(f"--duration = {args.duration!r}: allowed a finite number > 0")
    if args.timeout is not None and not (args.timeout > 0):
        return _fail(f"--timeout = {args.timeout!r}: allowed a number > 0")
    sweep = load_sweep(args.sweep)
    if args.bench:
        if args.bench_runs < 1:
            return _fail(f"--bench-runs = {args.bench_runs}: allowed an integer >= 1")
        bench(sweep, args.bench_runs, duration=args.duration)
        return 0
    out_dir = Path(args.out) if args.out else results_dir("sweeps", sweep.name)
    path = table_path(sweep, out_dir)
    if args.plot_only:
        if not path.exists():
            return _fail(f"no results table {path}; run the sweep first")
        _, rows = read_table(path)
        for p in plot_sweep(sweep, [rows[r] for r in sorted(rows)], out_dir):
            print(f"plot: {p}")
        return 0
    o = run_sweep(sweep, out_dir, workers=args.workers, scheduler=args.scheduler, resume=args.resume,
                  overwrite=args.overwrite, retry_failed=args.retry_failed, duration=args.duration,
                  timeout=args.timeout, progress=not args.quiet)
    bad = o.not_ok
    print(f"sweep {sweep.name} on scene {sweep.scene}: {o.total} runs, {o.total - len(bad)} ok, {len(bad)} not ok; "
          f"{o.ran} run now on {o.where} in {o.wall:.1f} s")
    print()
    print(head(o.rows, sweep.columns))
    if len(o.rows) > 8:
        print(f"... ({len(o.rows) - 8} more rows)")
    print()
    print(f"results: {o.table}")
    if args.plot:
        for p in plot_sweep(sweep, o.rows, out_dir):
            print(f"plot: {p}")
    missing = o.total - len(o.rows)
    if missing:
        return _fail(f"{missing} runs missing from {o.table}; --resume completes it", 1)
    if bad:
        reasons = "; ".join(f"run {r['run']} {r['status']}: {r['reason']}" for r in bad[:3])
        return _fail(f"{len(bad)} of {o.total} runs did not finish ok ({reasons}{' ...' if len(bad) > 3 else ''}); "
                     f"--resume --retry-failed reruns them", 1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
