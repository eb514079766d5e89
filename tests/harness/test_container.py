"""Issue 46.2: ``spurdiff export-container SCENE``, the coupled scene as one FMU (an FMU container of
fmu-manipulation-toolbox, whose C runtime steps the scene's FMUs), run in fmpy beside our master."""
from __future__ import annotations

import zipfile
import xml.etree.ElementTree as ET

import pytest

from harness.interop import container
from harness.run.runner import prepare_scene


def test_description_carries_the_scene():
    scene = prepare_scene("vehicle-cornering")
    d = container.description(scene)
    names = container.embedded_names(scene)
    assert d["fmu"] == [names[i.name] for i in scene.instances]          # the scene's Gauss-Seidel order
    assert d["sequential"] is True and d["step_size"] == scene.step
    assert len(d["link"]) == len(scene.connections)
    assert ["diff_SpurDifferential.fmu", "shaftCoupling", "wheel"] in d["start"]
    assert ["diff_SpurDifferential.fmu", "J_carrier", 13.1] in d["start"]
    assert all(o[2] in scene.record for o in d["output"])


def test_a_missing_toolbox_is_one_line(monkeypatch, capsys):
    from harness.cli import export_container as cli
    monkeypatch.setattr(container, "_toolbox", lambda: (_ for _ in ()).throw(
        container.ContainerError("fmu-manipulation-toolbox is not installed (pip install fmu-manipulation-toolbox)")))
    monkeypatch.setattr("harness.run.runner.fmu_files_for", lambda scene, **kw: {})
    assert cli.main(["vehicle-cornering", "-o", "/nonexistent/x.fmu"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("spurdiff export-container: ") and "pip install fmu-manipulation-toolbox" in err
    assert "\n" not in err


def test_the_container_runs_in_fmpy_as_our_master_runs_the_scene(fmu_files, tmp_path):
    pytest.importorskip("fmu_manipulation_toolbox", reason="fmu-manipulation-toolbox is not installed")
    from harness.interop.container_compare import compare
    scene = prepare_scene("vehicle-cornering", duration=0.5)
    files = {i.fmu: fmu_files[i.fmu] for i in scene.instances}
    s = container.export_container(scene, files, tmp_path / "scene.fmu")
    with zipfile.ZipFile(s.path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
        embedded = [n for n in z.namelist() if n.endswith(".fmu") or n.count("/") == 2 and n.endswith("modelDescription.xml")]
    assert root.get("fmiVersion") == "2.0" and embedded
    from fmpy.validation import validate_fmu
    assert validate_fmu(str(s.path)) == []          # fmpy validate: clean (names legal as "structured")
    rows = compare(scene, files, s.path, t_from=0.25)
    assert len(rows) == s.outputs >= 20          # every recorded output (a recorded parameter is not an output)
    # the same FMUs, order and step: equal to 1e-2 relative (measured at 3 s: at most 9e-4, the
    # start transient coupled differently; docs/interoperability.md)
    worst = max(rows, key=lambda r: r.rel)
    assert worst.rel < 1e-2, worst
    assert any(r.name == "diff.lockingTorque" and r.container > 20.0 for r in rows)
