"""``python -m harness.cli.tools.fmi3_features [--foh SCENE...] [--early SCENE...] [--steps MS...] [--out FILE]``:
what the FMI 3.0 features of the harness's FMI 3.0 master change (:mod:`harness.measure.fmi3_features`):
first-order hold with the FMUs' output derivatives against zero-order hold (Gauss-Seidel and
Jacobi), and early return at the differential's stick/slip switches, in accuracy against a
0.5 ms reference and in CPU time; prints the table (markdown) and writes it to ``--out``."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    from harness.cli import fail
    from harness.measure.fmi3_features import ER_VARIANTS, FOH_VARIANTS, markdown, measure
    from harness.scene.spec import SceneError

    p = argparse.ArgumentParser(prog="python -m harness.cli.tools.fmi3_features",
                                description="measure first-order hold and early return with the FMI 3.0 FMUs")
    p.add_argument("--foh", nargs="*", default=["vehicle-cornering", "tip-in-tip-out"],
                   help="scenes for zero- against first-order hold")
    p.add_argument("--early", nargs="*", default=["split-mu-launch", "wheel-lift"],
                   help="scenes for early return (they must have stick/slip switches)")
    p.add_argument("--steps", nargs="*", type=float, default=[5.0, 10.0], help="communication steps, ms")
    p.add_argument("--duration", type=float, default=None, help="simulated time per scene, s (default: the scene's)")
    p.add_argument("--repeats", type=int, default=3, help="runs per point for the CPU time (median)")
    p.add_argument("--out", type=Path, default=None, help="also write the table here")
    args = p.parse_args(argv)
    if not args.steps or not all(0.0 < s < float("inf") for s in args.steps):
        p.error(f"--steps must be > 0 ms, got {args.steps}")
    if args.repeats < 1:
        p.error(f"--repeats must be >= 1, got {args.repeats}")
    steps = [s * 1e-3 for s in args.steps]
    rows = []
    try:
        for name in args.foh:
            rows += measure(name, steps, FOH_VARIANTS, duration=args.duration, repeats=args.repeats,
                            log=lambda m: print(m, file=sys.stderr))
        for name in args.early:
            rows += measure(name, steps, ER_VARIANTS, duration=args.duration, repeats=args.repeats,
                            log=lambda m: print(m, file=sys.stderr))
    except (SceneError, RuntimeError) as e:
        return fail("fmi3_features", str(e), 1)
    cmd = "python -m harness.cli.tools.fmi3_features" + ("" if argv is None else " " + " ".join(argv))
    if argv is None:
        cmd = "python -m harness.cli.tools.fmi3_features " + " ".join(sys.argv[1:])
    text = markdown(rows, cmd.strip())
    print(text)
    if args.out:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
