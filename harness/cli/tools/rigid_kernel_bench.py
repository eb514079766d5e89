"""``python -m harness.cli.tools.rigid_kernel_bench``: the rigid level's compiled kernel against its Python
reference on vehicle-cornering, A/B interleaved (:mod:`harness.measure.bench.rigid_kernel`). Its
:func:`kernel_bench` is the command line of every such A/B bench (``harness.cli.tools.vehicle_kernel_bench``)."""
from __future__ import annotations

import argparse
import importlib
import sys


def kernel_bench(name: str, argv: list[str] | None) -> int:
    """Parse ``--rounds N`` for the A/B kernel bench :mod:`harness.measure.bench` ``.<name>`` and run it."""
    bench = importlib.import_module(f"harness.measure.bench.{name}")
    ap = argparse.ArgumentParser(prog=f"python -m harness.cli.tools.{name}_bench",
                                 description=bench.__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5, help="interleaved rounds; the fastest counts (default 5)")
    a = ap.parse_args(argv)
    if a.rounds < 1:
        ap.error(f"--rounds must be >= 1, got {a.rounds}")
    return bench.run(a.rounds)


def main(argv: list[str] | None = None) -> int:
    return kernel_bench("rigid_kernel", argv)


if __name__ == "__main__":
    sys.exit(main())
