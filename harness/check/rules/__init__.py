"""The rules of the compliance kit, as data (``table.toml`` beside this file, read once at import): id, FMI
version and section, severity, calls, what passes, the standard's sentence. One entry per meaning: where FMI 2.0
and FMI 3.0 say the same thing, one ``[[rule]]`` holds each version's id, citation and severity
(``[rule.fmi2]``, ``[rule.fmi3]``), as fmpy's validation and ruff's rule table keep rules as data. An FMU gets
the rules of its fmiVersion (:func:`fmi_version`, :func:`applies`).

May import: the standard library only (every other part of the kit imports this package).

Severity comes from the standard's own words (FMI 2.0.x, "Functional Mock-up Interface for Model
Exchange and Co-Simulation"; FMI 3.0, "Functional Mock-up Interface Specification"):

``error``
    the standard says *shall* / *must* / *has to* / *needs to*, or the call sequence is one the
    standard requires to work (3.2.3: "Every implementation of the FMI must support calling
    sequences of the functions according to the following state chart"; 4.2.4: "The following
    state machine defines the supported calling sequences"; 2.3: "An FMU has to implement all
    common functions (according to tables in sections 3.2.3 and 4.2.4)");
``warning``
    the standard says *should* / *is recommended*, or a sentence without *shall* / *must* (a
    definition, a permission), or the behaviour is left undefined (a call outside the allowed
    states, a step size the master must not use: 3.2.3 "The behaviour of an FMU is undefined for
    such a calling sequence") and a robust FMU still handles it by refusing;
``info``
    good practice, and the conventions of a profile (``--profile``): the standard does not ask
    for them. A rule with a ``profile`` runs only when that profile is selected, and then its
    failures count as errors (the profile makes them requirements).

Exit code: 1 when any rule of severity error failed (``--strict``: or a warning), else 0.
The kinds: ``static`` (modelDescription.xml and archive, no binary loaded), ``load`` (the binary outside
Python), ``cs`` (the co-simulation call sequence, each rule in a fresh process), ``me`` (model exchange,
likewise); for FMI 3.0 FMUs ``static3``, ``load3``, ``cs3`` and ``me3``.
"""
from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

ERROR, WARNING, INFO = "error", "warning", "info"
SEVERITIES = (ERROR, WARNING, INFO)
PROFILES = ("spurdiff",)
VERSIONS = {"fmi2": "2.0", "fmi3": "3.0"}
TABLE = Path(__file__).with_name("table.toml")


@dataclass(frozen=True)
class Rule:
    id: str
    section: str       # section of the FMI standard (version ``fmi``), e.g. "2.1.5"
    severity: str      # error / warning / info (see the module docstring)
    calls: str         # the FMI calls (or the XML parts) the rule exercises
    summary: str       # what passes, in one sentence
    profile: str | None = None  # only with --profile NAME
    quote: str | None = None    # the standard's sentence the rule enforces (None: no sentence says it)
    groups: tuple[str, ...] = ()  # selection groups besides the kind (see harness.check.selection)
    fmi: str = "2.0"            # the FMI version whose FMUs the rule checks (and whose text it cites)
    meaning: str = ""           # the table entry (shared by a 2.0 and a 3.0 rule that say the same)

    @property
    def kind(self) -> str:
        return self.id.split(".", 1)[0]

    def effective_severity(self, profiles: tuple[str, ...] = ()) -> str:
        return ERROR if self.profile is not None and self.profile in profiles else self.severity


FIELDS = ("id", "section", "severity", "calls", "summary", "quote", "profile", "groups")


def load_table(path: Path = TABLE) -> tuple[dict, tuple[Rule, ...]]:
    """The table's header (sources) and its rules, FMI 2.0 ones first, each version in table order. A field
    beside the version tables holds for both; an unknown field or severity is a ValueError."""
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    by_version: dict[str, list[Rule]] = {k: [] for k in VERSIONS}
    for entry in data.get("rule", []):
        shared = {k: v for k, v in entry.items() if k not in VERSIONS and k != "meaning"}
        for key, fmi in VERSIONS.items():
            if key not in entry:
                continue
            fields = {**shared, **entry[key]}
            unknown = set(fields) - set(FIELDS)
            if unknown or fields.get("severity") not in SEVERITIES:
                raise ValueError(f"{path.name}: rule {fields.get('id')!r}: unknown field(s) {sorted(unknown)} or "
                                 f"severity {fields.get('severity')!r}")
            fields["groups"] = tuple(fields.get("groups", ()))
            by_version[key].append(Rule(**fields, fmi=fmi, meaning=entry["meaning"]))
    header = {k: v for k, v in data.items() if k != "rule"}
    return header, tuple(r for key in VERSIONS for r in by_version[key])


_HEADER, RULES = load_table()
SOURCE_FMI2: str = _HEADER["source_fmi2"]
SOURCE_FMI3: str = _HEADER["source_fmi3"]
RULES2 = tuple(r for r in RULES if r.fmi == "2.0")
RULES3 = tuple(r for r in RULES if r.fmi == "3.0")
BY_ID: dict[str, Rule] = {r.id: r for r in RULES}
KINDS = {"2.0": ("static", "load", "cs", "me"), "3.0": ("static3", "load3", "cs3", "me3")}


def fmi_version(fmi_version_attribute: str | None) -> str:
    """The rule set an FMU gets from its modelDescription's fmiVersion: "3.0" for 3.x, else "2.0"."""
    return "3.0" if (fmi_version_attribute or "").strip().startswith("3") else "2.0"


def applies(rule: Rule, version: str) -> bool:
    """Whether ``rule`` checks FMUs of FMI ``version`` ("2.0" / "3.0")."""
    return rule.fmi == version


def rules(kind: str | None = None, profiles: tuple[str, ...] = ()) -> tuple[Rule, ...]:
    """The rules that run: of ``kind`` (static / cs / me; None: all), without a profile or with one
    of ``profiles``."""
    return tuple(r for r in RULES if (kind is None or r.kind == kind)
                 and (r.profile is None or r.profile in profiles))


def rule_table_markdown() -> str:
    """The rule table of docs/compliance.md, generated from :data:`RULES`."""
    lines = ["| rule | groups | FMI section | severity | calls / XML | passes when | the standard's words |",
             "|---|---|---|---|---|---|---|"]
    for r in RULES:
        sev = r.severity + (f" (profile `{r.profile}`: error)" if r.profile else "")
        quote = (f"\"{r.quote}\"" if r.quote else f"(no sentence of FMI {r.fmi}: "
                 + ("a convention)" if r.profile else "never an error)"))
        groups = ", ".join(f"`{g}`" for g in (r.kind,) + r.groups)
        lines.append(f"| `{r.id}` | {groups} | {r.fmi}: {r.section} | {sev} | {r.calls} | {r.summary} | {quote} |"
                     .replace("\\", "\\\\"))
    return "\n".join(lines)


TABLE_BEGIN = "<!-- rule table: generated by `spurdiff check --write-rule-table docs/compliance.md` -->"
TABLE_END = "<!-- end of the rule table -->"


def with_rule_table(text: str) -> str:
    """``text`` (docs/compliance.md) with the part between TABLE_BEGIN and TABLE_END replaced by
    :func:`rule_table_markdown` (ValueError when the markers are missing)."""
    i, j = text.find(TABLE_BEGIN), text.find(TABLE_END)
    if i < 0 or j < i:
        raise ValueError(f"no {TABLE_BEGIN} ... {TABLE_END} block")
    return text[:i + len(TABLE_BEGIN)] + "\n" + rule_table_markdown() + "\n" + text[j:]
