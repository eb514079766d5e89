"""Reference results in the layout of the FMI Cross-Check rules, and comparison against them.

Layout (modelica/fmi-cross-check, FMI-CROSS-CHECK-RULES.md, 9.1.4 and Appendix B "CSV Rules"),
one folder per model, ``DIR/<ModelName>/``:

``<ModelName>_ref.csv``
    reference solution: first column ``time`` (monotonically increasing), then one column per
    output; header names in double quotes, exactly as in modelDescription.xml; unquoted C-style
    numbers, Booleans as 0/1; comma separated; no units line, no comments.
``<ModelName>_ref.opt``
    the options that reproduce it, one ``Name, value`` per line: ``StartTime``, ``StopTime``,
    ``StepSize`` (the communication step) and ``RelTol``.
``<ModelName>_in.csv``
    only when the FMU has inputs: the input signals (same CSV rules), linearly interpolated
    between rows by the importer.

:func:`write_reference_results` simulates an FMU over its DefaultExperiment (start time, else
0 s; stop time, else start + 1 s; stepSize, else 1e-3 s, as communication step; tolerance, else
1e-4, handed to fmi2SetupExperiment) with :func:`fmpy.simulate_fmu` (co-simulation when the FMU
offers it, else model exchange with fmpy's CVode), every parameter and input
at its start value unless an input table says otherwise, in a fresh process (see
:func:`harness.check.isolation.run_isolated`). ``modelName`` becomes a folder and file name only
after :func:`safe_model_name` accepts it.

:func:`compare_results` judges an importer's result CSV column by column against a reference:
the result is interpolated linearly onto the reference time points, and sample i of column c
passes when ``|y_i - y_ref,i| <= atol_c + rtol_c |y_ref,i|``. ``rtol_c`` defaults to 1e-3;
``atol_c`` defaults to ``rtol_c * max_i |y_ref,i|`` (so a signal crossing zero is not judged
by a vanishing relative band), floored at 1e-12; both can be set for all columns or per column.
At a time that appears twice (an event) the result's left or right limit may match.
"""
from __future__ import annotations

import csv
import math
import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

from .report import FAIL, PASS, CheckResult

DEFAULT_RTOL = 1e-3
DEFAULT_STEP_SIZE = 1e-3     # s
DEFAULT_DURATION = 1.0       # s, when the DefaultExperiment has no stopTime
DEFAULT_REL_TOL = 1e-4       # solver tolerance written to RelTol when the FMU states none
ATOL_FLOOR = 1e-12
MAX_CSV_BYTES = 1024 ** 2    # cross-check rule: a CSV file must not be larger than 1 MB


class CsvFormatError(ValueError):
    """A CSV file does not follow the cross-check CSV rules (or cannot be read)."""


class ReferenceUsageError(ValueError):
    """Invalid request: e.g. an input table whose columns are not inputs of the FMU."""


# ----------------------------------------------------------------------------- file formats

def read_cross_check_csv(path: str | Path) -> tuple[list[str], list[list[float]]]:
    """Read a cross-check CSV: (column names with "time" first, rows of floats).

    Raises CsvFormatError for a missing/misnamed time column, ragged rows, non-numeric cells or
    decreasing time.
    """
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError) as e:
        raise CsvFormatError(f"{path}: cannot read: {e}") from None
    rows = [r for r in rows if r and any(c.strip() for c in r)]
    if not rows:
        raise CsvFormatError(f"{path}: empty file")
    names = [n.strip() for n in rows[0]]
    if not names or names[0] != "time":
        raise CsvFormatError(f'{path}: the first column must be "time", found {names[0] if names else "nothing"!r}')
    if len(set(names)) != len(names):
        raise CsvFormatError(f"{path}: duplicate column names")
    data: list[list[float]] = []
    for lineno, r in enumerate(rows[1:], 2):
        if len(r) != len(names):
            raise CsvFormatError(f"{path}:{lineno}: {len(r)} cells, the header has {len(names)}")
        try:
            data.append([float(c) for c in r])
        except ValueError:
            raise CsvFormatError(f"{path}:{lineno}: non-numeric cell in {r!r}") from None
    if not data:
        raise CsvFormatError(f"{path}: no data rows")
    for i in range(1, len(data)):
        if data[i][0] < data[i - 1][0]:
            raise CsvFormatError(f"{path}:{i + 2}: time decreases ({data[i - 1][0]!r} -> {data[i][0]!r})")
    return names, data


def _literal(x: Any) -> str:
    if isinstance(x, bool):
        return "1" if x else "0"
    if isinstance(x, int):
        return str(x)
    return repr(float(x))  # shortest round-trip literal: 0.1, 1e-05, nan, inf


def write_cross_check_csv(path: str | Path, names: Sequence[str], rows: Sequence[Sequence[Any]]) -> Path:
    """Write a CSV following the cross-check rules (quoted header, unquoted numbers)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", encoding="utf-8", newline="") as f:
        f.write(",".join('"' + n.replace('"', '""') + '"' for n in names) + "\n")
        for r in rows:
            f.write(",".join(_literal(x) for x in r) + "\n")
    return path


def write_ref_opt(path: str | Path, start_time: float, stop_time: float, step_size: float, rel_tol: float) -> Path:
    """Write ``<Model>_ref.opt``: StartTime, StopTime, StepSize, RelTol (cross-check rules 9.1.4)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"StartTime, {start_time!r}\nStopTime, {stop_time!r}\nStepSize, {step_size!r}\n"
                    f"RelTol, {rel_tol!r}\n", encoding="utf-8")
    return path


def read_ref_opt(path: str | Path) -> dict[str, float]:
    """Read a ``_ref.opt`` file (``Name, value`` lines; ``//`` comments ignored)."""
    opts: dict[str, float] = {}
    for line in Path(path).read_text(encoding="utf-8").splitlines():
        line = line.split("//", 1)[0].strip()
        if not line:
            continue
        key, _, value = line.partition(",")
        try:
            opts[key.strip()] = float(value)
        except ValueError:
            continue
    for key in ("StartTime", "StopTime", "StepSize", "RelTol"):
        if key not in opts:
            raise CsvFormatError(f"{path}: missing {key}")
    return opts


# ----------------------------------------------------------------------------- experiment

@dataclass(frozen=True)
class Experiment:
    """The run a reference result is made with (times and step in s)."""

    start_time: float
    stop_time: float
    step_size: float
    rel_tol: float


def default_experiment(md) -> Experiment:
    """From the FMU's DefaultExperiment, with the module defaults for what it leaves out."""
    de = md.defaultExperiment
    start = float(de.startTime) if de is not None and de.startTime is not None else 0.0
    stop = float(de.stopTime) if de is not None and de.stopTime is not None else start + DEFAULT_DURATION
    step = float(de.stepSize) if de is not None and de.stepSize is not None and float(de.stepSize) > 0 else DEFAULT_STEP_SIZE
    tol = float(de.tolerance) if de is not None and de.tolerance is not None else DEFAULT_REL_TOL
    return Experiment(start, stop, step, tol)


INPUT_TYPES = ("Real", "Integer", "Enumeration", "Boolean")


def _start(v) -> float:
    if v.start is None:
        return 0.0
    if v.type == "Boolean":
        return 1.0 if v.start in (True, "true", "1", 1) else 0.0
    return float(v.start)


def input_table(md, exp: Experiment, input_csv: str | Path | None = None) -> tuple[list[str], list[list[float]]]:
    """The input signals: every input at its start value, held from start to stop time, or the
    rows of ``input_csv`` (its columns must be inputs of the FMU; inputs it leaves out are held
    at their start values). Returns ([] , []) when the FMU has no inputs."""
    inputs = [v for v in md.modelVariables if v.causality == "input" and v.type in INPUT_TYPES]
    if not inputs:
        if input_csv is not None:
            raise ReferenceUsageError(f"--input {input_csv}: the FMU {md.modelName} has no inputs")
        return [], []
    names = ["time"] + [v.name for v in inputs]
    starts = [_start(v) for v in inputs]
    if input_csv is None:
        return names, [[exp.start_time] + starts, [exp.stop_time] + starts]
    try:
        given, rows = read_cross_check_csv(input_csv)
    except CsvFormatError as e:
        raise ReferenceUsageError(str(e)) from None
    unknown = [n for n in given[1:] if n not in names]
    if unknown:
        raise ReferenceUsageError(f"--input {input_csv}: columns {', '.join(unknown)} are not inputs of "
                                  f"{md.modelName} (inputs: {', '.join(names[1:])})")
    col = {n: i for i, n in enumerate(given)}
    table = []
    for r in rows:
        table.append([r[0]] + [r[col[n]] if n in col else s for n, s in zip(names[1:], starts)])
    return names, table


# ----------------------------------------------------------------------------- writing references

_SAFE_NAME = re.compile(r"[A-Za-z0-9_](?:[A-Za-z0-9_ .+(),-]{0,126}[A-Za-z0-9_+)-])?")


def safe_model_name(model_name: str | None) -> str:
    """``model_name`` when it can be a folder and file name inside the output folder: letters,
    digits, and inside the name spaces and ``_ . + - ( ) ,``; no separator, ``:`` or ``..``; at
    most 128 characters. Raises
    ReferenceUsageError (one line) otherwise: a hostile FMU must not write outside the folder."""
    if not model_name or not _SAFE_NAME.fullmatch(model_name) or ".." in model_name:
        raise ReferenceUsageError(f"modelName {model_name!r} cannot be used as a file name (allowed: letters, "
                                  f"digits, space and _ . + - ( ) , inside; no '/', '\\', ':', '..'; 1-128 characters)")
    return model_name


def reference_paths(out_dir: str | Path, model_name: str) -> dict[str, Path]:
    name = safe_model_name(model_name)
    root = Path(out_dir).resolve()
    folder = root / name
    paths = {"ref.csv": folder / f"{name}_ref.csv", "ref.opt": folder / f"{name}_ref.opt",
             "in.csv": folder / f"{name}_in.csv"}
    for p in paths.values():  # belt and braces: every path stays inside out_dir
        if root not in p.resolve().parents:
            raise ReferenceUsageError(f"modelName {model_name!r} would write outside {out_dir}")
    return paths


def write_reference_results(fmu_path: str | Path, out_dir: str | Path, input_csv: str | Path | None = None,
                            timeout: float = 600.0, subject: str | None = None) -> CheckResult:
    """Simulate the FMU over its default experiment and write ``DIR/<Model>/<Model>_ref.csv``,
    ``_ref.opt`` and (when it has inputs) ``_in.csv``. The simulation runs in a fresh process.

    Returns a ``reference.write`` CheckResult: FAIL when the archive is unsafe, the modelName is
    not a safe file name, or the simulation fails or crashes. Raises ReferenceUsageError for an
    invalid ``input_csv``.
    """
    import shutil

    from fmpy import read_model_description

    from .archive import ArchiveError, extract
    from .isolation import run_isolated
    subject = subject if subject is not None else str(fmu_path)
    t0 = time.perf_counter()
    try:
        unzipdir = extract(fmu_path)
    except ArchiveError as e:
        return CheckResult(subject, "reference.write", FAIL, f"the FMU could not be unpacked: {e}")
    try:
        md = read_model_description(str(unzipdir), validate=False)
        try:
            paths = reference_paths(out_dir, md.modelName)
        except ReferenceUsageError as e:
            return CheckResult(subject, "reference.write", FAIL, str(e), time.perf_counter() - t0)
        exp = default_experiment(md)
        names, table = input_table(md, exp, input_csv)
        paths["ref.csv"].parent.mkdir(parents=True, exist_ok=True)
        for p in paths.values():
            if p.exists():
                p.unlink()
        if names:
            write_cross_check_csv(paths["in.csv"], names, table)
        payload = {"fmu": str(unzipdir), "ref_csv": str(paths["ref.csv"]),
                   "in_csv": str(paths["in.csv"]) if names else None,
                   "experiment": [exp.start_time, exp.stop_time, exp.step_size, exp.rel_tol]}
        status, reason, _ = run_isolated("reference", payload, timeout)
    finally:
        shutil.rmtree(unzipdir, ignore_errors=True)
    if status == PASS:
        write_ref_opt(paths["ref.opt"], exp.start_time, exp.stop_time, exp.step_size, exp.rel_tol)
        written = [p for p in paths.values() if p.exists()]
        big = [p.name for p in written if p.stat().st_size > MAX_CSV_BYTES]
        reason = (f"wrote {', '.join(str(p) for p in written)} ({reason})"
                  + (f"; note: over the cross-check limit of 1 MB per CSV file: {', '.join(big)}" if big else ""))
    return CheckResult(subject, "reference.write", status, reason, time.perf_counter() - t0)


def simulate_reference_task(payload: dict, trace) -> tuple[str, str]:
    """Worker side of :func:`write_reference_results` (runs in the fresh process)."""
    import numpy as np
    from fmpy import read_model_description, simulate_fmu
    start, stop, step, rel_tol = payload["experiment"]
    md = read_model_description(payload["fmu"], validate=False)
    outputs = [v for v in md.modelVariables if v.causality == "output" and v.type in INPUT_TYPES]
    signals = None
    if payload["in_csv"]:
        names, rows = read_cross_check_csv(payload["in_csv"])
        types = {v.name: v.type for v in md.modelVariables}
        dtype = [("time", np.float64)] + [(n, {"Real": np.float64, "Boolean": np.bool_}.get(types[n], np.int32))
                                          for n in names[1:]]
        signals = np.array([tuple(r) for r in rows], dtype=dtype)
    trace(f"fmpy.simulate_fmu(start_time={start!r}, stop_time={stop!r}, output_interval={step!r})")
    fmi_type = "CoSimulation" if md.coSimulation is not None else "ModelExchange"  # ME: fmpy's CVode
    result = simulate_fmu(payload["fmu"], validate=False, fmi_type=fmi_type, start_time=start,
                          stop_time=stop, output_interval=step, relative_tolerance=rel_tol,
                          apply_default_start_values=True, input=signals, output=[v.name for v in outputs])
    names = ["time"] + [v.name for v in outputs]
    as_int = {v.name for v in outputs if v.type != "Real"}  # Integer, Enumeration; Boolean as 0/1
    rows = [[int(result[n][i]) if n in as_int else float(result[n][i]) for n in names] for i in range(len(result))]
    write_cross_check_csv(payload["ref_csv"], names, rows)
    if not rows:
        return FAIL, "the simulation gave no rows"
    if not math.isclose(rows[-1][0], stop, rel_tol=1e-9, abs_tol=1e-12):
        # fmpy stops early only when the FMU ends the simulation (fmi2Discard with fmi2Terminated)
        return PASS, (f"{len(rows)} rows, {len(outputs)} outputs, t = {start:g} .. {rows[-1][0]:g} s: the FMU ended "
                      f"the simulation before the stop time {stop:g} s; step {step:g} s")
    return PASS, f"{len(rows)} rows, {len(outputs)} outputs, t = {start:g} .. {stop:g} s, step {step:g} s"


# ----------------------------------------------------------------------------- comparison

@dataclass(frozen=True)
class Tolerance:
    """Per-column tolerance: relative ``rtol`` and absolute ``atol`` (None: rtol x column peak)."""

    rtol: float = DEFAULT_RTOL
    atol: float | None = None


@dataclass(frozen=True)
class ColumnComparison:
    """Outcome for one reference column."""

    name: str
    passed: bool
    reason: str
    max_error: float = math.nan
    samples_outside: int = 0


def _limits(t, y):
    """Left- and right-limit copies of a sampled signal with repeated time points (events)."""
    import numpy as np
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    keep_first = np.r_[True, np.diff(t) > 0]
    keep_last = np.r_[np.diff(t) > 0, True]
    return (t[keep_first], y[keep_first]), (t[keep_last], y[keep_last])


def compare_results(result_csv: str | Path, reference_csv: str | Path, rtol: float = DEFAULT_RTOL,
                    atol: float | None = None,
                    per_column: Mapping[str, Tolerance] | None = None) -> list[ColumnComparison]:
    """Compare every non-time column of ``reference_csv`` with the same column of ``result_csv``
    (see the module docstring for the rule). Raises CsvFormatError for unreadable files."""
    import numpy as np
    per_column = dict(per_column or {})
    res_names, res_rows = read_cross_check_csv(result_csv)
    ref_names, ref_rows = read_cross_check_csv(reference_csv)
    R = np.asarray(res_rows, dtype=float)
    F = np.asarray(ref_rows, dtype=float)
    t_ref, t_res = F[:, 0], R[:, 0]
    span = max(abs(t_ref[-1] - t_ref[0]), 1e-300)
    eps = 1e-9 * max(span, 1.0)
    covered = t_res[0] <= t_ref[0] + eps and t_res[-1] >= t_ref[-1] - eps
    out: list[ColumnComparison] = []
    for k, name in enumerate(ref_names[1:], 1):
        tol = per_column.get(name, Tolerance(rtol, atol))
        if name not in res_names:
            out.append(ColumnComparison(name, False, "column missing from the result"))
            continue
        if not covered:
            out.append(ColumnComparison(name, False, f"the result covers t = {t_res[0]:g} .. {t_res[-1]:g} s, "
                                                     f"the reference {t_ref[0]:g} .. {t_ref[-1]:g} s"))
            continue
        y_ref = F[:, k]
        (tl, yl), (tr, yr) = _limits(t_res, R[:, res_names.index(name)])
        y_left = np.interp(t_ref, tl, yl)
        y_right = np.interp(t_ref, tr, yr)
        finite_ref = y_ref[np.isfinite(y_ref)]
        peak = float(np.max(np.abs(finite_ref))) if finite_ref.size else 0.0
        a = tol.atol if tol.atol is not None else max(tol.rtol * peak, ATOL_FLOOR)
        allowed = a + tol.rtol * np.abs(y_ref)
        with np.errstate(invalid="ignore"):
            err = np.fmin(np.abs(y_left - y_ref), np.abs(y_right - y_ref))
            both_nan = np.isnan(y_ref) & (np.isnan(y_left) | np.isnan(y_right))
            err = np.where(both_nan, 0.0, err)
            err = np.where(np.isnan(err), np.inf, err)  # NaN on one side only
            outside = err > allowed
            y_best = np.where(np.abs(y_left - y_ref) <= np.abs(y_right - y_ref), y_left, y_right)
        n_out = int(outside.sum())
        i = int(np.argmax(err - allowed))
        rule = f"|error| <= {a:.3g} + {tol.rtol:.3g} |ref|"
        if n_out:
            reason = (f"{n_out} of {len(t_ref)} samples outside {rule}; worst at t = {t_ref[i]:g} s: "
                      f"result {float(y_best[i])!r} vs reference {float(y_ref[i])!r} (|error| {err[i]:.3g} > {allowed[i]:.3g})")
        else:
            i = int(np.argmax(err))
            reason = f"max |error| {float(err[i]):.3g} at t = {t_ref[i]:g} s; all {len(t_ref)} samples within {rule}"
        out.append(ColumnComparison(name, n_out == 0, reason, float(np.max(err)), n_out))
    return out


def compare_checks(result_csv: str | Path, reference_csv: str | Path, rtol: float = DEFAULT_RTOL,
                   atol: float | None = None, per_column: Mapping[str, Tolerance] | None = None,
                   subject: str | None = None) -> list[CheckResult]:
    """:func:`compare_results` as report lines: one ``compare.<column>`` check per column."""
    subject = subject if subject is not None else str(result_csv)
    return [CheckResult(subject, f"compare.{c.name}", PASS if c.passed else FAIL, c.reason)
            for c in compare_results(result_csv, reference_csv, rtol, atol, per_column)]
