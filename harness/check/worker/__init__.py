"""Inside a check process: the FMI session and the call-sequence rules, and :func:`worker_main`, the entry point
:mod:`harness.check.processes.isolation` starts (run one rule, write its outcome).

* :mod:`.fmi2`, :mod:`.fmi3`: one FMU instance of each version through fmpy, every call traced, with the same
  methods (initialize, run, outputs, state calls...), so a rule that means the same in both versions is one
  function;
* :mod:`.tasks`: every task by id (rule ids of kinds cs, me, cs3, me3, and "reference");
* the rules: :mod:`.cs_lifecycle` (the life of an instance), :mod:`.cs_state` (instances and FMU state),
  :mod:`.cs_steps` (the steps and the calls around them), :mod:`.me` (model exchange), :mod:`.cs3` and
  :mod:`.me3` (what only FMI 3.0 has).

May import: :mod:`harness.check.report`, :mod:`harness.check.rules`, :mod:`harness.check.crosscheck.formats`,
:mod:`harness.check.crosscheck.reference_task`, :mod:`harness.fmi` and fmpy; never the parent-side modules.
"""
from __future__ import annotations

import json
import os
import sys
from typing import Sequence

from ..report import FAIL


def worker_main(argv: Sequence[str]) -> None:
    """``task payload-json trace-file result-file``: writes {"status", "reason"[, "severity", "facts"]} as
    JSON to the result file, then leaves with ``os._exit`` (no interpreter teardown touching the
    FMU again, e.g. after fmi2Fatal)."""
    from .fmi2 import CallFailed, Tracer
    from .tasks import run_task
    task, payload_json, trace_path, result_path = argv
    try:
        import resource
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))  # a crashing FMU leaves no core file
    except Exception:
        pass
    tracer = Tracer(trace_path)
    payload = json.loads(payload_json)
    try:
        out = run_task(task, payload, tracer)
    except CallFailed as e:
        out = (FAIL, str(e))
    except Exception as e:   # an FMI 3.0 call refused (driver3.Call3Failed) reads like a 2.0 one
        from .fmi3 import Call3Failed
        out = (FAIL, str(e) if isinstance(e, Call3Failed) else f"{type(e).__name__}: {e}")
    facts = out[-1] if isinstance(out[-1], dict) else {}
    out = out[:-1] if facts or isinstance(out[-1], dict) else out
    data = {"status": out[0], "reason": out[1]}
    if len(out) > 2 and out[2]:
        data["severity"] = out[2]
    if facts:
        data["facts"] = facts
    with open(result_path, "w", encoding="utf-8") as f:
        json.dump(data, f)
        f.flush()
        os.fsync(f.fileno())
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)
