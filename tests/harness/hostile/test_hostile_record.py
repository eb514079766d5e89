"""Issue 45 item 5 (low): a scene with 100,000 ``record`` entries ran for minutes (every CSV row
formatted 100,000 columns). The record list is read each entry once (in order) and refused above
``harness.scene.spec.MAX_RECORD`` entries with one line."""
from __future__ import annotations

from hostile_harness_util import cli, one_line_error, sandbox, scene  # noqa: F401

from harness.scene.spec import MAX_RECORD, load_scene


def _record(n: int, var: str = "diff.carrier.tauDrive") -> str:
    return "record = [" + ",".join(f'"{var}"' for _ in range(n)) + "]"


def test_a_record_list_over_the_limit_is_refused_with_one_line(sandbox, capsys):
    path = scene(sandbox.dir, _record(100_000))
    r = cli(capsys, "run", path, "--no-plots", "--out", sandbox.dir / "out")
    one_line_error(r, "record has 100,000 entries", f"allowed: at most {MAX_RECORD:,}")
    assert not (sandbox.dir / "out").exists()


def test_the_limit_itself_is_accepted_and_each_variable_recorded_once(sandbox):
    s = load_scene(str(scene(sandbox.dir, _record(MAX_RECORD))))
    assert s.record.count("diff.carrier.tauDrive") == 1
    assert len(s.record) == len(set(s.record))


def test_one_entry_over_the_limit_is_refused(sandbox, capsys):
    r = cli(capsys, "run", scene(sandbox.dir, _record(MAX_RECORD + 1)), "--no-plots", "--out", sandbox.dir / "o")
    one_line_error(r, f"record has {MAX_RECORD + 1:,} entries")
