"""``python -m harness.cli.tools.mesh_bench``: the measurements behind docs/mesh-dynamics.md (the compiled
kernel against the Python reference, the paper's two cases at each mesh level, the tolerance
sweep, the comparison with scipy's solve_ivp; :mod:`harness.measure.bench.mesh`)."""
from __future__ import annotations

import argparse
import sys

SECTIONS = ("paper", "tolerance", "ivp", "kernel", "step-bound", "methods", "tight")


def main(argv: list[str] | None = None) -> int:
    from harness.measure.bench import mesh

    ap = argparse.ArgumentParser(prog="python -m harness.cli.tools.mesh_bench", description=mesh.__doc__)
    ap.add_argument("--full", action="store_true", help="also cornering with all effects (slow: tens of s)")
    ap.add_argument("--section", choices=SECTIONS, action="append",
                    help="default: paper, tolerance, ivp, kernel; step-bound (which error estimate sets the "
                         "step, about 6 s), methods (ROS34PW2 against RODAS5P in the do_step loop, a few "
                         "seconds) and tight (tight tolerances through the mesh-phase boundaries, about 30 s) only when named")
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args(argv)
    mesh.run(a.full, a.section or ["paper", "tolerance", "ivp", "kernel"], a.repeats)
    return 0


if __name__ == "__main__":
    sys.exit(main())
