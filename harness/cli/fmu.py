"""``spurdiff fmu NAME [--fmi-version 2|3]``: the path of a built FMU (built first if needed), for scripts and other hosts."""
from __future__ import annotations

import argparse
from pathlib import Path

from harness.cli import fail


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="spurdiff fmu", description="print the path of a built FMU, building it if needed")
    p.add_argument("name", help="SpurDifferential, WheelLoad or Vehicle")
    p.add_argument("--out", type=Path, default=None, help="build into DIR instead of the default place")
    p.add_argument("--fmi-version", dest="fmi_version", type=int, choices=(2, 3), default=2,
                   help="2: NAME.fmu (FMI 2.0, the default); 3: NAME-fmi3.fmu (FMI 3.0 co-simulation)")
    args = p.parse_args(argv)
    from harness.build.fmu import FMUS, BuildError
    from harness.build.fmu3 import build_versions
    if args.name not in FMUS:
        return fail("spurdiff", f"unknown FMU {args.name!r}; allowed: {', '.join(FMUS)}")
    try:
        (path,) = build_versions([args.name], args.out, quiet=True, versions=(args.fmi_version,))
    except BuildError as e:
        return fail("spurdiff", str(e))
    print(path)
    return 0
