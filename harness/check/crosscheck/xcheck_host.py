"""Worker side of ``spurdiff check --cross-check``: one co-simulation run of an FMU with a cross-check
folder's options and inputs, in one of the kit's hosts, written as a cross-check CSV.

Hosts:

``fmpy``
    :func:`fmpy.simulate_fmu` (co-simulation) with StartTime, StopTime, RelTol and StepSize (as output
    interval; ``StepSize, 0``, "variable step", leaves fmpy its own choice) and the input table.
``spurdiff``
    the kit's own master loop on :class:`harness.fmi.instance.Instance`: fmi2Instantiate; a tunable
    parameter the input table holds, at its StartTime value (FMI 2.0 2.1.6: "Before calling this function,
    all variables with attribute <ScalarVariable initial = "exact" or "approx"> can be set"; no other
    start value is set: the FMU has its own); fmi2SetupExperiment (tolerance, start time, stop time defined); fmi2EnterInitializationMode; the
    inputs at StartTime; fmi2ExitInitializationMode; then communication points StartTime + k h (h:
    StepSize; ``StepSize, 0`` means the reference came from a variable-step solver, and the host then
    steps as finely as the FMU suggests, its DefaultExperiment's stepSize, else (StopTime - StartTime) /
    2000: an FMU that integrates with its communication step, as Test-FMUs' VanDerPol does, comes close
    to the reference only with small steps), the last
    step shortened to end at StopTime when the FMU can vary its step (otherwise the run ends at the last
    regular point, as fmpy's does). Before each step the inputs at its start: continuous Real inputs
    interpolated linearly (after a repeated time, its last row), every other input (and a tunable
    parameter the table holds) the last row at or before that time. After each step the columns are read.

The CSV holds the columns asked for that the FMU has, time first; Booleans as 0/1.
"""
from __future__ import annotations

import math

from .formats import read_cross_check_csv, write_cross_check_csv
from ..report import FAIL, PASS

AUTO_STEPS = 2000         # communication steps when neither _ref.opt nor the FMU gives a step size
READABLE = ("Real", "Integer", "Enumeration", "Boolean")


def _columns(md, wanted):
    by_name = {v.name: v for v in md.modelVariables}
    if wanted:
        return [by_name[n] for n in wanted if n in by_name and by_name[n].type in READABLE]
    return [v for v in md.modelVariables if v.causality == "output" and v.type in READABLE]


def _signals(md, in_csv):
    """(names, rows) of the input table restricted to inputs and tunable variables of the FMU."""
    if not in_csv:
        return [], []
    names, rows = read_cross_check_csv(in_csv)
    by_name = {v.name: v for v in md.modelVariables}
    keep = [i for i, n in enumerate(names) if i == 0 or (n in by_name and (
        by_name[n].causality == "input" or by_name[n].variability == "tunable"))]
    return [names[i] for i in keep], [[r[i] for i in keep] for r in rows]


def _run_fmpy(md, payload, columns, names, rows):
    import numpy as np
    from fmpy import simulate_fmu
    start, stop, step, tol = payload["opt"]
    signals = None
    if names:
        types = {v.name: v.type for v in md.modelVariables}
        dtype = [("time", np.float64)] + [(n, {"Real": np.float64, "Boolean": np.bool_}.get(types[n], np.int32))
                                          for n in names[1:]]
        signals = np.array([tuple(r) for r in rows], dtype=dtype)
    res = simulate_fmu(payload["fmu"], validate=False, fmi_type="CoSimulation", start_time=start, stop_time=stop,
                       output_interval=step if step > 0 else None, relative_tolerance=tol, input=signals,
                       output=[v.name for v in columns])
    return [[float(res["time"][i])] + [float(res[v.name][i]) for v in columns] for i in range(len(res))]


def _input_at(t: float, names, rows, continuous):
    """The input row at ``t`` (see the module docstring)."""
    import bisect
    times = [r[0] for r in rows]
    j = bisect.bisect_right(times, t) - 1          # last row at or before t (after a repeated time)
    if j < 0:
        return dict(zip(names[1:], rows[0][1:]))
    out = dict(zip(names[1:], rows[j][1:]))
    if j + 1 < len(rows) and rows[j + 1][0] > rows[j][0]:
        a, b = rows[j], rows[j + 1]
        w = (t - a[0]) / (b[0] - a[0])
        for k, n in enumerate(names[1:], 1):
            if n in continuous:
                out[n] = a[k] + w * (b[k] - a[k])
    return out


def _typed(v, x):
    return bool(x) if v.type == "Boolean" else (int(round(x)) if v.type in ("Integer", "Enumeration") else float(x))


def _run_spurdiff(md, payload, columns, names, rows, trace):
    from harness.fmi.instance import Instance
    start, stop, step, tol = payload["opt"]
    de = md.defaultExperiment
    h = step if step > 0 else (float(de.stepSize) if de is not None and de.stepSize and float(de.stepSize) > 0
                               else (stop - start) / AUTO_STEPS)
    by_name = {v.name: v for v in md.modelVariables}
    inputs = {n: by_name[n] for n in names[1:]}
    continuous = {n for n, v in inputs.items() if v.type == "Real" and v.causality == "input"
                  and v.variability == "continuous"}
    table_at = (lambda t: _input_at(t, names, rows, continuous)) if names else (lambda t: {})
    first = table_at(start)
    early = {n: x for n, x in first.items() if inputs[n].causality != "input"}   # tunable parameters
    inst = Instance("xcheck", unzipdir=payload["fmu"], md=md, kind="cs", trace=trace, instantiate=False)
    inst.instantiate()
    if early:
        inst.set_values({n: _typed(by_name[n], x) for n, x in early.items()}, " start values")
    inst.call(f"fmi2SetupExperiment(tolerance={tol:g}, startTime={start:g}, stopTime={stop:g})",
              inst.slave.setupExperiment, tol if tol > 0 else None, start, stop)
    inst.call("fmi2EnterInitializationMode", inst.slave.enterInitializationMode)
    ins0 = {n: _typed(inputs[n], x) for n, x in first.items() if inputs[n].causality == "input"}
    if ins0:
        inst.set_values(ins0, " inputs")
    inst.call("fmi2ExitInitializationMode", inst.slave.exitInitializationMode)
    variable = bool(md.coSimulation.canHandleVariableCommunicationStepSize)
    t, k = start, 0
    out = [[t] + inst.read(columns, "columns")]
    span_eps = 1e-9 * max(abs(stop - start), 1e-300)
    while t < stop - span_eps:
        t_next = start + (k + 1) * h
        if t_next > stop + span_eps:
            if not variable:
                break
            t_next = stop
        elif abs(t_next - stop) <= span_eps:
            t_next = stop
        ins = table_at(t)
        if ins:
            inst.set_values({n: _typed(inputs[n], x) for n, x in ins.items()})
        inst.do_step(t, t_next - t)
        t, k = t_next, k + 1
        out.append([t] + inst.read(columns, "columns"))
    inst.terminate()
    inst.free()
    return out


def run_host(payload: dict, trace) -> tuple[str, str]:
    """Simulate ``payload["fmu"]`` (an unpacked FMU) in ``payload["host"]`` and write ``payload["out_csv"]``."""
    from fmpy import read_model_description
    md = read_model_description(payload["fmu"], validate=False)
    if md.coSimulation is None:
        return FAIL, "the FMU has no co-simulation interface"
    columns = _columns(md, payload.get("columns"))
    names, rows = _signals(md, payload.get("in_csv"))
    start, stop, step, _ = payload["opt"]
    trace(f"{payload['host']} run t = {start!r} .. {stop!r} s, step {step!r} s")
    if payload["host"] == "fmpy":
        out = _run_fmpy(md, payload, columns, names, rows)
    else:
        out = _run_spurdiff(md, payload, columns, names, rows, trace)
    as_int = [v.type != "Real" for v in columns]
    write_cross_check_csv(payload["out_csv"], ["time"] + [v.name for v in columns],
                          [[r[0]] + [int(x) if i and math.isfinite(x) else x for i, x in zip(as_int, r[1:])]
                           for r in out])
    return PASS, f"{len(out)} rows, {len(columns)} columns, t = {out[0][0]:.9g} .. {out[-1][0]:.9g} s"
