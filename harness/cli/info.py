"""``spurdiff info`` (= ``python -m harness.cli.info``): derived gear geometry, design-check findings, the
paper's theory table beside ours; ``breakaway``: the breakaway torques of both fidelity levels."""
from __future__ import annotations

import argparse
import sys


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="spurdiff info", description="derived geometry, design checks and the "
                                                                   "paper's theory table beside ours")
    ap.add_argument("table", nargs="?", choices=["breakaway"],
                    help="breakaway: the torque at which each fidelity level breaks away, beside K T0")
    args = ap.parse_args(argv)
    from harness.measure.info import breakaway_table, info_text
    print(breakaway_table() if args.table == "breakaway" else info_text())
    return 0


if __name__ == "__main__":
    sys.exit(main())
