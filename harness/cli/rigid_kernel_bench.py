"""``python -m harness.cli.rigid_kernel_bench``: the rigid level's compiled kernel against its Python
reference on vehicle-cornering, A/B interleaved (:mod:`harness.measure.bench.rigid_kernel`)."""
from __future__ import annotations

import argparse
import sys


def main(argv: list[str] | None = None) -> int:
    from harness.measure.bench import rigid_kernel

    ap = argparse.ArgumentParser(prog="python -m harness.cli.rigid_kernel_bench",
                                 description=rigid_kernel.__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5, help="interleaved rounds; the fastest counts (default 5)")
    a = ap.parse_args(argv)
    if a.rounds < 1:
        ap.error(f"--rounds must be >= 1, got {a.rounds}")
    return rigid_kernel.run(a.rounds)


if __name__ == "__main__":
    sys.exit(main())
