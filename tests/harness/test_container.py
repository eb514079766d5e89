"""Issue 46.2: ``spurdiff export-container SCENE``, the coupled scene as one FMU (an FMU container of
fmu-manipulation-toolbox, whose C runtime steps the scene's FMUs), FMI 2.0 and 3.0, run in fmpy and
libcosim beside our master."""
from __future__ import annotations

import re
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
    # the toolbox's lines (it exits 0 after its ERROR lines): one per input of an embedded FMU that no
    # link feeds (it keeps its start value) and its two loop warnings; no "Output ... is not connected"
    # (the outputs nothing reads are dropped)
    from fmpy import read_model_description
    fed = {(ln[2], ln[3]) for ln in container.description(scene)["link"]}
    names = container.embedded_names(scene)
    mds = {f: read_model_description(str(path)) for f, path in files.items()}
    unfed = {(names[i.name], v.name) for i in scene.instances for v in mds[i.fmu].modelVariables
             if v.causality == "input" and (names[i.name], v.name) not in fed}
    assert {w.split("'")[1].split(" ", 1)[1] for w in s.warnings if w.startswith("fmucontainer ERROR: Input")} == \
        {f"{f}/{v}" for f, v in unfed}
    assert len(unfed) == 16 and len(s.warnings) == 18
    assert sum(w.startswith("fmucontainer WARNING: Loop of links through the embedded FMU") for w in s.warnings) == 2
    assert float(root.find("DefaultExperiment").get("stopTime")) == scene.duration      # not the car's 10 s
    from fmpy.validation import validate_fmu
    assert validate_fmu(str(s.path)) == []          # fmpy validate: clean (names legal as "structured")
    rows = compare(scene, files, s.path, t_from=0.25)
    assert len(rows) == s.outputs >= 20          # every recorded output (a recorded parameter is not an output)
    # the same FMUs, order and step: equal to 1e-2 relative (measured at 3 s: at most 9e-4, the
    # start transient coupled differently; docs/interoperability.md)
    worst = max(rows, key=lambda r: r.rel())
    assert worst.rel() < 1e-2, worst
    assert any(r.name == "diff.lockingTorque" and r.container > 20.0 for r in rows)
    # the cause of the difference: the container breaks the loop car -> diff -> wheels -> car by
    # initializing the differential without the wheels' values (its own warning), so at t = 0 its
    # shaft torque carries the damping of a wheel speed input still at its start, 0 rad/s:
    # rightShaft.d (10 N m s/rad) times the sun speed, where our master's sweeps brought the wheel's speed
    by_name = {r.name: r for r in rows}
    tau, w = by_name["diff.rightShaft.tau"], by_name["diff.right.w"]
    # at t = 0 (318.866 against 318.867 N m: 3e-6, measured)
    assert tau.hosts_start["fmpy"] - tau.master_start == pytest.approx(10.0 * w.master_start, rel=1e-5)
    assert w.hosts_start["fmpy"] == w.master_start


def test_the_differentials_default_experiment_in_a_container_is_fmpys(fmu_files, tmp_path):
    """Issue 46 item 4: SpurDifferential alone in a container (a scene of one instance, no start values,
    its default experiment's step and stop time, every Real output recorded) run in fmpy equals the FMU's
    own default experiment in fmpy at every step: bit for bit but the angles, to rounding (the container
    steps exactly 1 ms; fmpy's own run steps from n h to (n + 1) h)."""
    pytest.importorskip("fmu_manipulation_toolbox", reason="fmu-manipulation-toolbox is not installed")
    import numpy as np
    from fmpy import read_model_description, simulate_fmu

    fmu = fmu_files["SpurDifferential"]
    md = read_model_description(str(fmu))
    de = md.defaultExperiment
    outs = [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    record = ", ".join(f'"diff.{n}"' for n in outs)
    scene_file = tmp_path / "default-experiment.toml"
    scene_file.write_text(f'name = "default-experiment"\nduration = {float(de.stopTime)!r}\nstep = {float(de.stepSize)!r}\n'
                          f'output_interval = {float(de.stepSize)!r}\nrecord = [{record}]\n'
                          '[fmus.diff]\nfmu = "SpurDifferential"\n')
    scene = prepare_scene(str(scene_file))
    s = container.export_container(scene, {"SpurDifferential": fmu}, tmp_path / "alone.fmu")
    assert s.outputs == len(outs) >= 30 and s.starts == 0
    boxed = simulate_fmu(str(s.path), stop_time=float(de.stopTime), output_interval=float(de.stepSize))
    own = simulate_fmu(str(fmu))
    assert len(boxed) == len(own) and boxed["time"][-1] == pytest.approx(own["time"][-1])
    for n in outs:
        a, b = np.asarray(boxed[f"diff.{n}"], dtype=float), np.asarray(own[n], dtype=float)
        if n.endswith(".phi"):
            assert np.all(np.abs(a - b) <= 1e-14 * np.maximum(np.abs(b), 1.0)), n
        else:
            assert np.array_equal(a, b), n

LIBCOSIM = "libcosimpy is not installed (pip install libcosimpy)"


def test_the_container_runs_in_libcosim_as_in_fmpy(fmu_files, tmp_path):
    """libcosim (through libcosimpy, in a child process) steps the FMI 2.0 container as fmpy does:
    every output at every step equal to the last bit (the same C runtime and FMUs, one host call
    per step); the comparison table gets its column."""
    pytest.importorskip("fmu_manipulation_toolbox", reason="fmu-manipulation-toolbox is not installed")
    pytest.importorskip("libcosimpy", reason=LIBCOSIM)
    import numpy as np
    from harness.interop.container_compare import compare, run_container, table
    from harness.interop.container_libcosim import run_container_libcosim
    scene = prepare_scene("vehicle-cornering", duration=0.2)
    files = {i.fmu: fmu_files[i.fmu] for i in scene.instances}
    s = container.export_container(scene, files, tmp_path / "scene ü.fmu")
    ours = run_container_libcosim(s.path, scene)
    ref = run_container(s.path, scene)
    assert ours.ok and len(ours.names) == s.outputs
    assert np.allclose(ours.time, ref["time"], rtol=0, atol=1e-12)      # libcosim counts nanoseconds
    for name in ours.names:
        assert np.array_equal(ours[name], ref[name]), name
    rows = compare(scene, files, s.path, t_from=0.1, hosts=("fmpy", "libcosim"))
    assert rows and all(r.hosts["libcosim"] == r.hosts["fmpy"] for r in rows)
    assert "container in libcosim" in table(rows, 0.1, 0.2)


def test_libcosim_is_not_given_an_fmi3_container(tmp_path):
    """An FMI 3.0 container is refused before libcosim sees it (libcosimpy 0.0.6 ends the process
    with SIGSEGV on any FMI 3.0 FMU), with the reason."""
    import zipfile as zf
    from harness.interop.container_libcosim import run_container_libcosim
    from harness.interop.libcosim_run import LibcosimError
    fake = tmp_path / "scene.fmu"
    with zf.ZipFile(fake, "w") as z:
        z.writestr("modelDescription.xml", '<fmiModelDescription fmiVersion="3.0"><ModelVariables>'
                   '<Float64 name="x" valueReference="1" causality="output"/></ModelVariables></fmiModelDescription>')
    with pytest.raises(LibcosimError, match="FMI 3.0 container.*FMI 1.0 and 2.0 FMUs only"):
        run_container_libcosim(fake, prepare_scene("vehicle-cornering", duration=0.2))


def test_an_fmi3_container_of_the_fmi3_fmus_runs_in_fmpy(tmp_path):
    """``--fmi-version 3``: the FMI 3.0 FMUs in an FMI 3.0 container (fmucontainer -fmi 3) whose
    outputs are Float64; fmpy runs it, equal to our master on the same FMUs as the FMI 2.0
    container is (the same start, order and step)."""
    pytest.importorskip("fmu_manipulation_toolbox", reason="fmu-manipulation-toolbox is not installed")
    from harness.interop.container_compare import compare
    from harness.run.runner import fmu_files_for
    scene = prepare_scene("vehicle-cornering", duration=0.3)
    files = fmu_files_for(scene, fmi_version=3)
    s = container.export_container(scene, files, tmp_path / "scene.fmu", fmi_version=3)
    with zipfile.ZipFile(s.path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    assert s.fmi_version == 3 and root.get("fmiVersion") == "3.0" and root.get("instantiationToken")
    outs = [v for v in root.find("ModelVariables") if v.get("causality") == "output"]
    assert len(outs) == s.outputs and {v.tag for v in outs} == {"Float64"}
    assert float(root.find("DefaultExperiment").get("stopTime")) == scene.duration
    rows = compare(scene, files, s.path, t_from=0.15)
    assert len(rows) == s.outputs
    worst = max(rows, key=lambda r: r.rel())
    assert worst.rel() < 2e-2, worst       # 0.3 s: the start still in the means (7.5e-3 at most, measured)
    assert any(r.name == "diff.lockingTorque" and r.container > 20.0 for r in rows)


def test_fmus_of_the_other_fmi_version_are_refused(fmu_files, tmp_path):
    pytest.importorskip("fmu_manipulation_toolbox", reason="fmu-manipulation-toolbox is not installed")
    scene = prepare_scene("vehicle-cornering", duration=0.2)
    files = {i.fmu: fmu_files[i.fmu] for i in scene.instances}
    with pytest.raises(container.ContainerError, match=r"is an FMI 2.0 FMU; an FMI 3.0 container takes FMI 3.0 FMUs"):
        container.export_container(scene, files, tmp_path / "scene.fmu", fmi_version=3)
    assert not (tmp_path / "scene.fmu").exists()


def test_compare_says_why_libcosim_is_not_run(monkeypatch, capsys):
    """``--compare`` runs libcosim only where it can: an FMI 3.0 container, or no libcosimpy, is
    a note naming the reason, not a crash."""
    from harness.cli import export_container as cli
    assert cli._libcosim_host(3) == ()
    assert "imports FMI 1.0 and 2.0 FMUs only" in capsys.readouterr().out
    monkeypatch.setattr("importlib.util.find_spec", lambda name: None)
    assert cli._libcosim_host(2) == ()
    assert "libcosimpy is not installed (pip install libcosimpy)" in capsys.readouterr().out


def test_an_unknown_fmi_version_is_refused(tmp_path):
    scene = prepare_scene("vehicle-cornering", duration=0.2)
    with pytest.raises(container.ContainerError, match="FMI version 4: allowed 2 or 3"):
        container.export_container(scene, {}, tmp_path / "x.fmu", fmi_version=4)


# A stand-in for fmucontainer that exits 0 after printing the toolbox's log lines and writes a
# container whose modelDescription has every output asked for (no runtime: never run).
FAKE_TOOLBOX = '''#!{python}
import json, sys, zipfile
desc = json.load(open("container.json"))
sys.stdout.write({lines!r})
outs = "".join('<ScalarVariable name="%s" valueReference="%d" causality="output"><Real/></ScalarVariable>' % (o[2], i)
               for i, o in enumerate(desc["output"]))
with zipfile.ZipFile(desc["name"], "w") as z:
    z.writestr("modelDescription.xml", '<fmiModelDescription fmiVersion="2.0"><ModelVariables>%s</ModelVariables>'
               '</fmiModelDescription>' % outs)
'''


def _fake_toolbox(monkeypatch, tmp_path, lines: str):
    import sys
    exe = tmp_path / "fmucontainer"
    exe.write_text(FAKE_TOOLBOX.format(python=sys.executable, lines=lines))
    exe.chmod(0o755)
    monkeypatch.setattr(container, "_toolbox", lambda: str(exe))


@pytest.mark.parametrize("line, named", [
    ("ERROR    | Cannot expose (output) 'diff.lockingTorque' because type 'Real' is not compatible\n",
     "Cannot expose (output) 'diff.lockingTorque'"),
    ("ERROR    | JSON: unexpected keyword drop. Skipped.\n", "unexpected keyword drop"),
    ("CRITICAL | No common OS found for embedded FMU. Container won't be runnable.\n", "No common OS found"),
    # an input a link of the scene feeds: the link was not made
    ("ERROR    | Input 'Port diff_SpurDifferential.fmu/carrier.tau' is not connected\n",
     "diff_SpurDifferential.fmu/carrier.tau"),
])
def test_an_error_line_of_a_toolbox_that_exits_0_fails_the_export(line, named, fmu_files, tmp_path, monkeypatch, capsys):
    """fmucontainer exits 0 after ERROR lines: one that says a part of the container was not made fails
    the export with a one-line ContainerError naming it, and no file is written (command: exit 2)."""
    from harness.cli import export_container as cli
    _fake_toolbox(monkeypatch, tmp_path, "INFO     | FMUContainer version 2.0\n" + line + "INFO     | 'x.fmu' is available.\n")
    scene = prepare_scene("vehicle-cornering", duration=0.2)
    files = {i.fmu: fmu_files[i.fmu] for i in scene.instances}
    with pytest.raises(container.ContainerError, match=re.escape(named)) as e:
        container.export_container(scene, files, tmp_path / "scene.fmu")
    assert "\n" not in str(e.value) and "exited 0" in str(e.value)
    assert not (tmp_path / "scene.fmu").exists()
    monkeypatch.setattr("harness.run.runner.fmu_files_for", lambda scene, **kw: files)
    assert cli.main(["vehicle-cornering", "--duration", "0.2", "-o", str(tmp_path / "cli.fmu")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("spurdiff export-container: ") and named in err and "\n" not in err
    assert not (tmp_path / "cli.fmu").exists()


def test_benign_lines_of_the_toolbox_are_carried_as_warnings(fmu_files, tmp_path, monkeypatch, capsys):
    """An unconnected input no link of the scene feeds (it keeps its start value) and the WARNING
    lines: the export is made, each line one warning of the summary and of the command's output."""
    from harness.cli import export_container as cli
    _fake_toolbox(monkeypatch, tmp_path,
                  "ERROR    | Input 'Port car_Vehicle.fmu/speedTarget' is not connected\n"
                  "ERROR    | Input 'Port car_Vehicle.fmu/grade' is not connected\n"
                  "WARNING  | Loop of links through the embedded FMU 'car_Vehicle.fmu': it is initialized without "
                  "the values its inputs get from the loop.\n")
    scene = prepare_scene("vehicle-cornering", duration=0.2)
    files = {i.fmu: fmu_files[i.fmu] for i in scene.instances}
    s = container.export_container(scene, files, tmp_path / "scene.fmu")
    assert s.path.is_file()
    assert s.warnings == (
        "fmucontainer ERROR: Input 'Port car_Vehicle.fmu/speedTarget' is not connected (no link of the scene "
        "feeds it: it keeps the scene's start value 10.0)",
        "fmucontainer ERROR: Input 'Port car_Vehicle.fmu/grade' is not connected (no link of the scene feeds it: "
        "it keeps the FMU's start value)",
        "fmucontainer WARNING: Loop of links through the embedded FMU 'car_Vehicle.fmu': it is initialized without "
        "the values its inputs get from the loop.")
    monkeypatch.setattr("harness.run.runner.fmu_files_for", lambda scene, **kw: files)
    assert cli.main(["vehicle-cornering", "--duration", "0.2", "-o", str(tmp_path / "cli.fmu")]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err == [f"spurdiff export-container: warning: {w}" for w in s.warnings]
