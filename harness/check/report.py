"""Outcomes of the compliance checks and their three renderings: text lines, JUnit XML, exit code.

One :class:`CheckResult` per (FMU, rule). A rule that does not hold is a FAIL carrying the
rule's severity (see :mod:`.rules`); the text form shows the severity instead of FAIL::

    PASS   build/fmus/SpurDifferential.fmu  cs.reset  outputs identical after fmi2Reset
    ERROR  Broken.fmu  cs.guid  [FMI 2.0 2.1.5] fmi2Instantiate accepted a wrong GUID
    WARN   Stair.fmu  cs.zero-step-size  [FMI 2.0 4.2.2] ...
    INFO   Stair.fmu  static.output-dependencies  ...

JUnit (``--junit FILE``): one ``testsuite`` per FMU, one ``testcase`` per rule; an error is a
``failure``; a warning is ``skipped`` with the reason (a ``failure`` with ``--strict``); an info
is a passing test case; every test case carries ``properties`` (severity, FMI section, outcome).
Text that an FMU wrote (log messages quoted in reasons) is cleaned of control characters, so the
XML always parses.

Exit code (:func:`exit_code`): 1 when an error-severity rule failed (``strict``: or a warning),
else 0. Usage errors (2) are decided by the command line before any check runs.
"""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Mapping, Sequence

from .rules import BY_ID, ERROR, INFO, SEVERITIES, WARNING

PASS = "PASS"
FAIL = "FAIL"
SKIP = "SKIP"
STATUSES = (PASS, FAIL, SKIP)

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2

LABELS = {ERROR: "ERROR", WARNING: "WARN", INFO: "INFO"}

# characters XML 1.0 cannot carry (C0 controls except tab/LF/CR, surrogates, U+FFFE/U+FFFF), and C1 controls
_BAD_CHARS = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f\ud800-\udfff\ufffe\uffff]")


def clean(text: str) -> str:
    """``text`` with every control character (and anything XML cannot hold) written as ``\\xNN``."""
    return _BAD_CHARS.sub(lambda m: f"\\x{ord(m.group()):02x}" if ord(m.group()) < 0x100
                          else f"\\u{ord(m.group()):04x}", str(text))


def one_line(text: str) -> str:
    return " ".join(clean(text).split())


@dataclass(frozen=True)
class CheckResult:
    """The outcome of one rule on one FMU (or one compared result file).

    ``subject`` names what was checked (the FMU path as given), ``check_id`` the rule id (e.g.
    ``cs.reset``), ``status`` PASS / FAIL / SKIP, ``reason`` one line. ``severity`` is the
    severity a FAIL carries (error unless the rule says otherwise; see :mod:`.rules`);
    ``duration`` the wall time, s (JUnit ``time``).
    """

    subject: str
    check_id: str
    status: str
    reason: str = ""
    duration: float = 0.0
    severity: str = ERROR

    def __post_init__(self):
        if self.status not in STATUSES:
            raise ValueError(f"CheckResult.status must be one of {STATUSES}, got {self.status!r}")
        if self.severity not in SEVERITIES:
            raise ValueError(f"CheckResult.severity must be one of {SEVERITIES}, got {self.severity!r}")

    @property
    def passed(self) -> bool:
        return self.status == PASS

    @property
    def failed(self) -> bool:
        return self.status == FAIL

    @property
    def is_error(self) -> bool:
        return self.status == FAIL and self.severity == ERROR

    @property
    def is_warning(self) -> bool:
        return self.status == FAIL and self.severity == WARNING

    @property
    def label(self) -> str:
        return LABELS[self.severity] if self.status == FAIL else self.status

    @property
    def section(self) -> str:
        rule = BY_ID.get(self.check_id)
        return rule.section if rule else ""

    @property
    def cite(self) -> str:
        """``FMI <version> <section>`` of the rule (the standard whose text it cites), or ""."""
        rule = BY_ID.get(self.check_id)
        return f"FMI {rule.fmi} {rule.section}" if rule and rule.section else ""


def format_line(result: CheckResult) -> str:
    """``LABEL  <subject>  <rule>  [FMI <version> <section>] <reason>`` on one line."""
    sec = f"[{result.cite}] " if result.status == FAIL and result.cite else ""
    return f"{result.label:<5}  {one_line(result.subject)}  {result.check_id}  {sec}{one_line(result.reason)}".rstrip()


def counts(results: Sequence[CheckResult]) -> dict[str, int]:
    return {"checks": len(results), "passed": sum(r.passed for r in results),
            "errors": sum(r.is_error for r in results), "warnings": sum(r.is_warning for r in results),
            "info": sum(r.status == FAIL and r.severity == INFO for r in results),
            "skipped": sum(r.status == SKIP for r in results)}


def summary(results: Sequence[CheckResult]) -> str:
    n = counts(results)
    return (f"{n['checks']} checks: {n['passed']} passed, {n['errors']} errors, {n['warnings']} warnings, "
            f"{n['info']} info, {n['skipped']} skipped")


Deselected = Mapping[str, Sequence[tuple[str, str]]]   # subject -> [(rule id, why it was left out)]


def _deselected_line(rules_why: Sequence[tuple[str, str]]) -> str:
    """'4 deselected: cs.stop-time (ignore 'cs.stop-time' (pyproject.toml)), ...' grouped by reason."""
    by_why: dict[str, list[str]] = {}
    for rid, why in rules_why:
        by_why.setdefault(why, []).append(rid)
    return f"{len(rules_why)} deselected: " + "; ".join(f"{', '.join(ids)} ({why})" for why, ids in by_why.items())


def format_report(results: Iterable[CheckResult], deselected: Deselected | None = None) -> str:
    """All result lines, then one summary line per subject (when there are several) and the total; what
    the selection left out, per subject, after its summary."""
    results = list(results)
    deselected = {k: v for k, v in (deselected or {}).items() if v}
    lines = [format_line(r) for r in results]
    subjects = list(dict.fromkeys([r.subject for r in results] + list(deselected)))
    if len(subjects) > 1 or deselected:
        for s in subjects:
            line = f"{one_line(s)}: " + summary([r for r in results if r.subject == s])
            if deselected.get(s):
                line += f"; {_deselected_line(deselected[s])}"
            lines.append(line)
    total = summary(results)
    n_des = sum(len(v) for v in deselected.values())
    lines.append(total + (f", {n_des} deselected" if n_des else ""))
    return "\n".join(lines)


def exit_code(results: Iterable[CheckResult], strict: bool = False) -> int:
    """1 when an error-severity rule failed (``strict``: or a warning), else 0."""
    bad = any(r.is_error or (strict and r.is_warning) for r in results)
    return EXIT_FAILED if bad else EXIT_OK


def junit_tree(results: Sequence[CheckResult], strict: bool = False,
               deselected: Deselected | None = None) -> ET.ElementTree:
    """JUnit XML: ``testsuites`` > one ``testsuite`` per subject > one ``testcase`` per rule; a rule the
    selection left out is a ``testcase`` with ``<skipped type="deselected" message="deselected: why"/>``."""
    suites: dict[str, list[CheckResult]] = {}
    for r in results:
        suites.setdefault(r.subject, []).append(r)
    deselected = deselected or {}
    for subject in deselected:
        suites.setdefault(subject, [])

    def as_failure(r: CheckResult) -> bool:
        return r.is_error or (strict and r.is_warning)

    def as_skipped(r: CheckResult) -> bool:
        return r.status == SKIP or (r.is_warning and not strict)

    def attrs(rs: Sequence[CheckResult], n_des: int = 0) -> dict[str, str]:
        return {"tests": str(len(rs) + n_des), "failures": str(sum(as_failure(r) for r in rs)), "errors": "0",
                "skipped": str(sum(as_skipped(r) for r in rs) + n_des), "time": f"{sum(r.duration for r in rs):.3f}"}

    root = ET.Element("testsuites", {"name": "spurdiff check",
                                     **attrs(results, sum(len(deselected.get(s, ())) for s in suites))})
    for subject, rs in suites.items():
        des = list(deselected.get(subject, ()))
        suite = ET.SubElement(root, "testsuite", {"name": clean(subject), **attrs(rs, len(des))})
        if des:
            sp = ET.SubElement(suite, "properties")
            ET.SubElement(sp, "property", {"name": "deselected", "value": clean(_deselected_line(des))})
        classname = clean(Path(subject).name)
        for r in rs:
            case = ET.SubElement(suite, "testcase", {"classname": classname, "name": r.check_id,
                                                     "time": f"{r.duration:.3f}"})
            props = ET.SubElement(case, "properties")
            for name, value in (("outcome", r.label), ("severity", r.severity), ("fmi-section", r.section)):
                ET.SubElement(props, "property", {"name": name, "value": value})
            message = one_line(r.reason)
            if r.status == FAIL:
                message = f"{r.severity} [{r.cite}]: {message}" if r.cite else f"{r.severity}: {message}"
            if as_failure(r):
                el = ET.SubElement(case, "failure", {"message": message, "type": r.severity})
                el.text = clean(r.reason)
            elif as_skipped(r):
                ET.SubElement(case, "skipped", {"message": message})
            elif r.status == FAIL:  # info: a passing test case with a note
                ET.SubElement(props, "property", {"name": "note", "value": message})
        for rid, why in des:
            case = ET.SubElement(suite, "testcase", {"classname": classname, "name": rid, "time": "0.000"})
            props = ET.SubElement(case, "properties")
            for name, value in (("outcome", "DESELECTED"), ("severity", BY_ID[rid].severity),
                                ("fmi-section", BY_ID[rid].section)):
                ET.SubElement(props, "property", {"name": name, "value": value})
            ET.SubElement(case, "skipped", {"type": "deselected", "message": clean(f"deselected: {why}")})
    ET.indent(root, space="  ")
    return ET.ElementTree(root)


def write_junit(path: str | Path, results: Sequence[CheckResult], strict: bool = False,
                deselected: Deselected | None = None) -> Path:
    """Write the JUnit XML report to ``path`` (parent directories are created; written whole
    through :func:`harness.common.outputs.atomic_file`: no link followed, a write error is one line)."""
    from harness.common.outputs import atomic_file

    path = Path(path)
    with atomic_file(path, "wb") as fh:
        junit_tree(results, strict, deselected).write(fh, encoding="utf-8", xml_declaration=True)
    return path
