"""``python -m harness.cli.tools.coupling_bench``: the vehicle scenes at 1 to 20 ms against the old coupling
at 0.2 ms (issue 19 item 2; :mod:`harness.measure.bench.coupling`)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    from harness.measure.bench import coupling

    ap = argparse.ArgumentParser(prog="python -m harness.cli.tools.coupling_bench", description=coupling.__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenes", nargs="*", default=list(coupling.WINDOWS), help="scenes (default: all five)")
    ap.add_argument("--steps", default="1e-3,5e-3,1e-2,2e-2", help="communication steps, s, comma-separated")
    ap.add_argument("--fresh", action="store_true", help="recompute the reference runs")
    ap.add_argument("--cache", type=Path, default=None,
                    help="file of the reference means (JSON; default ./results/coupling_refs.json)")
    a = ap.parse_args(argv)
    try:
        steps = coupling.parse_steps(a.steps)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return coupling.run(a.scenes, steps, a.fresh, a.cache)


if __name__ == "__main__":
    sys.exit(main())
