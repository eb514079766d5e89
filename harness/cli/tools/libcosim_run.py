"""The command line of the libcosim runner's child process (:func:`harness.interop.libcosim_run.run_ssp`
starts ``python -m harness.cli.tools.libcosim_run``): run an SSP file with libcosim, write the recorded
trajectories. Not a ``spurdiff`` command."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    """``python -m harness.cli.tools.libcosim_run SSP [--record C.V ...] [--step H] [--duration T] --out FILE``."""
    ap = argparse.ArgumentParser(prog="python -m harness.cli.tools.libcosim_run",
                                 description="Run an SSP file with libcosim (fixed step, Jacobi) and write the recorded trajectories")
    ap.add_argument("ssp", help="SSP file (e.g. from `spurdiff export-ssp`)")
    ap.add_argument("--record", nargs="*", help="component.variable names (default: the recording list in the SSP)")
    ap.add_argument("--step", type=float, help="communication step, s (default: the SSP's osp:FixedStepAlgorithm)")
    ap.add_argument("--duration", type=float, help="simulated time, s (default: the SSP's stopTime)")
    ap.add_argument("--out", required=True, help="result file: .npz (names, data, step, failure) or .csv")
    args = ap.parse_args(argv)
    from harness.interop.libcosim_run import LibcosimError, run_here
    try:
        res = run_here(args.ssp, args.record, args.step, args.duration)
    except LibcosimError as e:
        print(f"libcosim_run: {e}", file=sys.stderr)
        return 2
    from harness.common.outputs import OutputError, atomic_file

    out = Path(args.out)
    try:
        with atomic_file(out, "wb") as fh:   # no link followed; a full or read-only place is one line
            if out.suffix == ".csv":
                np.savetxt(fh, res.data, fmt="%.17g", delimiter=",", header=",".join(["time"] + res.names),
                           comments="")
            else:
                np.savez(fh, names=np.array(res.names), data=res.data, step=res.step, failure=res.failure or "")
    except OutputError as e:
        print(f"libcosim_run: {e}", file=sys.stderr)
        return 1
    if res.failure:
        print(f"libcosim_run: {res.failure}", file=sys.stderr)
    sys.stdout.flush()
    sys.stderr.flush()
    return 1 if res.failure else 0


if __name__ == "__main__":
    sys.exit(main())
