"""Worker side of :func:`.reference.write_reference_results`: the simulation, in the fresh process
(:mod:`.isolation`), with :func:`fmpy.simulate_fmu`."""
from __future__ import annotations

import math

from .formats import INPUT_TYPES, read_cross_check_csv, write_cross_check_csv
from ..report import FAIL, PASS


def simulate_reference_task(payload: dict, trace) -> tuple[str, str]:
    """Simulate the FMU of ``payload`` and write its reference CSV; (status, reason). A payload with a
    ``host`` is a cross-check run instead (:mod:`.xcheck_host`)."""
    if payload.get("host"):
        from .xcheck_host import run_host
        return run_host(payload, trace)
    import numpy as np
    from fmpy import read_model_description, simulate_fmu
    start, stop, step, rel_tol = payload["experiment"]
    md = read_model_description(payload["fmu"], validate=False)
    outputs = [v for v in md.modelVariables if v.causality == "output" and v.type in INPUT_TYPES]
    if payload.get("columns"):   # the columns of a cross-check reference beside the FMU, any variables
        by_name = {v.name: v for v in md.modelVariables}
        outputs = [by_name[n] for n in payload["columns"] if n in by_name and by_name[n].type in INPUT_TYPES]
    signals = None
    if payload["in_csv"]:
        names, rows = read_cross_check_csv(payload["in_csv"])
        types = {v.name: v.type for v in md.modelVariables}
        dtype = [("time", np.float64)] + [(n, {"Real": np.float64, "Boolean": np.bool_}.get(types[n], np.int32))
                                          for n in names[1:]]
        signals = np.array([tuple(r) for r in rows], dtype=dtype)
    trace(f"fmpy.simulate_fmu(start_time={start!r}, stop_time={stop!r}, output_interval={step!r})")
    fmi_type = "CoSimulation" if md.coSimulation is not None else "ModelExchange"  # ME: fmpy's CVode
    result = simulate_fmu(payload["fmu"], validate=False, fmi_type=fmi_type, start_time=start,
                          stop_time=stop, output_interval=step if step > 0 else None, relative_tolerance=rel_tol,
                          apply_default_start_values=True, input=signals, output=[v.name for v in outputs])
    names = ["time"] + [v.name for v in outputs]
    as_int = {v.name for v in outputs if v.type != "Real"}  # Integer, Enumeration; Boolean as 0/1
    rows = [[int(result[n][i]) if n in as_int else float(result[n][i]) for n in names] for i in range(len(result))]
    write_cross_check_csv(payload["ref_csv"], names, rows)
    if not rows:
        return FAIL, "the simulation gave no rows"
    if not math.isclose(rows[-1][0], stop, rel_tol=1e-9, abs_tol=1e-12):
        # fmpy stops early only when the FMU ends the simulation (fmi2Discard with fmi2Terminated)
        return PASS, (f"{len(rows)} rows, {len(outputs)} outputs, t = {start:g} .. {rows[-1][0]:g} s: the FMU ended "
                      f"the simulation before the stop time {stop:g} s; step {step:g} s")
    return PASS, f"{len(rows)} rows, {len(outputs)} columns, t = {start:g} .. {stop:g} s, step {step:g} s"
