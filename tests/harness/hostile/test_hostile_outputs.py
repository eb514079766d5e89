"""Issue 30, items 1 and 2: one writer per output place, no file written through a link planted in
the output folder, and full or read-only places end every writing command with one line naming the
place and the errno, keeping what was completely written and leaving no temporary file.

The full and read-only places are small tmpfs mounts made for the test (root only: skipped with
the reason elsewhere)."""
from __future__ import annotations

import csv
import os
import signal
import subprocess
import time
from pathlib import Path
from types import SimpleNamespace

import pytest

from hostile_harness_util import ROOT, SPURDIFF, cli, one_line_error, sandbox, start  # noqa: F401

PAGE = 4096


@pytest.fixture
def small_fs(tmp_path):
    """``make(size, ro=False, free=None)``: a tmpfs of ``size`` mounted in the test's folder, read-only
    with ``ro``, or filled up to ``free`` bytes left; unmounted after the test."""
    mounts = []

    def make(size: str = "64k", ro: bool = False, free: int | None = None) -> Path:
        d = tmp_path / f"fs{len(mounts)}"
        d.mkdir()
        try:
            r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(d)],
                               capture_output=True, text=True)
        except OSError as e:   # no mount command
            pytest.skip(f"cannot mount a small tmpfs for the test ({e})")
        if r.returncode != 0:
            pytest.skip(f"cannot mount a small tmpfs for the test ({(r.stderr or '').strip() or r.returncode}): "
                        "needs root (CI runs as root)")
        mounts.append(d)
        if free is not None:
            total = os.statvfs(d).f_blocks * os.statvfs(d).f_frsize
            (d / "filler").write_bytes(b"\0" * (total - free))
        if ro:
            subprocess.run(["mount", "-o", "remount,ro", str(d)], check=True)
        return d

    yield make
    for d in mounts:
        subprocess.run(["umount", "-l", str(d)], capture_output=True)


def leftovers(folder: Path) -> list[str]:
    """Temporary or staged files a command left behind."""
    return sorted(p.name for p in folder.rglob("*") if p.name.endswith((".tmp", ".partial.ssp"))
                  or (p.name.startswith(".") and not p.name.endswith(".lock")))


def complete_csv(path: Path) -> list[list[str]]:
    """The rows of a results CSV, each line whole (ends with its line end, as many fields as the header)."""
    text = path.read_bytes().decode()
    assert text.endswith("\r\n"), text[-80:]
    rows = list(csv.reader(text.splitlines()))
    assert all(len(r) == len(rows[0]) for r in rows), "a torn or interleaved row"
    times = [float(r[0]) for r in rows[1:]]
    assert times == sorted(set(times)), "times not strictly increasing"
    return rows


# ------------------------------------------------------------------------- one writer per place
def test_a_second_run_into_the_same_out_is_refused_naming_the_first(sandbox):
    out = sandbox.dir / "out"
    csv_path = out / "paper-cornering.csv"
    # 900 s simulated (900,000 steps): minutes of wall time, so the second run surely meets the first
    first = start("run", "paper-cornering", "--duration", "900", "--no-plots", "--out", out)
    try:
        deadline = time.monotonic() + 60
        while not (csv_path.exists() and csv_path.stat().st_size > 20000):
            assert first.poll() is None and time.monotonic() < deadline, first.communicate()
            time.sleep(0.1)
        second = subprocess.run(SPURDIFF + ["run", "paper-cornering", "--duration", "0.05", "--no-plots",
                                            "--out", str(out)], cwd=ROOT, capture_output=True, text=True, timeout=120)
        first.send_signal(signal.SIGINT)
        first.communicate(timeout=30)
    finally:
        first.kill()
    lines = [x for x in second.stderr.splitlines() if x.strip()]
    assert second.returncode != 0 and len(lines) == 1 and "Traceback" not in second.stderr, second.stderr
    assert f"is in use by spurdiff run paper-cornering (pid {first.pid}" in lines[0], lines[0]
    assert first.returncode == 130
    rows = complete_csv(csv_path)   # the first run's rows alone, none of the second's
    assert float(rows[-1][0]) > 0.05


def test_run_writes_no_file_through_a_link_planted_in_its_folder(sandbox, capsys, fmu_files):
    out = sandbox.dir / "out"
    out.mkdir()
    victim = sandbox.dir / "victim.txt"
    victim.write_text("outside --out\n")
    (out / "paper-cornering.csv").symlink_to(victim)
    r = cli(capsys, "run", "paper-cornering", "--duration", "0.05", "--no-plots", "--out", out)
    one_line_error(r, "paper-cornering.csv", "symbolic link", rc=1)
    assert victim.read_text() == "outside --out\n"
    (out / "paper-cornering.csv").unlink()
    (out / "paper-cornering_speeds.png").symlink_to(victim)
    r = cli(capsys, "run", "paper-cornering", "--duration", "0.05", "--out", out)
    one_line_error(r, "paper-cornering_speeds.png", "symbolic link", rc=1)
    assert victim.read_text() == "outside --out\n"
    (out / "paper-cornering_speeds.png").unlink()
    (out / "paper-cornering.csv").unlink()   # written by that run before its plots
    os.link(victim, out / "paper-cornering.csv")   # a hard link: replaced, not written through
    r = cli(capsys, "run", "paper-cornering", "--duration", "0.05", "--no-plots", "--out", out)
    assert r.rc == 0, r.err
    assert victim.read_text() == "outside --out\n"
    assert len(complete_csv(out / "paper-cornering.csv")) == 52
    assert leftovers(out) == []


# ------------------------------------------------------------------------- full places
def test_a_full_disk_during_a_run_is_one_line_keeping_the_complete_rows(sandbox, capsys, fmu_files, small_fs):
    fs = small_fs("32k")
    r = cli(capsys, "run", "paper-cornering", "--no-plots", "--out", fs / "r")
    line = one_line_error(r, "paper-cornering.csv", "No space left on device", "[errno 28 ENOSPC]", "are kept", rc=1)
    kept = int(line.split("its first ")[1].split()[0])
    rows = complete_csv(fs / "r" / "paper-cornering.csv")
    assert len(rows) == kept and 2 < kept < 302
    assert leftovers(fs) == []


def test_a_full_disk_while_plotting_is_one_line_keeping_the_csv(sandbox, capsys, fmu_files, small_fs):
    fs = small_fs("64k")
    r = cli(capsys, "run", "paper-cornering", "--out", fs / "r")
    one_line_error(r, "paper-cornering_", ".png", "[errno 28 ENOSPC]", rc=1)
    assert len(complete_csv(fs / "r" / "paper-cornering.csv")) == 302
    assert leftovers(fs) == []


def test_a_sweep_on_a_full_disk_is_one_line_leaving_no_temporary_file(sandbox, capsys, fmu_files, small_fs):
    fs = small_fs("64k", free=2 * PAGE)   # the lock and the table fit, the final table's rewrite does not
    r = cli(capsys, "sweep", "cornering-locking", "--workers", "0", "--quiet", "--duration", "0.05",
            "--out", fs / "s")
    one_line_error(r, "cornering-locking", "[errno 28 ENOSPC]", rc=1)
    assert leftovers(fs) == []
    table = (fs / "s" / "cornering-locking.csv").read_text().splitlines()
    assert table[0].startswith("run,status") and len(table) > 1


@pytest.mark.parametrize("argv, place", [
    (["export-ssp", "paper-cornering", "-o", "{fs}/x.ssp"], "x.ssp"),
    (["check", "{wheel}", "--static-only", "--junit", "{fs}/j.xml"], "j.xml"),
    (["build", "WheelLoad", "--out", "{fs}/f"], "WheelLoad"),
])
def test_a_full_place_is_one_line_leaving_no_temporary_file(sandbox, capsys, fmu_files, small_fs, argv, place):
    fs = small_fs("256k", free=PAGE if argv[0] == "check" else None)
    if argv[0] == "check":
        (fs / "filler2").write_bytes(b"\0" * PAGE)   # nothing left
    argv = [a.format(fs=fs, wheel=fmu_files["WheelLoad"]) for a in argv]
    if argv[0] == "build":   # in a fresh process, as a user runs it (this one has loaded FMUs: it would build in a child)
        p = subprocess.run(SPURDIFF + argv, cwd=ROOT, capture_output=True, text=True, timeout=300)
        r = SimpleNamespace(rc=p.returncode, out=p.stdout, err=p.stderr)
    else:
        r = cli(capsys, *argv)
    assert r.rc != 0
    one_line_error(r, place, "No space left on device", "[errno 28 ENOSPC]", rc=r.rc)
    assert leftovers(fs) == []


def test_bench_write_on_a_full_disk_is_one_line_keeping_the_page(sandbox, capsys, small_fs, monkeypatch):
    import harness.measure.bench.report as bench_report

    fs = small_fs("64k")
    page = fs / "performance.md"
    page.write_text("# Performance\n\nold block\n\n## kept section\n")
    (fs / "filler").write_bytes(b"\0" * (os.statvfs(fs).f_bavail * os.statvfs(fs).f_frsize))
    monkeypatch.setattr(bench_report, "_report", lambda args: print("x" * 20000) or 0)   # the text, not the bench
    r = cli(capsys, "bench", "--write", page)
    one_line_error(r, "performance.md", "[errno 28 ENOSPC]", rc=1)
    assert page.read_text() == "# Performance\n\nold block\n\n## kept section\n"
    assert leftovers(fs) == []


# ------------------------------------------------------------------------- read-only places
@pytest.mark.parametrize("argv, place", [
    (["run", "paper-cornering", "--duration", "0.05", "--out", "{fs}/r"], "{fs}/r"),
    (["sweep", "cornering-locking", "--workers", "0", "--quiet", "--duration", "0.05", "--out", "{fs}/s"], "{fs}/s"),
    (["export-ssp", "paper-cornering", "-o", "{fs}/x.ssp"], "{fs}/x.ssp"),
    (["check", "{wheel}", "--static-only", "--junit", "{fs}/j.xml"], "{fs}/j.xml"),
    (["build", "WheelLoad", "--out", "{fs}/f"], "{fs}/f"),
    (["accuracy", "--render", "--out", "{fs}/docs"], "{fs}/docs"),
    (["bench", "--write", "{fs}/performance.md"], "{fs}/performance.md"),
])
def test_a_read_only_place_is_one_line_naming_it_and_the_errno(sandbox, capsys, fmu_files, small_fs, argv, place):
    fs = small_fs("64k", ro=True)
    argv = [a.format(fs=fs, wheel=fmu_files["WheelLoad"]) for a in argv]
    r = cli(capsys, *argv)
    assert r.rc != 0
    one_line_error(r, place.format(fs=fs), "Read-only file system", "errno 30 EROFS", rc=r.rc)
