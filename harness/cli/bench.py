"""``spurdiff bench``: measured cost ratios (FMI versus direct physics, each effect versus rigid,
real-time factors), printed, never asserted (:mod:`harness.measure.bench`)."""
from __future__ import annotations

import argparse


def build_parser() -> argparse.ArgumentParser:
    from harness.measure.bench import core

    ap = argparse.ArgumentParser(prog="spurdiff bench", description=core.__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--levels", nargs="*", default=None, choices=list(core.EFFECT_SETS), metavar="SETTING",
                    help=f"fidelity settings to compare (default: all: {', '.join(core.EFFECT_SETS)})")
    ap.add_argument("--write", type=str, default=None, metavar="FILE.md",
                    help="also write the report as Markdown (e.g. docs/performance.md)")
    return ap


def main(argv: list[str] | None = None) -> int:
    from harness.measure.bench.report import run
    return run(build_parser().parse_args(argv))
