"""What a rule of the compliance kit is (:class:`Rule`) and the three severities; the rules themselves are data
in :mod:`.rules` (FMI 2.0) and :mod:`.rules3` (FMI 3.0), which both build on this module."""
from __future__ import annotations

from dataclasses import dataclass

ERROR, WARNING, INFO = "error", "warning", "info"
SEVERITIES = (ERROR, WARNING, INFO)

PROFILES = ("spurdiff",)


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

    @property
    def kind(self) -> str:
        return self.id.split(".", 1)[0]

    def effective_severity(self, profiles: tuple[str, ...] = ()) -> str:
        return ERROR if self.profile is not None and self.profile in profiles else self.severity
