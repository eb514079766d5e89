"""The mutation runner (harness/measure/mutate.py, ``spurdiff mutate``) on a toy repository: one mutation its
test catches, one it does not; the clone is private and removed, the repository untouched; a list
whose snippet is not in its file, or a field missing, is refused by name. The project's own list
(tests/mutations.toml) loads and each snippet occurs exactly once in its file."""
from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from harness.measure import mutate
from harness.cli.mutate import main

ROOT = Path(__file__).resolve().parents[2]
LIST = """
[settings]
pythonpath = ["."]
probe = ["toy"]

[[mutation]]
id = "sum-sign"
file = "toy/__init__.py"
original = "return a + b"
replacement = "return a - b"
tests = ["tests/test_toy.py"]
reason = "the sum"

[[mutation]]
id = "dead-branch"
file = "toy/__init__.py"
original = "if a is None:"
replacement = "if a is None and b is None:"
tests = ["tests/test_toy.py"]
reason = "a branch no test reaches"
timeout = 120
"""


@pytest.fixture()
def toy(tmp_path) -> Path:
    repo = tmp_path / "toy_repo"
    (repo / "toy").mkdir(parents=True)
    (repo / "tests").mkdir()
    (repo / "toy" / "__init__.py").write_text("def add(a, b):\n    if a is None:\n        raise ValueError('a')\n"
                                              "    return a + b\n")
    (repo / "tests" / "test_toy.py").write_text("from toy import add\n\n\ndef test_add():\n    assert add(2, 3) == 5\n")
    (repo / "mutations.toml").write_text(LIST)
    for cmd in (["init", "-q"], ["add", "."], ["-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "toy"]):
        subprocess.run(["git", *cmd], cwd=repo, check=True)
    return repo


def test_one_caught_one_survived_and_the_clone_is_private_and_gone(toy, monkeypatch):
    made = []
    real_clone = mutate.clone

    def watched_clone(repo):
        base = real_clone(repo)
        made.append((base, base.stat().st_mode & 0o777))
        return base

    monkeypatch.setattr(mutate, "clone", watched_clone)
    lines = []
    outcomes, base = mutate.run(toy, toy / "mutations.toml", report=lines.append)
    assert base.verdict == "passed"
    assert [(o.id, o.verdict) for o in outcomes] == [("sum-sign", "caught"), ("dead-branch", "survived")]
    assert all(o.seconds > 0.0 for o in outcomes) and len(lines) == 3
    (folder, mode), = made
    assert mode == 0o700 and not folder.exists()
    assert "return a + b" in (toy / "toy" / "__init__.py").read_text()     # the repository itself untouched
    text = mutate.table(outcomes)
    assert "sum-sign" in text and "1 caught, 1 survived" in text


def test_the_command_exits_1_on_a_survivor_and_0_with_only_caught_ones(toy, capsys):
    assert main(["--repo", str(toy), "--list", str(toy / "mutations.toml"), "--no-baseline"]) == 1
    out = capsys.readouterr().out
    assert "dead-branch" in out and "survived" in out and "total" in out
    assert main(["--repo", str(toy), "--list", str(toy / "mutations.toml"), "--only", "sum-sign"]) == 0


@pytest.mark.parametrize("change, words", [
    (("return a + b", "return a * b + 0"), "occurs 0 times"),
    (('reason = "the sum"\n', ""), "'reason' is missing"),
    (('id = "dead-branch"', 'id = "sum-sign"'), "used twice"),
])
def test_a_bad_list_is_refused_naming_the_entry(toy, capsys, change, words):
    bad = toy / "bad.toml"
    bad.write_text(LIST.replace(*change, 1))
    assert main(["--repo", str(toy), "--list", str(bad), "--no-baseline"]) == 2
    assert words in capsys.readouterr().err


def test_an_unknown_only_id_is_refused(toy, capsys):
    assert main(["--repo", str(toy), "--list", str(toy / "mutations.toml"), "--only", "nope"]) == 2
    assert "no mutation nope" in capsys.readouterr().err


@pytest.mark.parametrize("name, at_least", [("mutations.toml", 20), ("mutations_guards.toml", 20)])
def test_the_projects_list_loads_and_every_snippet_is_in_its_file_once(name, at_least):
    settings, ms = mutate.load(ROOT / "tests" / name)
    assert len(ms) >= at_least and settings.packages == {"spurdiff_fmus": "fmu_src"}
    mutate.check_snippets(ROOT, ms)
    for m in ms:
        for t in m.tests:
            assert (ROOT / t.split("::")[0]).is_file(), (m.id, t)


def test_verdicts_from_the_exit_code_and_the_summary():
    assert mutate.verdict(1, "1 failed, 3 passed in 2.0s") == "caught"
    assert mutate.verdict(0, "3 passed, 1 skipped in 2.0s") == "survived"
    assert mutate.verdict(0, "2 skipped in 1.3s") == "skipped"      # nothing ran: no verdict on the bug
    assert mutate.verdict(None) == "timeout" and mutate.verdict(5, "no tests ran") == "error"
