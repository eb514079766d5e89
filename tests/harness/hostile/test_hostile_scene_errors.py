"""Issue 14, item 15 (harness part): a scene with a value of the wrong type, a file that is not
UTF-8, an ``extends`` cycle through paths or a parameter the FMU refuses ends with one line naming
the key, not a traceback; a relative ``extends`` is read from the scene's own folder."""
from __future__ import annotations

import os

import pytest

from hostile_harness_util import BASE_SCENE, cli, one_line_error, sandbox, scene  # noqa: F401


@pytest.mark.parametrize("body, words", [
    ('algorithm = ["jacobi"]', ["algorithm = ['jacobi']", "allowed: gauss-seidel, jacobi"]),
    ("inputs = [1]", ["inputs = [1]", "allowed a table"]),
    ("checks = 5", ["checks = 5", "allowed an array of tables"]),
    ('[[checks]]\nname = "w"\nstat = "max"\nvar = "diff.left.tauMesh"\nwindow = "all"\nbelow = 1',
     ["checks 'w'.window = 'all'", "allowed [t0, t1]"]),
    ('[[checks]]\nname = "w"\nstat = "max"\nvar = "diff.left.tauMesh"\nbelow = "high"',
     ["checks 'w'.below = 'high'", "allowed a finite number"]),
    ('[[checks]]\nname = "w"\nstat = "max"\nvar = 3\nbelow = 1', ["checks 'w'.var = 3", "allowed a string"]),
    ('[[table]]\nlabel = "t"\nvar = "diff.left.tauMesh"\nscale = "big"', ["table 't'.scale = 'big'"]),
    ("record = \"diff.left.tauMesh\"", ["record = 'diff.left.tauMesh'", "allowed a list of strings"]),
    ("duration = \"long\"", ["duration = 'long'", "allowed a number > 0"]),
    ("step = true", ["step = True", "allowed a number > 0"]),
    ("description = 5", ["description = 5", "allowed a string"]),
    ("couplings = 1", ["couplings = 1", "allowed an array of tables"]),
    ("order = 1", ["order = 1", "allowed a list of strings"]),
    ("effects = 1", ["effects = 1", "allowed a table"]),
    ('[fmus.diff]\nparameters = 7', ["fmus.diff.parameters = 7", "allowed a table"]),
    ('[inputs."diff.left.tau"]\ntable = 5', ["table: allowed a list of [time, value] pairs"]),
    ('[inputs."diff.left.tau"]\ntable = [[0, 1]]\nstep = {time = 1}', ["give one of 'table' or 'step'"]),
])
def test_scene_value_of_the_wrong_type_is_one_line_naming_the_key(sandbox, capsys, body, words):
    p = scene(sandbox.dir, body)
    r = cli(capsys, "run", p, "--duration", "0.05", "--no-plots", "--out", sandbox.dir / "out")
    one_line_error(r, "hostile.toml", *words)
    assert not (sandbox.dir / "out").exists()


def test_scene_that_is_not_utf8_is_one_line(sandbox, capsys):
    p = sandbox.dir / "latin1.toml"
    p.write_bytes(b'name = "caf\xe9"\nduration = 0.05\n')
    r = cli(capsys, "run", p, "--no-plots", "--out", sandbox.dir)
    one_line_error(r, "latin1.toml: not UTF-8 text")


def test_extends_cycle_through_paths_is_one_line(sandbox, capsys):
    (sandbox.dir / "a.toml").write_text('name = "a"\nextends = "./sub/../b.toml"\n')
    (sandbox.dir / "b.toml").write_text(f'name = "b"\nextends = "{sandbox.dir / "a.toml"}"\n')
    (sandbox.dir / "sub").mkdir()
    r = cli(capsys, "run", sandbox.dir / "a.toml", "--no-plots", "--out", sandbox.dir)
    one_line_error(r, "extends makes a cycle: a.toml -> b.toml -> a.toml")
    (sandbox.dir / "self.toml").write_text('name = "s"\nextends = "self.toml"\n')
    r = cli(capsys, "run", sandbox.dir / "self.toml", "--no-plots", "--out", sandbox.dir)
    one_line_error(r, "self.toml: extends makes a cycle")


def test_relative_extends_is_read_from_the_scenes_folder(sandbox, capsys, fmu_files):
    folder = sandbox.dir / "scenes"
    folder.mkdir()
    (folder / "base.toml").write_text(BASE_SCENE.read_text().replace('name = "paper-cornering"', 'name = "base"'))
    (folder / "child.toml").write_text('name = "child"\nextends = "base.toml"\nduration = 0.05\n')
    here = os.getcwd()
    os.chdir(sandbox.dir)   # not the scene's folder
    try:
        r = cli(capsys, "run", "scenes/child.toml", "--no-plots", "--out", sandbox.dir / "out")
    finally:
        os.chdir(here)
    assert r.rc == 0, r.err
    assert (sandbox.dir / "out" / "child.csv").exists()
    (folder / "orphan.toml").write_text('name = "o"\nextends = "missing.toml"\n')
    r = cli(capsys, "run", folder / "orphan.toml", "--no-plots", "--out", sandbox.dir / "out")
    one_line_error(r, "scene file", "missing.toml", "not found")


def test_parameter_the_fmu_refuses_is_one_line_naming_it(sandbox, capsys, fmu_files):
    """gearing.m = 1e6 raised 'math domain error' inside the FMU: the harness names what was set."""
    r = cli(capsys, "run", "paper-cornering", "--duration", "0.05", "--no-plots", "--out", sandbox.dir,
            "--set", "diff.gearing.m=1e6")
    line = one_line_error(r, "diff failed at t = 0 s", "gearing.m", "nothing recorded", rc=1)
    assert "math domain error" not in line or "gearing.m" in line
