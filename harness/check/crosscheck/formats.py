"""The file formats of the FMI Cross-Check rules: CSV tables and ``_ref.opt`` options.

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
"""
from __future__ import annotations

import csv
from pathlib import Path
from typing import Any, Sequence

MAX_CSV_BYTES = 1024 ** 2    # cross-check rule: a CSV file must not be larger than 1 MB
INPUT_TYPES = ("Real", "Integer", "Enumeration", "Boolean")   # variable types a cross-check CSV holds


class CsvFormatError(ValueError):
    """A CSV file does not follow the cross-check CSV rules (or cannot be read)."""


_BOOLEAN_CELLS = {"true": 1.0, "false": 0.0}


def _cell(text: str) -> float:
    """A CSV cell as a number: a C literal, or ``true`` / ``false`` in any case (a Boolean written
    by a tool that does not follow the rules' 0/1) as 1 / 0."""
    t = text.strip()
    b = _BOOLEAN_CELLS.get(t.lower())
    return b if b is not None else float(t)


def last_time_text(path: str | Path) -> str:
    """The first cell of the last data line as written (for the rounding of a reference's last time)."""
    last = ""
    with Path(path).open(newline="", encoding="utf-8") as f:
        for r in csv.reader(f):
            if r and r[0].strip():
                last = r[0].strip()
    return last


def read_cross_check_csv(path: str | Path) -> tuple[list[str], list[list[float]]]:
    """Read a cross-check CSV: (column names with "time" first, rows of floats).

    Cells ``true`` / ``false`` (any case) read as 1 / 0; a separator ending every line adds no column.
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
    if len(names) > 1 and names[-1] == "" and all(len(r) == len(names) and not r[-1].strip() for r in rows[1:]):
        names = names[:-1]             # a separator at the end of every line: no column
        rows = [r[:-1] for r in rows]
    data: list[list[float]] = []
    for lineno, r in enumerate(rows[1:], 2):
        if len(r) != len(names):
            raise CsvFormatError(f"{path}:{lineno}: {len(r)} cells, the header has {len(names)}")
        try:
            data.append([_cell(c) for c in r])
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
