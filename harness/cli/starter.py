"""``spurdiff starter --host fmpy|c|ssp --interface wheel|torque``: write a ready-to-run starting
point for SpurDifferential.fmu in your own tool (:mod:`harness.interop.starter`, docs/use-the-fmu.md)."""
from __future__ import annotations

import argparse
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    from harness.interop.starter import HOSTS, INTERFACES, write_starter

    ap = argparse.ArgumentParser(prog="spurdiff starter", description="write a ready-to-run starter for "
                                 "SpurDifferential.fmu in your own tool (docs/use-the-fmu.md)")
    ap.add_argument("--host", choices=HOSTS, default="fmpy", help="fmpy script, C host, or SSP for libcosim (default fmpy)")
    ap.add_argument("--interface", choices=INTERFACES, default="wheel",
                    help="shaftCoupling: wheel (the FMU owns the half-shafts, steps to 20 ms; default) or torque "
                         "(your host owns them, steps to about 0.45 ms)")
    ap.add_argument("--out", type=Path, default=None, help="folder to write (default ./spurdiff-starter-HOST-INTERFACE)")
    ap.add_argument("--duration", type=float, default=None, help="stop time, s (default: the recipe's)")
    args = ap.parse_args(argv)
    out = args.out or Path(f"spurdiff-starter-{args.host}-{args.interface}")
    files, command = write_starter(args.host, args.interface, out, args.duration)
    for f in files:
        print(f"wrote {f}")
    print(f"run it:  cd {out} && {command}")
    return 0
