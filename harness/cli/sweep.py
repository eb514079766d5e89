"""``spurdiff sweep`` (= ``python -m harness.sweep``): run a design sweep (:mod:`harness.sweep`), list the
sweeps, plot a table, or measure the sweep machinery (``--bench``)."""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from harness.common.messages import printable
from harness.common.outputs import OutputError
from harness.common.paths import results_dir
from harness.scene.spec import SceneError
from harness.sweep.bench import bench
from harness.sweep.plots import head, plot_sweep
from harness.sweep.run import run_sweep
from harness.sweep.spec import available, load_sweep
from harness.sweep.table import FolderLock, read_table, table_path

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
    ap.add_argument("--max-steps", type=int, default=None, metavar="N",
                    help="refuse runs of more than N communication steps each (default 1,000,000)")
    ap.add_argument("--plot", action="store_true", help="after the sweep, draw the metrics over the parameters (PNG)")
    ap.add_argument("--plot-only", action="store_true", help="draw the plots from the existing table, run nothing")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    ap.add_argument("--bench", action="store_true", help="measure: speed-up with 1 versus 2 local workers and the "
                    "per-run overhead versus a bare scene run (writes only to a temporary directory)")
    ap.add_argument("--bench-runs", type=int, default=64, help="runs in the bench sweep (default 64)")
    return ap


def _fail(msg: str, code: int = 2) -> int:
    from harness.common.messages import one_line

    print(one_line(f"spurdiff sweep: {msg}"), file=sys.stderr)
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
    except OutputError as e:   # a table or plot that could not be written: the place and the errno
        return _fail(str(e), 1)
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
    if args.max_steps is not None and args.max_steps < 1:
        return _fail(f"--max-steps = {args.max_steps}: allowed an integer >= 1")
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
        with FolderLock(out_dir, f"{sweep.name} --plot-only"):   # not while a sweep writes the folder
            for p in plot_sweep(sweep, [rows[r] for r in sorted(rows)], out_dir):
                print(f"plot: {p}")
        return 0
    o = run_sweep(sweep, out_dir, workers=args.workers, scheduler=args.scheduler, resume=args.resume,
                  overwrite=args.overwrite, retry_failed=args.retry_failed, duration=args.duration,
                  timeout=args.timeout, progress=not args.quiet, max_steps=args.max_steps)
    bad = o.not_ok
    print(f"sweep {sweep.name} on scene {sweep.scene}: {o.total} runs, {o.total - len(bad)} ok, {len(bad)} not ok; "
          f"{o.ran} run now on {o.where} in {o.wall:.1f} s")
    print()
    print(printable(head(o.rows, sweep.columns)))   # values from the sweep file: no raw control characters
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
