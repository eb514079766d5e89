"""``python -m harness.cli.tools.startup_bench [RUNS] [--against EARLIER.fmu]``: section 8 of
``spurdiff bench`` alone (:mod:`harness.measure.bench.startup`), optionally beside an earlier build."""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    """``[RUNS] [--against EARLIER.fmu]``: the section (RUNS interleaved runs, default 5); with
    ``--against``, an earlier build of SpurDifferential measured in the same interleaved runs (before
    and after a change); the load average before and after."""
    from harness.measure.bench import startup

    ap = argparse.ArgumentParser(prog="python -m harness.cli.tools.startup_bench", description=startup.__doc__)
    ap.add_argument("runs", nargs="?", type=int, default=5)
    ap.add_argument("--against", type=Path, default=None, metavar="EARLIER.fmu")
    a = ap.parse_args(argv)
    if a.runs < 1:
        ap.error(f"runs {a.runs}: allowed 1 or more")
    if a.against is not None and not a.against.is_file():
        ap.error(f"--against {a.against}: no such FMU file")
    load = os.getloadavg()
    print(f"   load average {load[0]:.1f} (1 min), {load[1]:.1f} (5 min) on {os.cpu_count()} cores at the start")
    print("\n".join(startup.report(a.runs, a.against)))
    load = os.getloadavg()
    print(f"   load average {load[0]:.1f} (1 min), {load[1]:.1f} (5 min) on {os.cpu_count()} cores at the end")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
