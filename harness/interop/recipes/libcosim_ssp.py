"""An SSP file (SystemStructure.ssd plus the FMUs, as `spurdiff export-ssp` or `spurdiff starter
--host ssp` writes it) run by libcosim (docs/use-the-fmu.md).

libcosim reads the system from the SSP: the components, their connections, the start values
(parameter bindings) and, from the osp:FixedStepAlgorithm annotation, the communication step. It
steps every FMU at that step (Jacobi: each FMU gets its inputs from the others' outputs at the
step's start). Shaft coupling wheel (the differential owns the half-shafts) runs at the 5 ms the
scene uses; shaft coupling torque needs 0.2 ms.

Run:  python libcosim_ssp.py SYSTEM.ssp [--stop T] [--show comp.var ...]
Prints the means over the last 40 % of the run of the shaft torques and the locking torque (or of
the variables given with --show). Needs libcosimpy only (pip install libcosimpy).
"""
from __future__ import annotations

import argparse
import sys
import xml.etree.ElementTree as ET
import zipfile

SHOW = ["diff.leftShaft.tau", "diff.rightShaft.tau", "diff.lockingTorque", "diff.carrier.w"]
NANO = 1_000_000_000


def ssp_timing(path: str) -> tuple[float, float]:
    """Stop time and step from the SSP's SystemStructure.ssd."""
    with zipfile.ZipFile(path) as z:
        root = ET.fromstring(z.read("SystemStructure.ssd"))
    stop = step = None
    for el in root.iter():
        tag = el.tag.rsplit("}", 1)[-1]
        if tag == "DefaultExperiment" and el.get("stopTime"):
            stop = float(el.get("stopTime"))
        if tag == "FixedStepAlgorithm" and el.get("baseStepSize"):
            step = float(el.get("baseStepSize"))
    if step is None:
        raise SystemExit(f"{path}: no osp:FixedStepAlgorithm baseStepSize in SystemStructure.ssd")
    return stop, step


def run(path: str, stop: float | None, show: list[str]) -> dict[str, float]:
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.WARNING)    # libcosim logs every FMI call otherwise
    ssp_stop, step = ssp_timing(path)
    stop = stop or ssp_stop
    execution = CosimExecution.from_ssp_file(path)
    slaves = {s.name.decode(): s.index for s in execution.slave_infos()}
    refs = []
    for name in show:
        comp, _, var = name.partition(".")
        v = next(v for v in execution.slave_variables(slaves[comp]) if v.name.decode() == var)
        refs.append((slaves[comp], v.reference))
    n = int(round(stop / step))
    series = CosimObserver.create_time_series(buffer_size=n + 1)
    execution.add_observer(series)
    for idx, ref in refs:
        series.start_time_series(idx, ref, CosimVariableType.REAL)
    if not execution.step(n):
        raise SystemExit(f"libcosim stopped at t = {execution.status().current_time / NANO:g} s")
    out = {}
    for name, (idx, ref) in zip(show, refs):
        times, _, values = series.time_series_real_samples(idx, ref, 1, n)   # steps 1 to n (t > 0)
        kept = [v for t, v in zip(times, values) if t >= 0.6 * stop * NANO - 1]
        out[name] = sum(kept) / len(kept)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("ssp", help="the SSP file")
    ap.add_argument("--stop", type=float, help="stop time, s (default: the SSP's)")
    ap.add_argument("--show", nargs="+", default=SHOW, metavar="COMP.VAR", help="Real variables to report")
    args = ap.parse_args(argv)
    means = run(args.ssp, args.stop, args.show)
    print(f"{args.ssp}: means over the last 40 % of the run")
    for name, value in means.items():
        print(f"  {name:24s} {value:.6f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
