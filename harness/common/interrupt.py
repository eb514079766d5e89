"""Ctrl-C during a run: the run stops at its next communication step and keeps what it recorded.

:func:`stop_on_sigint` turns SIGINT into the event :data:`STOP`, which the masters and the sweep's
serial executor look at between steps; a run stopped that way ends with :class:`Interrupted`.
"""
from __future__ import annotations

import contextlib
import signal
import threading


class Interrupted(KeyboardInterrupt):
    """The user interrupted the run (Ctrl-C) at ``time``; what was recorded before is kept."""

    def __init__(self, time_: float):
        self.instance, self.time, self.reason = "master", time_, "interrupted"
        super().__init__(f"interrupted at t = {time_:.6g} s")


STOP = threading.Event()   # set by the SIGINT handler of stop_on_sigint; runs stop at the next step


@contextlib.contextmanager
def stop_on_sigint():
    """While active, Ctrl-C (SIGINT) sets :data:`STOP` instead of raising KeyboardInterrupt wherever
    the interpreter happens to be (inside an FMU's own Python code, which would turn it into an FMU
    error): the master stops at the next communication step and raises :class:`Interrupted`.
    A second Ctrl-C raises KeyboardInterrupt at once. An inherited 'ignore SIGINT' is respected."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.getsignal(signal.SIGINT)
    if old is signal.SIG_IGN:
        yield
        return

    def handler(signum, frame):
        if STOP.is_set():
            raise KeyboardInterrupt
        STOP.set()

    STOP.clear()
    signal.signal(signal.SIGINT, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
        STOP.clear()
