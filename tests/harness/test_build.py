"""harness/build/fmu.py: the C compiler is found or named (a CC that does not exist is a one-line
BuildError, and the build falls back with a warning instead of a traceback)."""
from __future__ import annotations

import shutil

import pytest

from harness.build.fmu import BuildError, c_compiler


def test_a_cc_that_does_not_exist_is_named(monkeypatch):
    monkeypatch.setenv("CC", "/nonexistent/cc")
    with pytest.raises(BuildError, match=r"CC = '/nonexistent/cc' is not an executable"):
        c_compiler()


@pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler here")
def test_cc_may_name_a_command_on_path(monkeypatch):
    name = "cc" if shutil.which("cc") else "gcc"
    monkeypatch.setenv("CC", name)
    assert c_compiler() == shutil.which(name)
    monkeypatch.delenv("CC")
    assert c_compiler() in (shutil.which("cc"), shutil.which("gcc"))


def test_no_compiler_on_path_is_named(monkeypatch):
    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setenv("PATH", "/nonexistent")
    with pytest.raises(BuildError, match=r"no C compiler \(cc/gcc\) on PATH"):
        c_compiler()
