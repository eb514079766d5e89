"""``python -m harness.cli.tools.fmi_versions [SCENE...] [--duration S]``: each scene (default: all) run
with the FMI 2.0 FMUs and with the FMI 3.0 ones; prints the largest difference of the recorded
results per scene (:mod:`harness.measure.fmi_versions`). Exit 1 when a difference exceeds ``--tolerance``
(default 1e-12, relative to each variable's largest magnitude) or only one version failed."""
from __future__ import annotations

import argparse

from harness.cli import fail


def main(argv: list[str] | None = None) -> int:
    from harness.measure.fmi_versions import compare, scene_names

    p = argparse.ArgumentParser(prog="python -m harness.cli.tools.fmi_versions",
                                description="compare each scene's results with the FMI 2.0 and the FMI 3.0 FMUs")
    p.add_argument("scenes", nargs="*", help="scene names (default: every scene)")
    p.add_argument("--duration", type=float, default=None, help="simulated time per scene, s (default: the scene's)")
    p.add_argument("--tolerance", type=float, default=1e-12, help="largest relative difference accepted")
    args = p.parse_args(argv)
    names = args.scenes or scene_names()
    bad = 0
    print(f"{'scene':<24} {'samples':>7} {'vars':>4}  {'max |3.0-2.0|':>13}  {'max rel':>9}  "
          f"{'wall 2.0':>8}  {'wall 3.0':>8}  failure")
    for name in names:
        c = compare(name, duration=args.duration)
        ok = c.max_rel <= args.tolerance and c.same_failure
        bad += not ok
        failure = "" if c.failure2 is None and c.failure3 is None else f"2.0: {c.failure2} | 3.0: {c.failure3}"
        print(f"{name:<24} {c.samples:>7} {c.variables:>4}  {c.max_abs:>13.3g}  {c.max_rel:>9.3g}  "
              f"{c.wall2:>7.3f}s  {c.wall3:>7.3f}s  {'' if ok else 'DIFFERS '}{failure}")
    if bad:
        return fail("fmi_versions", f"{bad} of {len(names)} scenes differ by more than {args.tolerance:g}", 1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
