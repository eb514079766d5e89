"""Text that reaches the terminal: values echoed in messages, and control characters.

* :func:`shown` is how a message echoes a value it got from a file or the command line: its
  ``repr``, cut to :data:`SHOWN` characters with the whole length stated (a 1 MB name gives a short
  line, not a 1 MB one).
* :func:`printable` writes every control character (C0, DEL, C1; escape codes, carriage returns,
  bells) as ``\\xNN``, as the JUnit report does, so text from a scene cannot clear the screen or
  rewrite a line; :func:`one_line` also writes line ends that way.
"""
from __future__ import annotations

import re

SHOWN = 200           # characters of a value echoed in a message (a long path still fits)
LINE = 2000           # characters of one message line at most

_CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f]")
_CONTROL_NL = re.compile(r"[\x00-\x1f\x7f-\x9f]")


def _escape(m: re.Match) -> str:
    return f"\\x{ord(m.group()):02x}"


def cut(text: str, limit: int = SHOWN) -> str:
    """``text`` itself (no quotes), at most ``limit`` characters; a longer one is cut and says its length."""
    text = str(text)
    return text if len(text) <= limit else f"{text[:limit - 3]}... ({len(text):,} characters)"


def shown(value, limit: int = SHOWN) -> str:
    """``repr(value)``, at most ``limit`` characters; a longer one is cut and says its length."""
    r = repr(value)
    if len(r) <= limit:
        return r
    size = f"{len(value):,} characters" if isinstance(value, str) else f"{len(r):,} characters as written"
    return f"{r[:limit - 3]}... ({size})"


def printable(text: str) -> str:
    """``text`` with every control character but the line end and the tab written as ``\\xNN``."""
    return _CONTROL.sub(_escape, str(text))


def one_line(text: str, limit: int = LINE) -> str:
    """``text`` as one printable line of at most ``limit`` characters (cut ones say their length)."""
    t = _CONTROL_NL.sub(_escape, str(text))
    return t if len(t) <= limit else f"{t[:limit - 3]}... ({len(t):,} characters)"
