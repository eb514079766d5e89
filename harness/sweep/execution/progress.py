"""The sweep's progress line."""
from __future__ import annotations

import sys
import time

class ProgressBar:
    """One line on stderr: runs done of total, failures, elapsed and estimated time left."""

    def __init__(self, total: int, done: int = 0, failed: int = 0, stream=None, enabled: bool = True):
        self.total, self.done, self.failed = total, done, failed
        self.start_done = done
        self.stream = stream or sys.stderr
        self.enabled = enabled and total > 0
        self.tty = getattr(self.stream, "isatty", lambda: False)()
        self.t0 = time.perf_counter()
        self._last_decile = -1

    def update(self, row: dict) -> None:
        self.done += 1
        self.failed += row["status"] != "ok"
        if not self.enabled:
            return
        decile = int(10 * self.done / self.total)
        if self.tty or decile != self._last_decile or self.done == self.total:
            self._last_decile = decile
            self.stream.write(("\r" if self.tty else "") + self.line() + ("" if self.tty else "\n"))
            if self.tty and self.done == self.total:
                self.stream.write("\n")
            self.stream.flush()

    def line(self) -> str:
        el = time.perf_counter() - self.t0
        ran = self.done - self.start_done
        left = (self.total - self.done) * el / ran if ran else float("nan")
        frac = self.done / self.total
        n = int(30 * frac)
        return (f"sweep [{'#' * n}{'.' * (30 - n)}] {self.done}/{self.total} runs, {self.failed} failed, "
                f"{el:6.1f} s, ~{left:5.1f} s left")
