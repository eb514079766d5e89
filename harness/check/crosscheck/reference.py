"""Reference results in the layout of the FMI Cross-Check rules (:mod:`.crosscheck`), written by
simulating an FMU in a fresh process; the simulation itself is :mod:`.reference_task`.

:func:`write_reference_results` simulates an FMU over its DefaultExperiment (start time, else
0 s; stop time, else start + 1 s; stepSize, else 1e-3 s, as communication step; tolerance, else
1e-4, handed to fmi2SetupExperiment) with :func:`fmpy.simulate_fmu` (co-simulation when the FMU
offers it, else model exchange with fmpy's CVode), every parameter and input
at its start value unless an input table says otherwise, in a fresh process (see
:func:`harness.check.processes.isolation.run_isolated`). ``modelName`` becomes a folder and file name only
after :func:`safe_model_name` accepts it.
"""
from __future__ import annotations

import re
import time
from dataclasses import dataclass
from pathlib import Path

from .formats import (INPUT_TYPES, MAX_CSV_BYTES, CsvFormatError, read_cross_check_csv, read_ref_opt,
                         write_cross_check_csv, write_ref_opt)
from ..report import FAIL, PASS, CheckResult

DEFAULT_STEP_SIZE = 1e-3     # s
DEFAULT_DURATION = 1.0       # s, when the DefaultExperiment has no stopTime
DEFAULT_REL_TOL = 1e-4       # solver tolerance written to RelTol when the FMU states none


class ReferenceUsageError(ValueError):
    """Invalid request: e.g. an input table whose columns are not inputs of the FMU."""


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
    if not inputs and input_csv is not None and any(v.variability == "tunable" for v in md.modelVariables):
        pass   # only tunable parameters in the table
    elif not inputs:
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
    tunable = [v for v in md.modelVariables if v.causality == "parameter" and v.variability == "tunable"
               and v.type in INPUT_TYPES and v.name in given]   # a cross-check _in.csv may set them (fmpy does)
    names += [v.name for v in tunable]
    starts += [_start(v) for v in tunable]
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
                            timeout: float = 600.0, subject: str | None = None, ref_opt: str | Path | None = None,
                            columns: list[str] | None = None) -> CheckResult:
    """Simulate the FMU over its default experiment and write ``DIR/<Model>/<Model>_ref.csv``,
    ``_ref.opt`` and (when it has inputs) ``_in.csv``. The simulation runs in a fresh process.

    Returns a ``reference.write`` CheckResult: FAIL when the archive is unsafe, the modelName is
    not a safe file name, or the simulation fails or crashes. Raises ReferenceUsageError for an
    invalid ``input_csv``.
    """
    import shutil

    from fmpy import read_model_description

    from ..archive import ArchiveError, extract
    from ..processes.isolation import run_isolated   # the process runs .reference_task
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
        if ref_opt is not None:   # the options of a cross-check reference: the same run
            try:
                o = read_ref_opt(ref_opt)
            except (CsvFormatError, OSError, UnicodeDecodeError) as e:
                raise ReferenceUsageError(f"--ref-opt {ref_opt}: {e}") from None
            exp = Experiment(o["StartTime"], o["StopTime"], o["StepSize"], o["RelTol"])
        names, table = input_table(md, exp, input_csv)
        paths["ref.csv"].parent.mkdir(parents=True, exist_ok=True)
        for p in paths.values():
            if p.exists():
                p.unlink()
        if names:
            write_cross_check_csv(paths["in.csv"], names, table)
        payload = {"fmu": str(unzipdir), "ref_csv": str(paths["ref.csv"]), "columns": list(columns or []),
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
