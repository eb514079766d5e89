"""Issue 46.4: long work says what it does (harness.common.progress): a line when a stage starts, plain
lines while it runs when not on a terminal, a bar on a terminal, and the time it took."""
from __future__ import annotations

import io
import time

import pytest

from harness.common import progress


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_plain_lines_while_a_stage_runs(monkeypatch):
    monkeypatch.setattr(progress, "HEARTBEAT", 0.05)
    out = io.StringIO()
    with progress.stage("building X.fmu", expected=35, stream=out):
        time.sleep(0.3)
    lines = out.getvalue().splitlines()
    assert lines[0] == "spurdiff: building X.fmu (about 35 s)..."
    assert any(ln.startswith("spurdiff: building X.fmu: ") and ln.endswith("s so far") for ln in lines[1:-1])
    assert lines[-1].startswith("spurdiff: building X.fmu: done in ")
    assert "\r" not in out.getvalue() and "#" not in out.getvalue()


def test_a_bar_on_a_terminal_and_inner_stages_report_alone(monkeypatch):
    monkeypatch.setattr(progress, "REDRAW", 0.02)
    out = _Tty()
    with progress.stage("outer", expected=1, stream=out):
        with progress.stage("inner", expected=1, stream=out):
            time.sleep(0.2)
    text = out.getvalue()
    assert "\r  [" in text and "of about 1 s" in text
    assert "spurdiff: inner: done in" in text and "spurdiff: outer: done in" in text


def test_a_failing_stage_says_so_and_the_error_passes(monkeypatch):
    out = io.StringIO()
    with pytest.raises(RuntimeError):
        with progress.stage("x", stream=out):
            raise RuntimeError("boom")
    assert out.getvalue().splitlines()[-1].startswith("spurdiff: x: stopped in ")


def test_off_with_the_environment(monkeypatch):
    monkeypatch.setenv("SPURDIFF_PROGRESS", "0")
    out = io.StringIO()
    with progress.stage("x", stream=out):
        pass
    assert out.getvalue() == ""


def test_bar_text():
    assert progress.bar(0.0, 10.0, width=10) == "[..........] 0 s of about 10 s"
    assert progress.bar(100.0, 10.0, width=10).startswith("[##########]")
    assert progress.bar(3.0, None) == "3 s"
