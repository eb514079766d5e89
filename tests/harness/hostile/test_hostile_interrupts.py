"""Issue 14, items 11 to 13: nothing lost. The output place is checked before a run; rows are
streamed to the CSV as they are recorded; Ctrl-C stops ``spurdiff run`` at the next step (exit 130,
the rows recorded so far kept) and an in-process sweep at once (exit 130, no row for the
interrupted run); a second sweep writing the same folder is refused and told who holds it."""
from __future__ import annotations

import csv
import signal
import subprocess
import sys
import time

import pytest

from hostile_harness_util import ROOT, cli, one_line_error, sandbox, start, sweep  # noqa: F401


def wait_for(cond, timeout: float = 60.0, proc: subprocess.Popen | None = None) -> None:
    t_end = time.monotonic() + timeout
    while not cond():
        if proc is not None and proc.poll() is not None:
            pytest.fail(f"exited early ({proc.returncode}): {proc.stderr.read()}")
        if time.monotonic() > t_end:
            pytest.fail("timed out")
        time.sleep(0.05)


def rows_of(path) -> list[list[str]]:
    text = path.read_text()
    return list(csv.reader(text.splitlines()))


def test_unwritable_out_is_refused_before_running(sandbox, capsys, fmu_files):
    blocker = sandbox.dir / "file"
    blocker.write_text("a file, not a folder\n")
    t0 = time.perf_counter()
    r = cli(capsys, "run", "paper-cornering", "--duration", "0.05", "--no-plots", "--out", blocker / "sub")
    one_line_error(r, "--out = ", "cannot write there")
    assert "scene paper-cornering" not in r.out   # refused before the run, not after it
    assert blocker.read_text() == "a file, not a folder\n"
    r = cli(capsys, "run", "paper-cornering", "--duration", "0.05", "--no-plots", "--out", "/proc/spurdiff-out")
    one_line_error(r, "--out = '/proc/spurdiff-out'", "cannot write there")


def test_ctrl_c_on_run_exits_130_keeping_the_rows_recorded(sandbox):
    out = sandbox.dir / "out"
    csv_path = out / "paper-cornering.csv"
    # 2000 s simulated: minutes of wall time, so the run is surely interrupted mid-way
    p = start("run", "paper-cornering", "--duration", "2000", "--max-steps", "3000000", "--no-plots", "--out", out)
    try:
        # streamed: rows are on disk while the run goes on
        wait_for(lambda: csv_path.exists() and len(rows_of(csv_path)) > 200, proc=p)
        p.send_signal(signal.SIGINT)
        _, err = p.communicate(timeout=30)
    finally:
        p.kill()
    assert p.returncode == 130, err
    lines = [x for x in err.splitlines() if x.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert "interrupted at t = " in lines[0] and str(csv_path) in lines[0]
    n = int(lines[0].split("the ")[1].split()[0])
    rows = rows_of(csv_path)
    assert rows[0][0] == "time" and len(rows) == n + 1
    t_stop = float(lines[0].split("t = ")[1].split()[0])
    assert float(rows[-1][0]) == pytest.approx(t_stop, abs=1.5e-3) and t_stop < 2000


def test_ctrl_c_on_an_in_process_sweep_stops_at_once_and_records_no_row_for_the_run(sandbox):
    p_sweep = sweep(sandbox.dir, '[[metrics]]\nname = "lt"\nvar = "diff.lockingTorque"\nstat = "mean"',
                    values="[0.1, 0.2]", duration=2000)
    out = sandbox.dir / "out"
    table = out / "hsweep.csv"
    p = start("sweep", p_sweep, "--workers", "0", "--quiet", "--max-steps", "3000000", "--out", out)
    try:
        wait_for(table.exists, proc=p)   # the table is made just before the first run starts
        time.sleep(1.0)                  # the first run (minutes long) is stepping now
        t0 = time.perf_counter()
        p.send_signal(signal.SIGINT)
        _, err = p.communicate(timeout=30)
        stopped = time.perf_counter() - t0
    finally:
        p.kill()
    assert p.returncode == 130, err
    lines = [x for x in err.splitlines() if x.strip()]
    assert len(lines) == 1 and "interrupted" in lines[0] and "--resume" in lines[0], err
    assert rows_of(table) == [["run", "status", "reason", "wall_time_s", "worker", "diff.mu_pin", "lt"]]
    print(f"sweep stopped {stopped:.2f} s after Ctrl-C")   # the run itself would take minutes


def test_second_sweep_in_a_locked_folder_is_refused_naming_the_holder(sandbox, capsys, fmu_files):
    out = sandbox.dir / "out"
    holder = subprocess.Popen([sys.executable, "-c", (
        "import sys, time; from pathlib import Path; from harness.sweep import FolderLock\n"
        f"FolderLock(Path({str(out)!r}), 'first').acquire(); print('locked', flush=True); time.sleep(60)")],
        cwd=ROOT, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        p = sweep(sandbox.dir, '[[metrics]]\nname = "lt"\nvar = "diff.lockingTorque"\nstat = "mean"')
        r = cli(capsys, "sweep", p, "--workers", "0", "--quiet", "--out", out)
        one_line_error(r, f"results folder {out} is in use by sweep first (pid {holder.pid}", "another --out")
        assert not (out / "hsweep.csv").exists()
    finally:
        holder.kill()
        holder.wait()
    # the lock went with its holder (killed, not released): the folder is free again
    r = cli(capsys, "sweep", p, "--workers", "0", "--quiet", "--out", out)
    assert r.rc == 0, r.err
    assert len(rows_of(out / "hsweep.csv")) == 2
