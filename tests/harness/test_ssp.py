"""SSP export (pyssp-standard), and the same scene run by libcosim from that SSP against our master.

The comparison: our master with algorithm "jacobi" and libcosim's fixed-step algorithm (Jacobi)
at the same step must agree to rounding: per recorded variable, the largest difference over the
run is at most RTOL times the variable's largest magnitude (at least 1). Both masters call the
same FMU code with the same inputs; what is left is rounding (libcosim counts time in integer
nanoseconds, we in floating seconds): measured at most 1e-15 of the scale on the differential
scenes and 1.6e-12 on vehicle-cornering (15,000 steps).

Initialization: both masters exchange connected values in Initialization Mode (one Jacobi
sweep per instance, every FMU computing its outputs there from what it was given), so the runs
agree from t = 0 on (docs/interoperability.md).
"""
from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pyssp_standard", reason="pyssp-standard is not installed (pip install pyssp-standard)")
pytest.importorskip("libcosimpy", reason="libcosimpy is not installed (pip install libcosimpy)")

from harness.interop.libcosim_run import LibcosimError, read_facts, run_ssp  # noqa: E402
from harness.run.master import run_scene  # noqa: E402
from harness.run.runner import fmu_files_for, prepare_scene  # noqa: E402
from harness.scene.spec import SCENE_DIR, SceneError  # noqa: E402
from harness.cli.export_ssp import main as export_main  # noqa: E402
from harness.interop.ssp import SspError, export_ssp, export_ssp_summary  # noqa: E402

RTOL = 1e-9   # of max(1, max |x|) per variable: rounding, far below any modelling difference

# Two differentials: a's carrier speed follows a time table (carried by the scene annotation and
# applied by libcosim's override manipulator), a's left sun speed drives b's carrier through a
# connection. a's mu_pin is not the default, so a dropped parameter binding shows.
CHAIN = """
name = "two-differentials"
description = "test: a (carrier speed from a table) drives b's carrier through a connection"
duration = 0.1
step = 1e-3
algorithm = "jacobi"
record = ["a.left.w", "a.right.w", "a.carrier.tauDrive", "a.lockingTorque",
          "b.carrier.w", "b.left.w", "b.right.w", "b.carrier.tauDrive", "b.lockingTorque", "b.stuck"]

[effects]
meshModel = "rigid"

[fmus.a]
fmu = "SpurDifferential"
gearSet = "paper"
parameters = { carrierDrive = "speed", mu_pin = 0.2, lockingLaw = "paper", "differential.w_start" = 0.0 }

[fmus.b]
fmu = "SpurDifferential"
gearSet = "paper"
parameters = { carrierDrive = "speed", lockingLaw = "paper", "differential.w_start" = 0.0 }

[inputs]
"a.carrier.w_ref" = { table = [[0.0, 0.5], [0.05, 1.389], [0.1, 1.389]] }
"a.left.tau" = -1110.201
"a.right.tau" = -989.799
"b.left.tau" = -1050.0
"b.right.tau" = -1000.0

[connections]
"b.carrier.w_ref" = "a.left.w"
"""

VEHICLE = SCENE_DIR / "vehicle-cornering.toml"


def _scene(name: str, tmp_path: Path) -> str:
    """A shipped scene's name, or the path of the two-differential test scene written to tmp_path."""
    if name == "two-differentials":
        p = tmp_path / "two-differentials.toml"
        p.write_text(CHAIN)
        return str(p)
    return name


@pytest.fixture
def chain_toml(tmp_path) -> str:
    return _scene("two-differentials", tmp_path)


def differences(ours, theirs, names):
    """[(name, max abs difference, scale, time of the largest difference)] at our sample times."""
    h = theirs.step
    idx = np.rint(ours.time / h).astype(int)
    assert idx[-1] < len(theirs.time), "libcosim recorded fewer samples than our master"
    assert np.allclose(theirs.time[idx], ours.time, rtol=0, atol=1e-12), "sample times differ"
    out = []
    for n in names:
        a, b = ours[n], theirs[n][idx]
        d = np.abs(a - b)
        k = int(np.argmax(d))
        out.append((n, float(d[k]), max(1.0, float(np.max(np.abs(a)))), float(ours.time[k])))
    return out


def _both(scene_name: str, tmp_path: Path, algorithm: str = "jacobi"):
    """The scene run by libcosim from its SSP, and by our master as it is."""
    scene = prepare_scene(scene_name, algorithm=algorithm)
    files = fmu_files_for(scene, build_missing=True)
    ssp = export_ssp(scene, files, tmp_path / f"{scene.name}.ssp")
    theirs = run_ssp(ssp)
    assert theirs.ok, theirs.failure
    ours = run_scene(scene, files)
    assert ours.ok, str(ours.failure)
    return scene, ours, theirs


# ------------------------------------------------------------------------------------ export
def test_export_paper_cornering_reads_back_and_passes_the_schema(tmp_path):
    from pyssp_standard import SSP
    from spurdiff.gears.design_sets import fmu_parameters

    scene = prepare_scene("paper-cornering")
    files = fmu_files_for(scene)
    path = export_ssp(scene, files, tmp_path / "pc.ssp")
    with SSP(path, mode="r") as ssp:
        assert ssp.resources == ["SpurDifferential.fmu"]
        ssd = ssp.system_structure
        ssd.__check_compliance__()  # the file as written, against the SSP 1.0 schema
        assert (ssd.name, ssd.version, ssd.default_experiment.stop_time) == ("paper-cornering", "1.0", 0.3)
        (diff,) = ssd.system.elements
        assert (diff.name, diff.source, diff.component_type) == ("diff", "resources/SpurDifferential.fmu",
                                                                 "application/x-fmu-sharedlibrary")
        kinds = {c.name: c.kind for c in diff.connectors}
        assert kinds["left.tau"] == "input" and kinds["left.w"] == "output" and kinds["mu_pin"] == "parameter"
        bound = {p["name"]: (p["type_name"], p["type_value"].parameter["value"])
                 for b in diff.parameter_bindings for p in b.ssv.parameters}
    gear = {k: ("Integer" if isinstance(v, int) else "Real", repr(float(v)) if isinstance(v, float) else str(v))
            for k, v in fmu_parameters("paper").items()}    # the scene names the paper's gear set (issue 46)
    assert bound == {"meshModel": ("String", "rigid"), "carrierDrive": ("String", "speed"),
                     "lockingLaw": ("String", "paper"), "differential.w_start": ("Real", "0.0"), **gear,
                     "carrier.w_ref": ("Real", "1.389"), "left.tau": ("Real", "-1110.201"),
                     "right.tau": ("Real", "-989.799")}
    facts = read_facts(path)
    assert facts.step == 1e-3 and facts.stop_time == 0.3 and facts.record == scene.record and not facts.tables


def test_export_carries_connections_and_table_start_values(chain_toml, tmp_path):
    from pyssp_standard import SSP

    scene = prepare_scene(chain_toml)
    summary = export_ssp_summary(scene, fmu_files_for(scene), tmp_path / "chain.ssp")
    assert (summary.components, summary.connections, summary.tables) == (2, 1, ["a.carrier.w_ref"])
    with SSP(summary.path, mode="r") as ssp:
        ssd = ssp.system_structure
        assert [c.as_dict() for c in ssd.connections()] == [
            {"source": "a", "signal": "left.w", "target": "b", "receiver": "carrier.w_ref"}]
        assert ssd.check_connections() == []
    facts = read_facts(summary.path)
    assert facts.bindings["a"]["carrier.w_ref"] == ("Real", "0.5")        # the table at t = 0
    assert facts.bindings["a"]["mu_pin"] == ("Real", "0.2")
    assert "carrier.w_ref" not in facts.bindings["b"]                      # connected, not bound
    table = facts.tables["a.carrier.w_ref"]
    assert table.times == (0.0, 0.05, 0.1) and table.values == (0.5, 1.389, 1.389)


def test_schema_check_rejects_an_invalid_ssd_and_leaves_no_file(tmp_path, monkeypatch):
    import harness.interop.ssp as ssp_mod
    from pyssp_standard.common_content_ssc import TypeReal
    from pyssp_standard.ssd import Connector

    monkeypatch.setattr(ssp_mod, "_connector", lambda v: Connector(name=v.name, kind="sideways", type_=TypeReal(None)))
    scene = prepare_scene("paper-cornering")
    with pytest.raises(SspError, match="schema"):
        export_ssp(scene, fmu_files_for(scene), tmp_path / "bad.ssp")
    assert list(tmp_path.iterdir()) == []


def test_a_failed_archive_write_leaves_no_pyssp_folder(tmp_path, monkeypatch):
    """pyssp writes the archive in its exit and removes its temporary folder only after that: when
    writing fails (here a full disk, as tests/harness/hostile/test_hostile_outputs.py makes it), the
    export fails, and neither the archive nor pyssp's folder is left."""
    import tempfile

    import pyssp_standard.utils as pyssp_utils

    scratch = tmp_path / "tmp"
    scratch.mkdir()
    scene = prepare_scene("paper-cornering")
    files = fmu_files_for(scene)
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(pyssp_utils.shutil, "make_archive", full)
    from harness.common.outputs import OutputError

    with pytest.raises(OutputError, match="ENOSPC"):
        export_ssp(scene, files, tmp_path / "x.ssp")
    assert list(scratch.iterdir()) == []
    assert not (tmp_path / "x.ssp").exists()


def test_export_errors_name_the_problem(chain_toml, tmp_path):
    scene = prepare_scene("paper-cornering")
    files = fmu_files_for(scene)
    with pytest.raises(SspError, match=r"must end in \.ssp"):
        export_ssp(scene, files, tmp_path / "pc.zip")
    scene.instance("diff").parameters["mu_pni"] = 0.1
    with pytest.raises(SceneError, match="no variable 'mu_pni'"):
        export_ssp(scene, files, tmp_path / "pc.ssp")
    chain = prepare_scene(chain_toml)
    chain.connections["b.carrier.w_ref"] = "a.left.tau"
    with pytest.raises(SceneError, match="'a.left.tau' is a input, not an output"):
        export_ssp(chain, files, tmp_path / "chain.ssp")


def test_cli_export_ssp(tmp_path, capsys):
    out = tmp_path / "pc.ssp"
    assert export_main(["paper-cornering", "-o", str(out), "--step", "5e-4"]) == 0
    assert "1 component(s)" in capsys.readouterr().out and zipfile.is_zipfile(out)
    assert read_facts(out).step == 5e-4
    assert export_main(["no-such-scene", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown scene 'no-such-scene'" in err[0]


# ------------------------------------------------------------------------ libcosim vs ours
SCENES = [
    "paper-cornering",
    "two-differentials",
    pytest.param("vehicle-cornering", marks=pytest.mark.skipif(
        not VEHICLE.exists(), reason=f"{VEHICLE.name} does not exist yet")),
]


@pytest.mark.parametrize("name", SCENES)
def test_libcosim_from_ssp_matches_our_jacobi_master(name, tmp_path):
    scene, ours, theirs = _both(_scene(name, tmp_path), tmp_path)
    assert len(theirs.time) == int(round(scene.duration / scene.step)) + 1  # step from the SSP annotation
    diffs = differences(ours, theirs, scene.record)
    bad = [f"{n}: {d:.3g} (scale {s:.3g}) at t = {t:g} s" for n, d, s, t in diffs if d > RTOL * s]
    assert not bad, "libcosim and our Jacobi master differ: " + "; ".join(bad)
    assert max(np.ptp(ours[n]) for n in scene.record) > 1.0  # a real trajectory, not constants


@pytest.mark.parametrize("name", [
    "paper-cornering",
    "two-differentials",
    pytest.param("vehicle-cornering", marks=pytest.mark.skipif(
        not VEHICLE.exists(), reason=f"{VEHICLE.name} does not exist yet")),
])
def test_libcosim_from_ssp_reproduces_spurdiff_run_from_t0(name, tmp_path):
    """What a user of the SSP gets: libcosim reads our outputs in Initialization Mode to
    propagate initial values (they are computed there from the parameters and inputs set so far),
    and our master initializes the same way, so both runs agree from t = 0 on, the vehicle's
    wheels included (they used to start from rest under libcosim)."""
    scene, ours, theirs = _both(_scene(name, tmp_path), tmp_path)
    bad = [f"{n}: {d:.3g} at t = {t:g} s" for n, d, s, t in differences(ours, theirs, scene.record) if d > RTOL * s]
    assert not bad, "differ: " + "; ".join(bad)
    idx = np.rint(ours.time / theirs.step).astype(int)
    for n in scene.record:   # t = 0 itself, not only the trajectory after it
        assert abs(ours[n][0] - theirs[n][idx[0]]) <= RTOL * max(1.0, abs(ours[n][0])), n


def test_the_comparison_tells_jacobi_from_gauss_seidel(tmp_path):
    """With our master in Gauss-Seidel order the connected instance sees its input one step
    earlier: the comparison must show it, far above the tolerance."""
    scene, ours, theirs = _both(_scene("two-differentials", tmp_path), tmp_path, algorithm="gauss-seidel")
    worst = {n: d / s for n, d, s, _ in differences(ours, theirs, scene.record)}
    assert worst["b.carrier.w"] > 1e6 * RTOL
    assert worst["a.left.w"] <= RTOL  # a has no connected input: the same either way


def test_initial_values_travel_through_the_chain_in_initialization_mode(tmp_path):
    """b's carrier is driven by a's sun speed; a starts at 0.5 rad/s. In Initialization Mode b
    already reads a's initial output (not the start value 0): b starts at 0.5 rad/s."""
    scene, ours, theirs = _both(_scene("two-differentials", tmp_path), tmp_path)
    assert ours["b.carrier.w"][0] == pytest.approx(0.5, abs=1e-12)
    assert theirs["b.carrier.w"][0] == pytest.approx(0.5, abs=1e-12)


def test_a_binding_libcosim_drops_is_reported(chain_toml, tmp_path):
    """libcosim only logs a warning for a parameter binding it cannot apply; the runner reads
    every bound value back and reports the one that did not arrive."""
    scene = prepare_scene(chain_toml)
    good = export_ssp(scene, fmu_files_for(scene), tmp_path / "good.ssp")
    bad = tmp_path / "bad.ssp"
    with zipfile.ZipFile(good) as zin, zipfile.ZipFile(bad, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item)
            if item.filename == "SystemStructure.ssd":
                assert b'<ssv:Parameter name="mu_pin">' in data
                data = data.replace(b'<ssv:Parameter name="mu_pin">', b'<ssv:Parameter name="mu_pinn">')
            zout.writestr(item, data)
    res = run_ssp(bad)
    assert not res.ok and "a.mu_pinn" in res.failure and "not a variable of the FMU" in res.failure


def test_libcosim_runner_errors_are_one_line(tmp_path, chain_toml):
    with pytest.raises(LibcosimError, match="no such SSP file"):
        run_ssp(tmp_path / "missing.ssp")
    scene = prepare_scene(chain_toml)
    ssp = export_ssp(scene, fmu_files_for(scene), tmp_path / "chain.ssp")
    with pytest.raises(LibcosimError, match="nanoseconds"):
        run_ssp(ssp, step=1e-3 / 3)
    with pytest.raises(LibcosimError, match="no variable 'nope'"):
        run_ssp(ssp, record=["a.nope"])


if __name__ == "__main__":   # the numbers in docs/interoperability.md: python tests/harness/test_ssp.py
    import tempfile

    tmp = Path(tempfile.mkdtemp())
    for scene_name in ("paper-cornering", "two-differentials", "vehicle-cornering"):
        sc, ours, theirs = _both(_scene(scene_name, tmp), tmp)
        n, d, s, t = max(differences(ours, theirs, sc.record), key=lambda x: x[1] / x[2])
        i0 = int(round(ours.time[0] / theirs.step))
        at0 = max(abs(ours[v][0] - theirs[v][i0]) / max(1.0, abs(ours[v][0])) for v in sc.record)
        print(f"{scene_name}: largest relative difference {d / s:.2g} ({n} at t = {t:g} s); at t = 0: {at0:.2g}")
