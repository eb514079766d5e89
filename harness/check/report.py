"""Outcomes of the compliance checks and their three renderings: text lines, JUnit XML, exit code.

One :class:`CheckResult` per (FMU, check). The text form is one line per check::

    PASS  build/fmus/SpurDifferential.fmu  lifecycle.reset  outputs identical after fmi2Reset

The JUnit form (``--junit FILE``) has one ``testsuite`` per FMU and one ``testcase`` per check;
a FAIL is a ``failure`` element, a SKIP a ``skipped`` element, both carrying the reason. This is
the schema understood by GitHub Actions / GitLab / Jenkins JUnit reporters (no ``error``
elements are written: a crash or timeout of an FMU is a failure of the FMU, not of the checker).

Exit code (:func:`exit_code`): 0 when every check passed or was skipped, 1 when any failed.
Usage errors (exit code 2) are decided by the command line, before any check runs.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Sequence

PASS = "PASS"
FAIL = "FAIL"
SKIP = "SKIP"
STATUSES = (PASS, FAIL, SKIP)

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2


@dataclass(frozen=True)
class CheckResult:
    """The outcome of one check on one FMU (or one compared result file).

    ``subject`` is what was checked (the FMU path as given on the command line), ``check_id`` a
    stable dotted identifier such as ``static.units`` or ``lifecycle.reset``, ``status`` one of
    PASS / FAIL / SKIP and ``reason`` one line saying why. ``duration`` is the wall time of the
    check in seconds (informative only; written to JUnit's ``time`` attribute).
    """

    subject: str
    check_id: str
    status: str
    reason: str = ""
    duration: float = 0.0

    def __post_init__(self):
        if self.status not in STATUSES:
            raise ValueError(f"CheckResult.status must be one of {STATUSES}, got {self.status!r}")

    @property
    def passed(self) -> bool:
        return self.status == PASS

    @property
    def failed(self) -> bool:
        return self.status == FAIL


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def format_line(result: CheckResult) -> str:
    """``STATUS  <subject> <check-id>  <reason>`` (reason flattened to one line)."""
    return f"{result.status}  {result.subject} {result.check_id}  {_one_line(result.reason)}".rstrip()


def format_report(results: Iterable[CheckResult]) -> str:
    """All result lines followed by a one-line summary (counts per status)."""
    results = list(results)
    lines = [format_line(r) for r in results]
    n = {s: sum(r.status == s for r in results) for s in STATUSES}
    lines.append(f"{len(results)} checks: {n[PASS]} passed, {n[FAIL]} failed, {n[SKIP]} skipped")
    return "\n".join(lines)


def exit_code(results: Iterable[CheckResult]) -> int:
    """0 when nothing failed (passes and skips only), 1 when any check failed."""
    return EXIT_FAILED if any(r.failed for r in results) else EXIT_OK


def junit_tree(results: Sequence[CheckResult]) -> ET.ElementTree:
    """JUnit XML: ``testsuites`` > one ``testsuite`` per subject > one ``testcase`` per check."""
    suites: dict[str, list[CheckResult]] = {}
    for r in results:
        suites.setdefault(r.subject, []).append(r)

    def counts(rs: Sequence[CheckResult]) -> dict[str, str]:
        return {
            "tests": str(len(rs)),
            "failures": str(sum(r.status == FAIL for r in rs)),
            "errors": "0",
            "skipped": str(sum(r.status == SKIP for r in rs)),
            "time": f"{sum(r.duration for r in rs):.3f}",
        }

    root = ET.Element("testsuites", {"name": "spurdiff check", **counts(results)})
    for subject, rs in suites.items():
        suite = ET.SubElement(root, "testsuite", {"name": subject, **counts(rs)})
        classname = Path(subject).name
        for r in rs:
            case = ET.SubElement(suite, "testcase",
                                 {"classname": classname, "name": r.check_id, "time": f"{r.duration:.3f}"})
            if r.status == FAIL:
                el = ET.SubElement(case, "failure", {"message": _one_line(r.reason), "type": "FAIL"})
                el.text = r.reason
            elif r.status == SKIP:
                ET.SubElement(case, "skipped", {"message": _one_line(r.reason)})
    ET.indent(root, space="  ")
    return ET.ElementTree(root)


def write_junit(path: str | Path, results: Sequence[CheckResult]) -> Path:
    """Write the JUnit XML report to ``path`` (parent directories are created)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    junit_tree(results).write(path, encoding="utf-8", xml_declaration=True)
    return path
