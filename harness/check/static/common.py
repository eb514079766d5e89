"""What the FMI 2.0 and FMI 3.0 static rules share: the archive rule and the start-within-min/max rule
(one function each, the version's module feeds it its variables)."""
from __future__ import annotations

from typing import Callable, Iterable

from ..archive import FmuArchive
from ..report import FAIL, PASS, SKIP

Outcome = tuple[str, str]


def cut(problems: list[str], n: int = 6) -> str:
    return "; ".join(problems[:n]) + (f"; ... ({len(problems) - n} more)" if len(problems) > n else "")


def check_archive(arc: FmuArchive) -> Outcome:
    """static.archive, static3.archive: the archive was read within the limits, its names safe."""
    if arc.error:
        return FAIL, arc.error
    return PASS, (f"{len(arc.members)} members, {arc.unpacked / 1024 ** 2:.2f} MiB unpacked, names safe, "
                  f"within the limits")


def start_range(items: Iterable[tuple[str, str, Callable[[str], list[float]], str | None, str | None]],
                more: Callable[[list[str]], str]) -> Outcome:
    """static.start-range, static3.start-range: ``items`` are (name, start text, its numbers, min, max) of the
    variables with a start value (min/max their own, else their declared type's); ``more`` joins the problems."""
    problems, n = [], 0
    for name, start, numbers, lo, hi in items:
        if lo is None and hi is None:
            continue
        n += 1
        try:
            xs = numbers(start)
            below = [x for x in xs if lo is not None and x < float(lo)]
            above = [x for x in xs if hi is not None and x > float(hi)]
        except ValueError:
            problems.append(f"{name}: start/min/max not numbers ({start!r}, {lo!r}, {hi!r})")
            continue
        if below or above:
            x = (below or above)[0]
            shown = start if len(xs) == 1 else f"{x:g}"
            problems.append(f"{name} start = {shown} {'<' if below else '>'} {'min' if below else 'max'} = "
                            f"{lo if below else hi}")
    if not n:
        return SKIP, "no start value with a min or max"
    if problems:
        return FAIL, f"{len(problems)} of {n} start values outside min/max: " + more(problems)
    return PASS, f"all {n} start values with a min or max lie within them"
