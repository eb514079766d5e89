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
from .processes.isolation import run_isolated, run_isolated_outcome
from .report import FAIL, SKIP, CheckResult
from .rules import BY_ID, RULES, rules

GATES = {"cs": "cs.basic", "me": "me.basic", "cs3": "cs3.basic", "me3": "me3.basic"}
CALL_KINDS = ("cs", "me", "cs3", "me3")   # FMI 2.0 and FMI 3.0 call sequences


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
    return [r.id for k in CALL_KINDS if k in kinds for r in rules(k, profiles)]


# rule -> the rules whose outcome says whether its precondition happened (see :func:`precondition`)
DEPENDS = {
    "cs.status-after-discard": ("cs.stop-time", "cs.default-experiment", "cs.nan-inputs"),
    "cs.free-state": ("cs.get-set-state",),
    "cs.serialize-state": ("cs.get-set-state",),
    "cs3.free-state": ("cs3.get-set-state",),
    "cs3.serialize-state": ("cs3.get-set-state",),
}


def _brief(r: CheckResult) -> str:
    text = r.reason if len(r.reason) <= 70 else r.reason[:67] + "..."
    return f"{r.check_id}: {r.label} ({text})"


def precondition(rule_id: str, done: dict[str, tuple[CheckResult, dict]]) -> tuple[dict | None, str | None]:
    """(payload additions, None) when ``rule_id``'s precondition happened in the rules it depends on,
    else (None, the SKIP reason). ``done`` maps a rule id to (its result, its facts)."""
    if rule_id == "cs.status-after-discard":
        for provider in DEPENDS[rule_id]:
            res, facts = done.get(provider, (None, {}))
            if facts.get("discard"):
                return {"discard": facts["discard"]}, None
        seen = "; ".join(_brief(done[p][0]) for p in DEPENDS[rule_id] if p in done)
        return None, f"precondition not met: no doStep was discarded ({seen})"
    if rule_id in DEPENDS and DEPENDS[rule_id][0].endswith(".get-set-state"):   # free / serialize state
        provider = DEPENDS[rule_id][0]
        res, facts = done.get(provider, (None, {}))
        if res is None or res.status == SKIP or facts.get("restores"):
            return {}, None   # not declared: the rule says so itself
        f = "fmi2" if provider.startswith("cs.") else "fmi3"
        return None, f"precondition not met: {f}SetFMUstate does not restore a saved state ({_brief(res)})"
    return {}, None


def _dedupe_aborts(results: dict[str, CheckResult], aborts: dict[str, dict]) -> None:
    """One crash or hang, one finding: when several rules of an FMU crashed or hung in the same FMI call,
    the rule about that call (the first whose ``calls`` name the function; else the first in rule order)
    reports it and the others are SKIP naming it."""
    by_call: dict[tuple[str, str], list[str]] = {}
    for rid, ab in aborts.items():
        if rid in results and ab.get("call") and ab["call"] != "exit":
            by_call.setdefault((ab["kind"], ab["call"]), []).append(rid)
    order = {r.id: i for i, r in enumerate(rules())}
    for (kind, call), ids in by_call.items():
        if len(ids) < 2:
            continue
        fn = call.split("(", 1)[0].strip()
        ids.sort(key=lambda i: order.get(i, 1 << 30))
        owner = next((i for i in ids if fn and fn in BY_ID[i].calls), ids[0])
        what = {"crash": "crashed", "timeout": "hung (timed out)"}.get(kind, "ended the process")
        for rid in ids:
            if rid != owner:
                r = results[rid]
                results[rid] = CheckResult(r.subject, rid, SKIP, f"precondition not met: {call} {what}, reported by "
                                                                  f"{owner}", r.duration, r.severity)


def run_lifecycle_checks_many(fmus: Sequence[tuple[str | Path, str, Sequence[str]]],
                              options: LifecycleOptions | None = None,
                              checks: Sequence[str] | None = None) -> dict[str, list[CheckResult]]:
    """Call-sequence rules for several FMUs. ``fmus`` holds (path, subject, kinds[, rule ids]) with
    kinds a subset of ("cs", "me"): the interfaces the FMU offers. ``checks`` (or an FMU's own rule
    ids) restricts the rules run; the gates cs.basic / me.basic run whenever they are included.
    A rule of :data:`DEPENDS` runs after the rules it depends on (run unreported when they are not
    selected) and only when its precondition happened. Returns subject -> results in rule order."""
    options = options or LifecycleOptions()
    unzipped: dict[str, Path] = {}
    plan: dict[str, list[str]] = {}
    hidden: dict[str, set[str]] = {}
    out: dict[str, dict[str, CheckResult]] = {}
    facts: dict[str, dict[str, dict]] = {}
    aborts: dict[str, dict[str, dict]] = {}

    def result(subject, rule_id, status, reason, duration=0.0, severity=None) -> CheckResult:
        sev = severity or BY_ID[rule_id].effective_severity(options.profiles)
        return CheckResult(subject, rule_id, status, reason, duration, sev)

    def run_one(job) -> CheckResult:
        subject, rule_id, extra = job
        t0 = time.perf_counter()
        payload = {"unzipdir": str(unzipped[subject]), "steps": options.steps, "timeout": options.timeout, **extra}
        o = run_isolated_outcome(rule_id, payload, options.timeout)
        facts[subject][rule_id] = o.facts
        if o.abort:
            aborts[subject][rule_id] = o.abort
        return result(subject, rule_id, o.status, o.reason, time.perf_counter() - t0, o.severity)

    def run_jobs(pool, jobs) -> None:
        for (s, c, _), res in zip(jobs, pool.map(run_one, jobs)):
            out[s][c] = res

    try:
        for path, subject, kinds, *own in fmus:
            only = own[0] if own else checks
            # without a list: the kit's default (profile rules with their profile); a list may name any rule
            available = (lifecycle_rules(kinds, options.profiles) if only is None
                         else [r.id for r in RULES if r.kind in kinds and r.kind in CALL_KINDS])
            ids = [c for c in available if only is None or c in only]
            plan[subject] = ids
            hidden[subject] = {p for c in ids for p in DEPENDS.get(c, ()) if p not in ids and p in available}
            out[subject], facts[subject], aborts[subject] = {}, {}, {}
            try:
                unzipped[subject] = extract(path)
            except ArchiveError as e:
                for c in ids:
                    out[subject][c] = result(subject, c, FAIL, f"the FMU could not be unpacked: {e}")
        dependents = set(DEPENDS)
        with ThreadPoolExecutor(max_workers=max(1, options.jobs)) as pool:
            run_jobs(pool, [(s, c, {}) for s, ids in plan.items() if s in unzipped for c in ids if c in GATES.values()])

            def blocked(s, c):
                gate = GATES[c.split(".", 1)[0]]
                return gate in out[s] and out[s][gate].failed and gate

            for phase in ("independent", "dependent"):
                jobs = []
                for s, ids in plan.items():
                    if s not in unzipped:
                        continue
                    todo = ids + sorted(hidden[s]) if phase == "independent" else ids
                    for c in todo:
                        if c in out[s] or (c in dependents) != (phase == "dependent"):
                            continue
                        if blocked(s, c):
                            out[s][c] = result(s, c, SKIP, f"needs {blocked(s, c)}, which failed")
                            continue
                        extra = {}
                        if phase == "dependent":
                            done = {p: (out[s][p], facts[s].get(p, {})) for p in DEPENDS[c] if p in out[s]}
                            extra, why = precondition(c, done)
                            if extra is None:
                                out[s][c] = result(s, c, SKIP, why)
                                continue
                        jobs.append((s, c, extra))
                run_jobs(pool, jobs)
        for s in plan:
            _dedupe_aborts(out[s], aborts[s])
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
