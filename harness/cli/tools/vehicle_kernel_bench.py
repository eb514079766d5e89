"""``python -m harness.cli.tools.vehicle_kernel_bench``: the car's and the wheel's compiled steps against their
Python reference on vehicle-cornering, A/B interleaved (:mod:`harness.measure.bench.vehicle_kernel`)."""
from __future__ import annotations

import sys

from harness.cli.tools.rigid_kernel_bench import kernel_bench


def main(argv: list[str] | None = None) -> int:
    return kernel_bench("vehicle_kernel", argv)


if __name__ == "__main__":
    sys.exit(main())
