"""``spurdiff build`` (= ``python build_fmu.py``): build the project's FMUs and say where."""
from __future__ import annotations

import argparse
from pathlib import Path

from harness.cli import fail


def main(argv: list[str] | None = None) -> int:
    from harness.build import FMUS, BuildError, build

    ap = argparse.ArgumentParser(prog="spurdiff build", description="Build the project's FMUs")
    ap.add_argument("names", nargs="*", help=f"FMUs to build (default: all of {', '.join(FMUS)})")
    ap.add_argument("--out", "--dest", dest="dest", type=Path, default=None,
                    help="output directory (default: build/fmus in a checkout, else the per-user cache)")
    ap.add_argument("--force", action="store_true", help="rebuild even if up to date")
    args = ap.parse_args(argv)
    try:
        paths = build(args.names or None, args.dest, args.force)
        print(f"FMUs in {paths[0].parent}" if paths else "nothing to build")
    except BuildError as e:
        return fail("spurdiff build", str(e))
    return 0
