"""Issue 29 (citations): every section a rule cites exists in the text of the standard that was checked
(harness/check/rules.py: SOURCE_FMI2, SOURCE_FMI3), and docs/compliance.md names that text.

The section numbers below are the tables of contents of those two documents, copied once by hand:
a rule citing a number that is not there (a section cited from memory, or from another version) fails.
"""
from __future__ import annotations

import re
from pathlib import Path

from harness.check.rules import ERROR, INFO, RULES, SOURCE_FMI2, SOURCE_FMI3, WARNING

# FMI 2.0 (SOURCE_FMI2): chapters 1 to 5 with their sections
FMI2_SECTIONS = {
    "1", "1.1", "1.2", "2", "2.1", *(f"2.1.{i}" for i in range(1, 10)), "2.2", *(f"2.2.{i}" for i in range(1, 10)),
    "2.3", "3", "3.1", "3.2", *(f"3.2.{i}" for i in range(1, 5)), "3.3", "3.3.1", "3.3.2",
    "4", "4.1", "4.1.1", "4.1.2", "4.2", *(f"4.2.{i}" for i in range(1, 6)), "4.3", "4.3.1", "4.3.2", "5",
}

# FMI 3.0 (SOURCE_FMI3): chapters 1 to 4 (and 5's number) with their sections, as deep as the rules cite
FMI3_SECTIONS = {
    "1", "1.1", "1.2", *(f"1.2.{i}" for i in range(1, 5)), "1.3", "1.4",
    "2", "2.1", "2.2", *(f"2.2.{i}" for i in range(1, 13)), *(f"2.2.7.{i}" for i in range(1, 5)),
    *(f"2.2.8.{i}" for i in range(1, 5)), "2.2.12.1", "2.2.12.2", "2.3", *(f"2.3.{i}" for i in range(1, 9)),
    "2.4", *(f"2.4.{i}" for i in range(1, 11)), *(f"2.4.7.{i}" for i in range(1, 6)), "2.4.7.5.1",
    *(f"2.4.10.{i}" for i in range(1, 8)), "2.5", "2.5.1", *(f"2.5.1.{i}" for i in range(1, 7)), "2.5.2", "2.5.3",
    "2.5.4", "2.6", "3", "3.1", "3.1.1", "3.2", "3.2.1", "3.3", "3.4", "3.4.1",
    "4", "4.1", "4.1.1", "4.1.2", "4.1.3", "4.2", "4.2.1", "4.2.2", "4.3", *(f"4.3.{i}" for i in range(1, 6)), "4.4",
    "4.4.1", "4.4.1.1", "5",
}

# a section number where a quote names the part it comes from: "2.1.5: ..." or "2.2.7 name: ..."
_QUOTED_SECTION = re.compile(r"(?:^|[;.(] )(\d(?:\.\d+)+)(?=[: ])")


def _sections(rule) -> set[str]:
    return {p.strip() for p in rule.section.split(",")}


def _toc(rule) -> set[str]:
    return {"2.0": FMI2_SECTIONS, "3.0": FMI3_SECTIONS}[rule.fmi]


def test_every_cited_section_exists_in_the_checked_text():
    for r in RULES:
        toc = _toc(r)
        assert _sections(r) <= toc, (r.id, _sections(r) - toc)
        if r.quote:
            quoted = set(_QUOTED_SECTION.findall(r.quote))
            assert quoted <= toc, (r.id, quoted - toc)


def test_errors_quote_the_standard_and_the_others_say_why_not():
    """An error needs the standard's sentence; a rule without one is a warning or info and says so."""
    for r in RULES:
        if r.severity == ERROR:
            assert r.quote and len(r.quote) > 30, r.id
        if r.quote is None:
            assert r.severity in (WARNING, INFO), r.id
            assert r.profile or "no sentence of fmi" in r.summary.lower() or "good practice" in r.summary, r.id


# rules that quote a recommendation beside a requirement, and fail as a warning where only the recommendation
# is broken (each has a broken FMU for that case in test_check_fmus.py's CATCH_TABLE)
MIXED = {"cs.version": "ChkCTypes"}


def test_should_is_never_an_error():
    """Where the only requirement quoted is a recommendation ("should", "is recommended"), the rule is not an
    error."""
    strong = re.compile(r"\b(must|shall|has to|have to|needs to)\b")
    for r in RULES:
        if r.quote and r.severity == ERROR and not strong.search(r.quote) and r.id not in MIXED:
            # allowed without must/shall: a definition of what a function or a declared flag does
            assert not re.search(r"\b(should|is recommended)\b", r.quote), r.id


def test_docs_name_the_text_that_was_checked():
    doc = (Path(__file__).resolve().parents[3] / "docs" / "compliance.md").read_text(encoding="utf-8")
    assert "3f33b06837359c3cf71981ad412096e3eded8c8a" in SOURCE_FMI2 and SOURCE_FMI2 in doc
    assert "d4b021e9fbf8ad57e15d75210abecb900e0290d3" in SOURCE_FMI3 and SOURCE_FMI3 in doc
