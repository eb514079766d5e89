"""``python -m harness.cli.vehicle_kernel_bench``: the car's and the wheel's compiled steps against their
Python reference on vehicle-cornering, A/B interleaved (:mod:`harness.measure.bench.vehicle_kernel`)."""
from __future__ import annotations

import argparse
import sys


def main(argv: list[str] | None = None) -> int:
    from harness.measure.bench import vehicle_kernel

    ap = argparse.ArgumentParser(prog="python -m harness.cli.vehicle_kernel_bench",
                                 description=vehicle_kernel.__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5, help="interleaved rounds; the fastest counts (default 5)")
    a = ap.parse_args(argv)
    if a.rounds < 1:
        ap.error(f"--rounds must be >= 1, got {a.rounds}")
    return vehicle_kernel.run(a.rounds)


if __name__ == "__main__":
    sys.exit(main())
