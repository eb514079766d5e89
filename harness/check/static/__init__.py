"""The static rules: the FMU archive and its modelDescription.xml, no binary loaded.

* :mod:`.common`: what both versions share (the archive, start values within min/max);
* :mod:`.fmi2`: the FMI 2.0 rules (kind ``static``); :mod:`.fmi3`: the FMI 3.0 rules (kind ``static3``);
* here: :func:`run_static_checks`, which runs the rules of the FMU's fmiVersion.

May import: :mod:`harness.check.archive`, :mod:`harness.check.report`, :mod:`harness.check.rules` and fmpy
(for its validation and schema files); nothing that loads a binary.
"""
from __future__ import annotations

import time
from pathlib import Path
from typing import Sequence

from ..archive import FmuArchive, peek_fmi_version, read_archive  # noqa: F401  (FmuArchive, read_archive: re-exported)
from ..report import FAIL, SKIP, CheckResult
from ..rules import RULES, fmi_version, rules
from .fmi2 import CHECKS, host_platform, is_structured_name  # noqa: F401  (re-exported)
from .fmi3 import CHECKS3, GATES3

GATES2 = ("static.archive", "static.fmi2")   # when one fails, the others are SKIPped


def run_static_checks(fmu_path: str | Path, subject: str | None = None,
                      profiles: tuple[str, ...] = (), also: Sequence[str] = ()) -> list[CheckResult]:
    """Every static rule (and those of ``profiles``, and the profile rules named in ``also``) on one FMU file.

    When the archive or the model description cannot be read, the later rules are SKIPped
    (they would only repeat the same failure).
    """
    subject = subject if subject is not None else str(fmu_path)
    arc = read_archive(fmu_path)
    results: list[CheckResult] = []
    declared = arc.root.get("fmiVersion") if arc.root is not None else peek_fmi_version(fmu_path)
    if fmi_version(declared) == "3.0":   # FMI 3.0: the static3 rules (static/fmi3.py)
        kind, checks, gates = "static3", CHECKS3, GATES3
    else:
        kind, checks, gates = "static", CHECKS, GATES2
    for rule in [r for r in RULES if r.kind == kind and (r in rules(kind, profiles) or r.id in also)]:
        t0 = time.perf_counter()
        blocker = next((r for r in results if r.check_id in gates and r.failed), None)
        if blocker is not None:
            status, reason = SKIP, f"needs {blocker.check_id}, which failed"
        else:
            try:
                status, reason = checks[rule.id](arc)
            except Exception as e:  # a malformed description must not stop the other rules
                status, reason = FAIL, f"could not evaluate: {type(e).__name__}: {e}"
        results.append(CheckResult(subject, rule.id, status, reason, time.perf_counter() - t0,
                                   rule.effective_severity(profiles)))
    return results
