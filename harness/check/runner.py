"""Running the compliance kit over several FMUs: the static rules, the ``load`` rules (the binary outside
Python), then the call-sequence rules of every interface each FMU offers, each FMU with the rules its
selection leaves in (the command line is :mod:`harness.cli.check`)."""
from __future__ import annotations

from typing import Sequence

from .archive import peek_fmi_version
from .lifecycle import LifecycleOptions, run_lifecycle_checks_many
from .processes.native import run_load_checks
from .report import FAIL, PASS, SKIP, CheckResult
from .rules import BY_ID, RULES, applies, fmi_version
from .selection import Selection
from .static import read_archive, run_static_checks

STATIC_GATES = ("static.archive", "static.fmi2", "static.binary")
STATIC_GATES3 = ("static3.archive", "static3.fmi3", "static3.binary")


def _version(fmu: str) -> str:
    """The FMI version whose rules check ``fmu`` (from its fmiVersion; "2.0" when it cannot be read)."""
    arc = read_archive(fmu)
    return fmi_version(arc.root.get("fmiVersion") if arc.root is not None else peek_fmi_version(fmu))


def run_checks(fmus: Sequence[str], options: LifecycleOptions, static_only: bool = False,
               selection: Selection | None = None) -> list[CheckResult]:
    """Static rules, then (unless ``static_only``) the load rules and the call-sequence rules of every
    interface the FMU offers, for every FMU, as ``selection`` says (default: every rule); report order.
    See :func:`run_checks_selected` for what was deselected."""
    return run_checks_selected(fmus, options, static_only, selection)[0]


def run_checks_selected(fmus: Sequence[str], options: LifecycleOptions, static_only: bool = False,
                        selection: Selection | None = None) -> tuple[list[CheckResult], dict[str, list[tuple[str, str]]]]:
    """(results, FMU -> [(rule id, why it was deselected)])."""
    selection = selection or Selection()
    profiles = options.profiles
    version = {f: _version(f) for f in fmus}   # FMI 2.0 rules for FMI 2.0 FMUs, FMI 3.0 rules for 3.x
    chosen = {f: {i for i in selection.rule_ids(f, profiles) if applies(BY_ID[i], version[f])} for f in fmus}
    deselected = {f: [(i, why) for i, why in selection.deselected(f, profiles) if applies(BY_ID[i], version[f])]
                  for f in fmus}
    static = {}
    for f in fmus:
        everything = run_static_checks(f, subject=f, profiles=profiles, also=chosen[f])   # gates: needed either way
        static[f] = everything
    later: dict[str, list[CheckResult]] = {}
    runnable = []
    for f in fmus:
        if static_only:
            continue
        res = {r.check_id: r for r in static[f]}
        v3 = version[f] == "3.0"
        gates = STATIC_GATES3 if v3 else STATIC_GATES
        arc = read_archive(f) if not any(res[c].failed or res[c].status == SKIP for c in gates[:2]) else None
        kinds = [k + ("3" if v3 else "") for k in ("cs", "me") if arc is not None and arc.interface(k) is not None]
        blocker = next((res[c] for c in gates if res[c].status != PASS), None)
        wanted_load = [r.id for r in RULES if r.kind in ("load", "load3") and r.id in chosen[f]]
        if blocker is not None:
            ids = wanted_load + [r.id for r in RULES if r.kind in (kinds or ["cs3" if v3 else "cs"]) and r.id in chosen[f]]
            why = (f"{blocker.check_id} did not pass" if kinds or blocker.status != SKIP else
                   "the FMU offers neither co-simulation nor model exchange (scheduled execution is not checked)")
            later[f] = [CheckResult(f, c, SKIP, why, severity=BY_ID[c].effective_severity(profiles)) for c in ids]
        else:
            ids = [r.id for r in RULES if r.kind in kinds and r.id in chosen[f]]
            try:
                later[f] = run_load_checks(f, f, wanted_load, options.timeout, profiles)
            except Exception as e:   # e.g. lxml's XMLSyntaxError: this FMU's finding, the batch goes on (issue 45)
                why = f"modelDescription.xml cannot be read: {type(e).__name__}: {' '.join(str(e).split())[:300]}"
                first = next((c for c in ("load.libraries", "load3.libraries") if c in wanted_load),
                             wanted_load[0] if wanted_load else None)
                later[f] = [CheckResult(f, c, FAIL if c == first else SKIP,
                                        why if c == first else f"precondition not met: {why}",
                                        severity=BY_ID[c].effective_severity(profiles)) for c in wanted_load + ids]
                if first is None and ids:
                    later[f][0] = CheckResult(f, ids[0], FAIL, why, severity=BY_ID[ids[0]].effective_severity(profiles))
                continue
            unloadable = next((r for r in later[f] if r.check_id in ("load.libraries", "load3.libraries")
                               and r.failed), None)
            if unloadable is not None and ids:   # no FMI call can be made: one finding, under load
                later[f] += [CheckResult(f, c, SKIP, f"{unloadable.check_id} did not pass: {unloadable.reason}",
                                         severity=BY_ID[c].effective_severity(profiles)) for c in ids]
            elif ids:
                runnable.append((f, f, kinds, ids))
    if runnable:
        calls = run_lifecycle_checks_many(runnable, options)
        for f, results in calls.items():
            later[f] = later.get(f, []) + results
    out = [r for f in fmus for r in static[f] + later.get(f, []) if r.check_id in chosen[f]]
    return out, deselected
