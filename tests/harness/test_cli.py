"""The command line (harness/cli/): one module per command, every command answers -h, and no
argparse anywhere else in the harness."""
from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

from harness.cli import COMMANDS, main

HARNESS = Path(__file__).resolve().parents[2] / "harness"


@pytest.mark.parametrize("command", list(COMMANDS))
def test_every_command_has_its_module_and_answers_help(command, capsys):
    module = importlib.import_module(f"harness.cli.{COMMANDS[command][0]}")
    try:
        code = module.main(["-h"])
    except SystemExit as e:   # argparse leaves after the help; check and sweep return its code
        code = e.code
    assert code == 0
    assert f"spurdiff {command}" in capsys.readouterr().out


def test_an_unknown_command_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as e:
        main(["frobnicate"])
    assert e.value.code == 2 and "invalid choice: 'frobnicate'" in capsys.readouterr().err


def test_argparse_lives_only_in_the_cli_package():
    # harness/interop/recipes/ are standalone scripts a user copies out (spurdiff starter): their own command
    # lines, and they import nothing from this package (checked below)
    users = sorted(str(p.relative_to(HARNESS)) for p in HARNESS.rglob("*.py")
                   if re.search(r"^\s*(import argparse|from argparse import)", p.read_text(), re.M))
    assert users and all(u.startswith(("cli/", "interop/recipes/")) for u in users), users
    for p in (HARNESS / "interop" / "recipes").glob("*.py"):
        assert not re.search(r"^\s*(from|import) (harness|spurdiff)\b", p.read_text(), re.M), p.name


@pytest.mark.parametrize("module", ["mesh_bench", "rigid_kernel_bench", "vehicle_kernel_bench"])
def test_bench_modules_answer_help(module, capsys):
    """The benchmark modules' command lines (``python -m harness.cli.tools.<name>``) answer -h."""
    with pytest.raises(SystemExit) as e:
        importlib.import_module(f"harness.cli.tools.{module}").main(["-h"])
    assert e.value.code == 0 and f"python -m harness.cli.tools.{module}" in capsys.readouterr().out


@pytest.mark.parametrize("module", ["rigid_kernel_bench", "vehicle_kernel_bench"])
def test_kernel_benches_reject_zero_rounds(module, capsys):
    with pytest.raises(SystemExit) as e:
        importlib.import_module(f"harness.cli.tools.{module}").main(["--rounds", "0"])
    assert e.value.code == 2 and "--rounds must be >= 1, got 0" in capsys.readouterr().err
