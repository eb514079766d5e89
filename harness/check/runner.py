"""Running the compliance kit over several FMUs: the static rules, then the call-sequence rules of
every interface each FMU offers (the command line is :mod:`harness.cli.check`)."""
from __future__ import annotations

from typing import Sequence

from .lifecycle import LifecycleOptions, lifecycle_rules, run_lifecycle_checks_many
from .report import SKIP, CheckResult
from .rules import BY_ID
from .static import read_archive, run_static_checks


def run_checks(fmus: Sequence[str], options: LifecycleOptions, static_only: bool = False) -> list[CheckResult]:
    """Static rules, then (unless ``static_only``) the call-sequence rules of every interface the
    FMU offers, for every FMU; report order."""
    profiles = options.profiles
    static = {f: run_static_checks(f, subject=f, profiles=profiles) for f in fmus}
    lifecycle: dict[str, list[CheckResult]] = {}
    runnable = []
    for f in fmus:
        if static_only:
            continue
        res = {r.check_id: r for r in static[f]}
        arc = read_archive(f) if not any(res[c].failed or res[c].status == SKIP
                                         for c in ("static.archive", "static.fmi2")) else None
        kinds = [k for k in ("cs", "me") if arc is not None and arc.interface(k) is not None]
        blocker = next((res[c] for c in ("static.archive", "static.fmi2", "static.binary") if res[c].status != "PASS"), None)
        if blocker is not None:
            ids = lifecycle_rules(kinds or ("cs",), profiles)
            lifecycle[f] = [CheckResult(f, c, SKIP, f"{blocker.check_id} did not pass",
                                        severity=BY_ID[c].effective_severity(profiles)) for c in ids]
        else:
            runnable.append((f, f, kinds))
    if runnable:
        lifecycle.update(run_lifecycle_checks_many(runnable, options))
    return [r for f in fmus for r in static[f] + lifecycle.get(f, [])]

