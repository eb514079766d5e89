"""Progress of long work (an FMU build, the runtime bundling, the win64 download), on stderr.

``with stage("building SpurDifferential.fmu", expected=35):`` says what starts, then while it runs:
on a terminal a progress bar against the expected duration, redrawn every half second; otherwise
(a log, CI) a plain line every :data:`HEARTBEAT` seconds; at the end one line with the time it took.
Nothing is written for work that is not done (an FMU that is up to date). ``SPURDIFF_PROGRESS=0``
turns it off (stdout, where results and messages go, is never used).
"""
from __future__ import annotations

import os
import sys
import threading
import time
from contextlib import contextmanager
from typing import Iterator, TextIO

HEARTBEAT = 5.0      # s between plain lines while a stage runs (not a terminal)
REDRAW = 0.5         # s between redraws of the bar (a terminal)
WIDTH = 24           # characters of the bar
_open: list[str] = []   # the stages running, outermost first: only the innermost one reports


def enabled() -> bool:
    return os.environ.get("SPURDIFF_PROGRESS", "1") not in ("0", "", "false", "no")


def bar(elapsed: float, expected: float | None, width: int = WIDTH) -> str:
    """``[#####.....] 12 s of about 35 s`` (the bar stops short of full while the work runs on)."""
    if not expected:
        return f"{elapsed:.0f} s"
    frac = min(elapsed / expected, 0.97)
    n = int(round(frac * width))
    return f"[{'#' * n}{'.' * (width - n)}] {elapsed:.0f} s of about {expected:.0f} s"


@contextmanager
def stage(what: str, expected: float | None = None, stream: TextIO | None = None) -> Iterator[None]:
    """Report ``what`` while the block runs (see the module docstring); ``expected``: seconds it
    usually takes (shown, and the bar's length)."""
    out = stream or sys.stderr
    if not enabled():
        yield
        return
    tty = bool(getattr(out, "isatty", lambda: False)())
    t0 = time.monotonic()
    about = f" (about {expected:.0f} s)" if expected else ""
    print(f"spurdiff: {what}{about}...", file=out, flush=True)
    done = threading.Event()

    def beat() -> None:
        while not done.wait(REDRAW if tty else HEARTBEAT):
            if _open[-1:] != [what]:
                continue       # an inner stage reports
            el = time.monotonic() - t0
            if tty:
                out.write(f"\r  {bar(el, expected)}")
            else:
                out.write(f"spurdiff: {what}: {el:.0f} s so far\n")
            out.flush()

    if tty and _open:
        out.write("\n")
    _open.append(what)
    th = threading.Thread(target=beat, name="spurdiff-progress", daemon=True)
    th.start()
    ok = False
    try:
        yield
        ok = True
    finally:
        done.set()
        th.join()
        _open.remove(what)
        el = time.monotonic() - t0
        end = "\r" + " " * (WIDTH + 40) + "\r" if tty else ""
        print(f"{end}spurdiff: {what}: {'done' if ok else 'stopped'} in {el:.1f} s", file=out, flush=True)


__all__ = ["bar", "enabled", "stage"]
