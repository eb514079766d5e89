"""Issue 14, item 2: a name becomes a file name only after validation (scene ``name`` for ``run``
and ``export-ssp``, sweep ``name`` and plot ``file``)."""
from __future__ import annotations

import pytest

from hostile_harness_util import cli, one_line_error, sandbox, scene, sweep  # noqa: F401

BAD_NAMES = ["../../escaped", "a/b", "/tmp/abs", "..", "a\\\\b", ".hidden", "x" * 101, ""]


@pytest.mark.parametrize("name", BAD_NAMES)
def test_scene_name_that_is_not_a_plain_file_name_is_refused_by_run(sandbox, capsys, name):
    p = scene(sandbox.dir, "", name=name, filename="named.toml")
    out = sandbox.dir / "out" / "a" / "b"
    r = cli(capsys, "run", p, "--duration", "0.05", "--no-plots", "--out", out)
    one_line_error(r, "named.toml: name = ", "allowed letters, digits")
    assert list(sandbox.dir.rglob("*.csv")) == []


def test_scene_name_with_dots_is_refused_by_run_without_out(sandbox, capsys):
    """Default output folder results/<name>: '../..' would leave the repository."""
    p = scene(sandbox.dir, "", name="../../escaped", filename="named.toml")
    r = cli(capsys, "run", p, "--duration", "0.05", "--no-plots")
    one_line_error(r, "named.toml: name = '../../escaped'")


@pytest.mark.parametrize("name", ["../../escaped", "a/b"])
def test_scene_name_is_refused_by_export_ssp(sandbox, capsys, name):
    p = scene(sandbox.dir, "", name=name, filename="named.toml")
    r = cli(capsys, "export-ssp", p)
    one_line_error(r, "named.toml: name = ", "allowed letters, digits")


def test_default_ssp_path_validates_a_programmatic_scene_name():
    from dataclasses import replace

    from harness.scene.spec import SceneError, load_scene
    from harness.interop.ssp import default_output

    sc = replace(load_scene("paper-cornering"), name="../../escaped")
    with pytest.raises(SceneError, match="scene name = '../../escaped'"):
        default_output(sc)


def test_sweep_name_and_plot_file_are_validated(sandbox, capsys):
    p = sweep(sandbox.dir, '[[metrics]]\nname = "lt"\nvar = "diff.lockingTorque"\nstat = "mean"', name="ok")
    text = p.read_text().replace('name = "ok"', 'name = ".."', 1)
    p.write_text(text)
    r = cli(capsys, "sweep", p, "--workers", "0", "--quiet")
    one_line_error(r, "ok.toml: name = '..'")
    p.write_text(text.replace('name = ".."', 'name = "ok"', 1)
                 + '[[plots]]\nx = "diff.mu_pin"\ny = "lt"\nfile = "../../escaped"\n')
    r = cli(capsys, "sweep", p, "--workers", "0", "--quiet", "--out", sandbox.dir / "out")
    one_line_error(r, "ok.toml: plots.file = '../../escaped'")
