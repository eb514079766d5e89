"""``spurdiff design``: the proposal, what it changed, the data file it writes, one line and a
non-zero exit for bad input (an endless --input, bad values in it, a symlinked --write target)."""
import os
import tomllib

import pytest

from harness.cli import main
from spurdiff.datafile import DATA_FOLDER


def test_scene_parameters_select_the_designed_set(capsys):
    from spurdiff.gears.design_sets import gear_set, table_from_data

    assert main(["design", "--centre-distances", "72.5,77.5,40.75", "--scene-parameters"]) == 0
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
    assert main(["design", "--centre-distances", "72.5,77.5,40.75", "--torque", "2100", "--write", str(out)]) == 0
    text = capsys.readouterr().out
    # with the margins the only finding left is the axial layout's (mesh B2 on 17 of 22 mm)
    assert "design checks of the proposed set: 0 errors, 1 warnings" in text
    assert "WARNING mesh-width: mesh B2" in text
    assert "usable contact ratio 1.011 -> 1.175" in text            # mesh B2, paper -> proposed
    assert "ISO 6336 capacity of the proposed set" in text
    assert "limited life over the duty cycle" in text
    # the input (paper's) set: its honest findings with the margins
    for check in ("undercut:", "specific-sliding:", "tip-clearance:", "tip-interference:"):
        assert f"WARNING {check}" in text
    assert oct(out.stat().st_mode & 0o777) == oct(0o666 & ~_umask())
    written = tomllib.loads(out.read_text())
    bundled = tomllib.loads((DATA_FOLDER / "gear_set_designed.toml").read_text())
    assert written == bundled


@pytest.mark.parametrize("args,needle", [
    (["--teeth", "-5,13,36,13"], "sunA.z = -5 is invalid: allowed an integer from 6 to 400"),
    (["--teeth", "36,13,36"], "--teeth"),
    (["--centre-distances", "71.5,76.5,39"], "a12 = 0.039 is invalid: allowed >= 0.040523 m"),
    (["--centre-distances", "71.5,76.5,-4"], "a12 = -0.004 is invalid"),
    (["--centre-distances", "71.5,76.5,nan"], "finite"),
    (["--eps-min", "3"], "--eps-min"),
    (["--sliding", "0"], "--sliding"),
    (["--undercut-margin", "nan"], "--undercut-margin"),
    (["--clearance", "-1"], "--clearance"),
    (["--backlash", "0.1,0.1"], "--backlash"),
    (["--backlash", "0.1,0.1,5"], "mesh12.backlash"),
    (["--centre-distances", "72.5,77.5,40.75", "--torque", "inf"], "--torque"),
    (["--centre-distances", "72.5,77.5,40.75", "--torque", "2100", "--pin-diameter", "nan"], "--pin-diameter"),
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


def _umask() -> int:
    m = os.umask(0o022)
    os.umask(m)
    return m


def _one_line(capsys, argv, needle):
    rc = main(["design", *argv])
    err = capsys.readouterr().err
    assert rc != 0
    assert len(err.strip().splitlines()) == 1 and needle in err, err
    assert "Traceback" not in err
    return err


def test_input_from_an_endless_device_is_refused_without_reading_it_all(capsys):
    """--input /dev/zero grew to gigabytes: now at most MAX_INPUT bytes are read, then one line."""
    from harness.cli.design import MAX_INPUT
    err = _one_line(capsys, ["--input", "/dev/zero"], "--input = '/dev/zero' is invalid")
    assert f"at most {MAX_INPUT} bytes" in err


def test_a_large_or_bad_input_file_is_one_line(tmp_path, capsys):
    from harness.cli.design import MAX_INPUT
    big = tmp_path / "big.toml"
    big.write_text("# " + "x" * MAX_INPUT)
    _one_line(capsys, ["--input", str(big)], "at most")
    for text, needle in (('[sunA]\nz = "many"\n', "--input sunA.z = 'many' is invalid: allowed an integer"),
                         ("[planet1]\nx = [1, 2]\n", "--input planet1.x = [1, 2] is invalid: allowed a number"),
                         ("[sunA]\nz = -3\n", "--input sunA.z = -3 is invalid"),
                         ("[planet1]\nb = 1e400\n", "--input planet1.b"),
                         ("[planet2]\nx = nan\n", "--input planet2.x"),
                         ("[carrier]\nwallB = -1.0\n", "--input carrier.wallB"),
                         ("[sunB]\nbogus = 1\n", "--input sunB.bogus"),
                         ("nPairs = 3.5\n", "--input nPairs = 3.5 is invalid: allowed an integer"),
                         ("[sunA\n", "a readable TOML gear set"),
                         (b"\xff\xfe".decode("latin-1"), "--input")):
        f = tmp_path / "bad.toml"
        f.write_text(text, encoding="latin-1")
        _one_line(capsys, ["--input", str(f)], needle)
    _one_line(capsys, ["--input", str(tmp_path / "missing.toml")], "--input")


def test_write_refuses_a_symlink_and_writes_through_a_private_name(tmp_path, capsys):
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    link = tmp_path / "set.toml"
    link.symlink_to(victim)
    _one_line(capsys, ["--centre-distances", "72.5,77.5,40.75", "--write", str(link)], "not a symbolic link")
    assert victim.read_text() == "keep me" and link.is_symlink()
    folder = tmp_path / "sub"
    folder.mkdir()
    _one_line(capsys, ["--centre-distances", "72.5,77.5,40.75", "--write", str(folder)], "a regular file")
    out = tmp_path / "ok.toml"
    out.write_text("old")
    assert main(["design", "--centre-distances", "72.5,77.5,40.75", "--write", str(out)]) == 0
    assert out.read_text().startswith("# The designed gear set")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ok.toml", "set.toml", "sub", "victim.txt"]   # no temp left
