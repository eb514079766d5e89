"""Parent side of the call-sequence rules (kinds ``cs`` and ``me``): schedule each rule of each FMU
in its own process (:mod:`.isolation`), ``jobs`` at a time.

The FMU is unpacked once (within the limits of :mod:`.archive`) and every rule's process loads
the binary from there. ``cs.basic`` and ``me.basic`` run first; when one fails, the other rules
of that interface are SKIPped (they would all fail for the same reason).
"""
from __future__ import annotations

import os
import shutil
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from .archive import ArchiveError, extract
from .isolation import run_isolated
from .report import FAIL, SKIP, CheckResult
from .rules import BY_ID, rules

GATES = {"cs": "cs.basic", "me": "me.basic"}


@dataclass
class LifecycleOptions:
    """How the call-sequence rules are run.

    ``steps``: doSteps per short run (cs.basic, reset, state rules...); ``timeout``: wall-clock
    limit per rule process, s; ``jobs``: rule processes at once; ``profiles``: opt-in profiles.
    """

    steps: int = 10
    timeout: float = 60.0
    jobs: int = max(1, os.cpu_count() or 1)
    profiles: tuple[str, ...] = ()


def lifecycle_rules(kinds: Sequence[str], profiles: tuple[str, ...] = ()) -> list[str]:
    return [r.id for k in ("cs", "me") if k in kinds for r in rules(k, profiles)]


def run_lifecycle_checks_many(fmus: Sequence[tuple[str | Path, str, Sequence[str]]],
                              options: LifecycleOptions | None = None,
                              checks: Sequence[str] | None = None) -> dict[str, list[CheckResult]]:
    """Call-sequence rules for several FMUs. ``fmus`` holds (path, subject, kinds[, rule ids]) with
    kinds a subset of ("cs", "me"): the interfaces the FMU offers. ``checks`` (or an FMU's own rule
    ids) restricts the rules run; the gates cs.basic / me.basic run whenever they are included.
    Returns subject -> results in rule order."""
    options = options or LifecycleOptions()
    unzipped: dict[str, Path] = {}
    plan: dict[str, list[str]] = {}
    out: dict[str, dict[str, CheckResult]] = {}

    def result(subject, rule_id, status, reason, duration=0.0, severity=None) -> CheckResult:
        sev = severity or BY_ID[rule_id].effective_severity(options.profiles)
        return CheckResult(subject, rule_id, status, reason, duration, sev)

    def run_one(subject: str, rule_id: str) -> CheckResult:
        t0 = time.perf_counter()
        payload = {"unzipdir": str(unzipped[subject]), "steps": options.steps}
        status, reason, severity = run_isolated(rule_id, payload, options.timeout)
        return result(subject, rule_id, status, reason, time.perf_counter() - t0, severity)

    try:
        for path, subject, kinds, *own in fmus:
            only = own[0] if own else checks
            ids = [c for c in lifecycle_rules(kinds, options.profiles) if only is None or c in only]
            plan[subject] = ids
            out[subject] = {}
            try:
                unzipped[subject] = extract(path)
            except ArchiveError as e:
                for c in ids:
                    out[subject][c] = result(subject, c, FAIL, f"the FMU could not be unpacked: {e}")
        with ThreadPoolExecutor(max_workers=max(1, options.jobs)) as pool:
            first = [(s, c) for s, ids in plan.items() if s in unzipped for c in ids if c in GATES.values()]
            for (s, c), res in zip(first, pool.map(lambda j: run_one(*j), first)):
                out[s][c] = res
            jobs = []
            for s, ids in plan.items():
                if s not in unzipped:
                    continue
                for c in ids:
                    if c in out[s]:
                        continue
                    gate = GATES[c.split(".", 1)[0]]
                    if gate in out[s] and out[s][gate].failed:
                        out[s][c] = result(s, c, SKIP, f"needs {gate}, which failed")
                    else:
                        jobs.append((s, c))
            for (s, c), res in zip(jobs, pool.map(lambda j: run_one(*j), jobs)):
                out[s][c] = res
    finally:
        for d in unzipped.values():
            shutil.rmtree(d, ignore_errors=True)
    return {s: [out[s][c] for c in ids] for s, ids in plan.items()}


def run_lifecycle_checks(fmu_path: str | Path, subject: str | None = None, options: LifecycleOptions | None = None,
                         kinds: Sequence[str] = ("cs",)) -> list[CheckResult]:
    """All call-sequence rules of ``kinds`` for one FMU."""
    subject = subject if subject is not None else str(fmu_path)
    return run_lifecycle_checks_many([(fmu_path, subject, kinds)], options)[subject]


def run_model_exchange(fmu_path: str | Path, out_csv: str | Path, timeout: float = 600.0,
                       steps: int = 10) -> CheckResult:
    """``me.basic`` on one FMU (in a fresh process), writing time and the outputs after every
    explicit Euler step to ``out_csv`` (cross-check CSV): the run compared with the FMU Compliance
    Checker's ``-k me`` output."""
    t0 = time.perf_counter()
    try:
        unzipdir = extract(fmu_path)
    except ArchiveError as e:
        return CheckResult(str(fmu_path), "me.basic", FAIL, f"the FMU could not be unpacked: {e}")
    try:
        payload = {"unzipdir": str(unzipdir), "steps": steps, "out_csv": str(Path(out_csv).resolve())}
        status, reason, severity = run_isolated("me.basic", payload, timeout)
    finally:
        shutil.rmtree(unzipdir, ignore_errors=True)
    return CheckResult(str(fmu_path), "me.basic", status, reason, time.perf_counter() - t0, severity or "error")
