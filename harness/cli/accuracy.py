"""``spurdiff accuracy``: accuracy versus wall time over fidelities, steps and tolerances, our solver
against scipy's solve_ivp; writes docs/accuracy.md and the stored data ``fidelity = "auto"`` scenes
choose from (:mod:`harness.measure.accuracy`)."""
from __future__ import annotations

import argparse
from pathlib import Path


def build_parser() -> argparse.ArgumentParser:
    from harness.measure.accuracy import stored_files

    ap = argparse.ArgumentParser(prog="spurdiff accuracy", description="accuracy versus wall time, measured")
    ap.add_argument("scenes", nargs="*", help="scenes (default: all in the grid file)")
    ap.add_argument("--quick", action="store_true", help="the grid's small 'quick' subset (for tests)")
    ap.add_argument("--out", type=Path, default=None,
                    help="where accuracy.md and accuracy.png go (default: docs/ in a checkout, else ./results/docs)")
    ap.add_argument("--data", type=Path, default=stored_files()[0], help="stored data for fidelity = auto")
    ap.add_argument("--no-ivp", action="store_true", help="skip the solve_ivp baseline (a few minutes)")
    ap.add_argument("--only-ivp", action="store_true",
                    help="run only the solve_ivp baseline; the stored scene data stay as they are")
    ap.add_argument("--render", action="store_true",
                    help="only rewrite docs/accuracy.md and .png from the stored data (no runs)")
    return ap


def main(argv: list[str] | None = None) -> int:
    from harness.measure.accuracy import run
    return run(build_parser().parse_args(argv))
