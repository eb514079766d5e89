"""``spurdiff design``: the proposal, what it changed, the data file it writes, one line and a
non-zero exit for bad input."""
import tomllib

import pytest

from harness.cli import main
from spurdiff.datafile import DATA_FOLDER


def test_scene_parameters_select_the_designed_set(capsys):
    from spurdiff.gears.design_sets import gear_set, table_from_data

    assert main(["design", "--centre-distances", "71.5,76.5,40.5", "--scene-parameters"]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("scene parameters"))
    params = tomllib.loads("p = " + line.split(": ", 1)[1])["p"]
    nested = {}
    for k, v in params.items():
        if "." in k:
            sec, key = k.split(".", 1)
            nested.setdefault(sec, {})[key] = v
        else:
            nested[k] = v
    assert table_from_data(nested) == gear_set("designed")


def test_design_prints_the_changes_and_writes_the_bundled_set(tmp_path, capsys):
    out = tmp_path / "set.toml"
    assert main(["design", "--centre-distances", "71.5,76.5,40.5", "--torque", "2100", "--write", str(out)]) == 0
    text = capsys.readouterr().out
    assert "design checks of the proposed set: 0 errors, 0 warnings" in text
    assert "usable contact ratio 1.011 -> 1.341" in text            # mesh B2, paper -> proposed
    assert "ISO 6336 capacity of the proposed set" in text
    written = tomllib.loads(out.read_text())
    bundled = tomllib.loads((DATA_FOLDER / "gear_set_designed.toml").read_text())
    assert written == bundled


@pytest.mark.parametrize("args,needle", [
    (["--teeth", "-5,13,36,13"], "sunA.z = -5 is invalid: allowed an integer from 6 to 400"),
    (["--teeth", "36,13,36"], "--teeth"),
    (["--centre-distances", "71.5,76.5,39"], "a12 = 0.039 is invalid: allowed >= 0.040292 m"),
    (["--centre-distances", "71.5,76.5,-4"], "a12 = -0.004 is invalid"),
    (["--centre-distances", "71.5,76.5,nan"], "finite"),
    (["--eps-min", "3"], "--eps-min"),
    (["--bogus"], "unrecognized arguments"),
])
def test_bad_input_is_one_line_and_nonzero(args, needle, capsys):
    with pytest.raises(SystemExit) if args == ["--bogus"] else _no_raise() as e:
        rc = main(["design", *args])
    if args == ["--bogus"]:
        rc = e.value.code
    err = capsys.readouterr().err
    assert rc != 0
    assert len(err.strip().splitlines()) == 1 and needle in err


class _no_raise:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False
