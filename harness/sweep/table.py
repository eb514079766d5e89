"""A sweep's results table: one CSV row per finished run, appended and flushed at once, read back
for ``--resume`` (a torn last line is dropped), and the lock on its folder."""
from __future__ import annotations

import csv
import os
from pathlib import Path
from typing import Iterable

from harness.common.outputs import OutputLock, atomic_file, output_error
from harness.common.paths import results_dir
from harness.sweep.jobs import STATUSES, Task
from harness.sweep.spec import Sweep, SweepError

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
    """Write a whole table atomically (private temporary file, then rename: :mod:`harness.common.outputs`;
    on a write error the temporary file is removed and the table left as it was)."""
    with atomic_file(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(columns)
        for row in rows:
            w.writerow([fmt(row.get(c, "")) for c in columns])


class TableWriter:
    """Appends one row per finished run and flushes it, so a killed sweep keeps every finished run.
    The table is opened without following a link; a write error is an :class:`OutputError`."""

    def __init__(self, path: Path, columns: list[str]):
        self.columns, self.path = columns, Path(path)
        try:
            fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o666)
        except OSError as e:
            raise output_error(self.path, e) from None
        self.fh = os.fdopen(fd, "a", newline="")
        self.w = csv.writer(self.fh)
        self.rows = 0

    def append(self, row: dict) -> None:
        try:
            self.w.writerow([fmt(row.get(c, "")) for c in self.columns])
            self.fh.flush()
        except OSError as e:
            raise output_error(self.path, e, f"the {self.rows} runs written before are kept; "
                               "--resume completes it") from None
        self.rows += 1

    def close(self) -> None:
        try:
            self.fh.close()
        except OSError:   # a row that did not fit was reported by append; the torn line is dropped on reading
            pass


class FolderLock(OutputLock):
    """The lock on a sweep's results folder (:class:`harness.common.outputs.OutputLock`, the same lock a
    run takes): a second sweep or run writing the same folder is refused with a SweepError, told
    who holds it. The kernel drops the lock when its holder exits, however it exits, so a killed
    sweep leaves no stale lock behind."""

    def __init__(self, folder: Path, what: str):
        super().__init__(folder, f"sweep {what}", SweepError)


def prepare_table(sweep: Sweep, tasks: list[Task], path: Path, resume: bool, overwrite: bool,
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
