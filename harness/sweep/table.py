"""A sweep's results table: one CSV row per finished run, appended and flushed at once, read back
for ``--resume`` (a torn last line is dropped), and the lock on its folder."""
from __future__ import annotations

import csv
import os
import socket
import time
from pathlib import Path
from typing import Iterable

from harness.paths import results_dir
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
