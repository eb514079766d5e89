"""Which rules run on which FMU: selection the way Python linters do it (ruff, flake8).

A *selector* is a rule id (``cs.stop-time``), a kind (``static``, ``load``, ``cs``, ``me``), a group
(``state``, ``discard``, ``steps``, ``io``, ``experiment``, ``instances``, ``values``, ``load``,
``conventions``: the ``groups`` of :mod:`.rules`) or ``ALL``.

* ``select`` (default ``ALL``) names what runs, ``extend-select`` adds to it, ``ignore`` takes away;
  when a rule matches both a select and an ignore selector, the more specific one wins (rule id over
  group over kind over ``ALL``), and at equal specificity ``ignore`` wins;
* ``per-fmu-ignores`` maps a glob (matched against the FMU's path as given and its file name) to
  selectors ignored for the FMUs it matches;
* profile rules (``--profile``) are not in ``ALL``: they run when their profile is on, or when selected
  by id.

Settings come from ``[tool.spurdiff.check]`` in ``pyproject.toml`` (the nearest one, from the current
folder upwards, that has the table; or ``--config FILE``), and the command line on top: ``--select``
replaces the file's ``select``, ``--ignore``, ``--extend-select`` and ``--per-fmu-ignore`` add to the
file's. Every rule left out is reported as deselected with the setting that left it out.
"""
from __future__ import annotations

import fnmatch
import tomllib
from dataclasses import dataclass, field
from pathlib import Path, PurePath
from typing import Iterable, Mapping, Sequence

from .rules import BY_ID, RULES, Rule

CONFIG_KEYS = ("select", "ignore", "extend-select", "per-fmu-ignores", "strict", "profile", "timeout", "jobs", "steps")


class SelectionError(ValueError):
    """A bad selector or configuration (one line naming the setting and what is allowed)."""


def groups() -> dict[str, int]:
    """Every selector name but rule ids, with its specificity (ALL 0, kind 1, group 2)."""
    out = {"ALL": 0}
    for r in RULES:
        out.setdefault(r.kind, 1)
        for g in r.groups:
            out.setdefault(g, 2)
    return out


def _specificity(selector: str, rule: Rule) -> int | None:
    """How specifically ``selector`` names ``rule`` (3 id, 2 group, 1 kind, 0 ALL), or None."""
    if selector == rule.id:
        return 3
    if selector in rule.groups:
        return 2
    if selector == rule.kind:
        return 1
    if selector == "ALL" and rule.profile is None:
        return 0
    return None


def check_selectors(selectors: Iterable[str], where: str) -> list[str]:
    out = []
    known = groups()
    for s in selectors:
        s = str(s).strip()
        if s not in BY_ID and s not in known:
            raise SelectionError(f"{where}: unknown rule or group {s!r} (allowed: ALL, a kind "
                                 f"{sorted(k for k, v in known.items() if v == 1)}, a group "
                                 f"{sorted(k for k, v in known.items() if v == 2)} or a rule id; "
                                 f"`spurdiff check --list-rules`)")
        out.append(s)
    return out


@dataclass(frozen=True)
class Selection:
    """The resolved selection; ``source`` names where each list came from (for the report)."""

    select: tuple[str, ...] = ("ALL",)
    ignore: tuple[str, ...] = ()
    extend_select: tuple[str, ...] = ()
    per_fmu_ignores: tuple[tuple[str, tuple[str, ...]], ...] = ()
    source: Mapping[str, str] = field(default_factory=dict)

    def why_not(self, rule: Rule, fmu: str | None = None, profiles: Sequence[str] = ()) -> str | None:
        """None when ``rule`` runs on ``fmu``, else the setting that leaves it out (one line)."""
        ignores = list(self.ignore)
        per_fmu = []
        if fmu is not None:
            for pattern, sels in self.per_fmu_ignores:
                if _fmu_matches(pattern, fmu):
                    per_fmu += [(s, pattern) for s in sels]
        best_sel = max((sp for s in (*self.select, *self.extend_select)
                        if (sp := _specificity(s, rule)) is not None), default=None)
        if rule.profile is not None:
            if rule.profile in profiles:
                best_sel = max(best_sel if best_sel is not None else -1, 1)  # the profile selects it like its kind
            elif best_sel is not None and best_sel < 2:
                best_sel = None   # off with its profile unless named by id or group
        best_ign = max(((sp, s) for s in ignores if (sp := _specificity(s, rule)) is not None), default=None)
        best_fmu = max(((sp, s, p) for s, p in per_fmu if (sp := _specificity(s, rule)) is not None), default=None)
        if best_sel is None:
            if rule.profile is not None and rule.profile not in profiles:
                return f"profile {rule.profile} not on"
            return f"not in select = {list(self.select) + list(self.extend_select)} ({self.source.get('select', 'default')})"
        if best_fmu is not None and best_fmu[0] >= best_sel:
            return f"per-fmu-ignores {best_fmu[2]!r} = {best_fmu[1]!r} ({self.source.get('per-fmu-ignores', 'command line')})"
        if best_ign is not None and best_ign[0] >= best_sel:
            return f"ignore {best_ign[1]!r} ({self.source.get('ignore', 'command line')})"
        return None

    def rule_ids(self, fmu: str | None = None, profiles: Sequence[str] = (), kind: str | None = None) -> list[str]:
        return [r.id for r in RULES if (kind is None or r.kind == kind) and self.why_not(r, fmu, profiles) is None]

    def deselected(self, fmu: str, profiles: Sequence[str] = ()) -> list[tuple[str, str]]:
        """(rule id, why) for every rule that does not run on ``fmu``, profile rules whose profile is off
        left out (they are not part of the kit's default)."""
        out = []
        for r in RULES:
            why = self.why_not(r, fmu, profiles)
            if why is not None and not why.startswith("profile "):
                out.append((r.id, why))
        return out

    @property
    def is_default(self) -> bool:
        return self.select == ("ALL",) and not (self.ignore or self.extend_select or self.per_fmu_ignores)


def _fmu_matches(pattern: str, fmu: str) -> bool:
    p = PurePath(fmu)
    return fnmatch.fnmatch(fmu, pattern) or fnmatch.fnmatch(p.name, pattern) or p.match(pattern)


def find_config(start: str | Path | None = None) -> Path | None:
    """The nearest pyproject.toml with a [tool.spurdiff.check] table, from ``start`` (default: the
    current folder) upwards, or None."""
    d = Path(start or Path.cwd()).resolve()
    for folder in (d, *d.parents):
        f = folder / "pyproject.toml"
        if f.is_file():
            try:
                data = tomllib.loads(f.read_text(encoding="utf-8"))
            except (tomllib.TOMLDecodeError, OSError, UnicodeDecodeError):
                continue
            if "check" in data.get("tool", {}).get("spurdiff", {}):
                return f
    return None


def read_config(path: str | Path) -> dict:
    """The [tool.spurdiff.check] table of ``path`` (a pyproject.toml, or any TOML file with that table or
    with the keys at top level), checked; raises SelectionError naming the bad key."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as e:
        raise SelectionError(f"--config {path}: cannot be read ({e.strerror})") from None
    except tomllib.TOMLDecodeError as e:
        raise SelectionError(f"{path}: not valid TOML ({e})") from None
    table = data.get("tool", {}).get("spurdiff", {}).get("check")
    if table is None:
        table = {k: v for k, v in data.items() if k != "tool"}
    where = f"{path} [tool.spurdiff.check]"
    unknown = [k for k in table if k not in CONFIG_KEYS]
    if unknown:
        raise SelectionError(f"{where}: unknown key {unknown[0]!r} (allowed: {', '.join(CONFIG_KEYS)})")
    for key in ("select", "ignore", "extend-select", "profile"):
        if key in table and not (isinstance(table[key], list) and all(isinstance(x, str) for x in table[key])):
            raise SelectionError(f"{where}: {key} must be a list of strings")
    for key in ("select", "ignore", "extend-select"):
        if key in table:
            check_selectors(table[key], f"{where} {key}")
    pfi = table.get("per-fmu-ignores", {})
    if not isinstance(pfi, dict) or not all(isinstance(v, list) and all(isinstance(x, str) for x in v)
                                            for v in pfi.values()):
        raise SelectionError(f'{where}: per-fmu-ignores must be a table of glob = ["rule or group", ...]')
    for pattern, sels in pfi.items():
        check_selectors(sels, f"{where} per-fmu-ignores {pattern!r}")
    if "strict" in table and not isinstance(table["strict"], bool):
        raise SelectionError(f"{where}: strict must be true or false")
    for key, lo in (("timeout", 0.0), ("jobs", 1), ("steps", 2)):
        if key in table and (isinstance(table[key], bool) or not isinstance(table[key], (int, float))
                             or table[key] < lo or (key == "timeout" and table[key] == 0)):
            raise SelectionError(f"{where}: {key} must be a number {'> 0' if key == 'timeout' else f'>= {lo}'}")
    return table


def resolve(config: Mapping | None, config_path: str | None, select: Sequence[str] | None,
            ignore: Sequence[str], extend_select: Sequence[str],
            per_fmu_ignore: Sequence[tuple[str, Sequence[str]]]) -> Selection:
    """The file's settings with the command line's on top (see the module docstring)."""
    config = dict(config or {})
    src_file = f"{config_path}" if config_path else "config"
    source: dict[str, str] = {}
    if select is not None:
        sel, source["select"] = tuple(check_selectors(select, "--select")), "--select"
    elif "select" in config:
        sel, source["select"] = tuple(config["select"]), f"select in {src_file}"
    else:
        sel = ("ALL",)
    ign = tuple(config.get("ignore", ())) + tuple(check_selectors(ignore, "--ignore"))
    if ign:
        source["ignore"] = " and ".join(x for x in ((f"{src_file}" if config.get("ignore") else ""),
                                                     ("--ignore" if ignore else "")) if x)
    ext = tuple(config.get("extend-select", ())) + tuple(check_selectors(extend_select, "--extend-select"))
    pfi = [(p, tuple(v)) for p, v in config.get("per-fmu-ignores", {}).items()]
    pfi += [(p, tuple(check_selectors(v, f"--per-fmu-ignore {p}"))) for p, v in per_fmu_ignore]
    if pfi:
        source["per-fmu-ignores"] = " and ".join(x for x in ((src_file if config.get("per-fmu-ignores") else ""),
                                                              ("--per-fmu-ignore" if per_fmu_ignore else "")) if x)
    return Selection(sel, ign, ext, tuple(pfi), source)
