"""``python -m harness.cli.tools.process_bench [--load [N]] [--steps N] [--fmu PATH ...]``: section 7
of ``spurdiff bench`` alone, or with ``--load`` the per-step ratio of the model's own process against
the host's, quiet and beside N spinning processes in the same run (:mod:`harness.measure.bench.process`)."""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    """``python -m harness.cli.tools.process_bench [--load N]``: the table; with --load only the step
    quiet and beside N spinning processes (default 2 x cores), the same run."""
    from harness.measure.bench import process

    ap = argparse.ArgumentParser(prog="python -m harness.cli.tools.process_bench", description=process.__doc__)
    ap.add_argument("--load", type=int, nargs="?", const=0, default=None,
                    help="only the per-step ratio quiet and beside LOAD spinning processes (default 2 x cores)")
    ap.add_argument("--steps", type=int, default=2000, help="communication steps per round (default 2000)")
    ap.add_argument("--fmu", type=Path, action="append", default=[],
                    help="with --load: this SpurDifferential.fmu instead of this checkout's build (repeatable: "
                         "each measured in turn, e.g. an older build beside today's)")
    args = ap.parse_args(argv)
    if args.load is None:
        print("\n".join(process.report()))
        return 0
    if args.load < 0 or args.steps < 1:
        ap.error("--load must be >= 0 and --steps >= 1")
    for fmu in args.fmu:
        if not fmu.is_file():
            ap.error(f"--fmu {fmu}: no such file")
    for fmu in args.fmu or [None]:
        ul = process.under_load(args.steps, args.load or None, fmu)
        print(f"{fmu or 'SpurDifferential.fmu of this checkout'}:")
        for what in ("quiet", "loaded"):
            r = ul[what]
            print(f"  {what:7s} set+doStep+get: this process {r['in']['set+doStep+get']:.1f} us, own process "
                  f"{r['out']['set+doStep+get']:.1f} us (ratio {ul['ratio_' + what]:.2f}x), own process stepping "
                  f"there {r['out-model']['set+doStep+get']:.1f} us (ratio {ul['ratio_model_' + what]:.2f}x)"
                  + (f" (beside {ul['load']} spinning processes, {os.cpu_count()} cores)" if what == "loaded" else ""))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
