"""Issue 46.1/46.2: the container runtime of fmu-manipulation-toolbox as a host. A scene's container
FMU (spurdiff export-container) run by ecos, the installable C++ host, as ``nobody`` in a mount
namespace where every Python is hidden, with a bare environment, from a folder whose path has
spaces and non-ASCII characters: the container's C runtime steps our four FMUs there, and the
results equal those of the same container run by fmpy in this process (to ecos's six decimals).
FMI 2.0 and FMI 3.0 containers (``export_container(..., fmi_version=3)``: the FMI 3.0 FMUs) in ecos;
the FMI 2.0 one in our own C host."""
from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

from host_cases import ECOS_LOG, build_c_host, read_ecos_csv
from test_travel import ECOS, WHY_NOT, hidden_run

pytestmark = pytest.mark.skipif(WHY_NOT is not None, reason=str(WHY_NOT))
NO_ECOS = "the ecos command line (pip install ecospy; apt-get install libtbb12) does not run here"
STOP, STEP = 0.2, 5e-3


@pytest.fixture(scope="module")
def containers(fmu_files, tmp_path_factory):
    """FMI version -> the scene's container FMU of that version, made on first use."""
    pytest.importorskip("fmu_manipulation_toolbox", reason="fmu-manipulation-toolbox is not installed")
    from harness.interop.container import export_container
    from harness.run.runner import fmu_files_for, prepare_scene
    scene = prepare_scene("vehicle-cornering", duration=STOP)
    made = {}

    def get(version: int) -> Path:
        if version not in made:
            files = ({i.fmu: fmu_files[i.fmu] for i in scene.instances} if version == 2
                     else fmu_files_for(scene, fmi_version=3))
            made[version] = export_container(scene, files, tmp_path_factory.mktemp(f"container{version}") /
                                             "vehicle-cornering.fmu", fmi_version=version).path
        return made[version]
    return get


@pytest.fixture(scope="module")
def container_fmu(containers):
    return containers(2)


@pytest.mark.skipif(ECOS is None, reason=NO_ECOS)
@pytest.mark.parametrize("version", [2, 3])
def test_the_container_runs_in_ecos_where_no_python_is(containers, version):
    from fmpy import simulate_fmu
    container_fmu = containers(version)
    root = Path(tempfile.mkdtemp(prefix="spurdiff container ü ", dir="/tmp"))
    try:
        os.chmod(root, 0o777)
        shutil.copy(container_fmu, root / "scene.fmu")
        shutil.copy(ECOS, root / "ecos")
        os.chmod(root / "ecos", 0o755)
        os.chmod(root / "scene.fmu", 0o644)
        r = hidden_run(f"./ecos simulate --path scene.fmu --stopTime {STOP} --stepSize {STEP} {ECOS_LOG} >log.txt 2>&1; "
                       "echo RC $?\n", root)
        log = (root / "log.txt").read_text(errors="replace") if (root / "log.txt").exists() else ""
        assert "RC 0" in r.stdout, r.stdout + r.stderr + log[-3000:]
        got = read_ecos_csv(root / "scene.csv", log, f"ecos, FMI {version}.0 container")
        ref = simulate_fmu(str(container_fmu), stop_time=STOP, step_size=STEP, output_interval=STEP)
        common = [n for n in ref.dtype.names[1:] if n in got]
        assert len(common) >= 20, common
        t = got["time"]
        n = min(len(t), len(ref["time"]))
        assert n >= int(STOP / STEP) and np.allclose(t[:n], ref["time"][:n], atol=1e-9)
        for name in common:
            g, f = got[name][:n], np.asarray(ref[name][:n], dtype=float)
            # ecos writes six decimals or seven significant digits: half a unit of either
            assert np.allclose(g, f, rtol=5e-7, atol=5e-7), f"{name}: ecos differs from fmpy by {np.max(np.abs(g - f)):.3g}"
        assert np.max(got["diff.lockingTorque"]) > 20.0      # the differential slips at its capacity
    finally:
        shutil.rmtree(root, ignore_errors=True)


def test_the_container_runs_in_our_c_host_where_no_python_is(container_fmu, tmp_path):
    """Our own C host (tests/c_host/fmi2_any_host.c: ours, not an independent host) runs the unzipped
    container in the same hidden namespace; its outputs after the run equal fmpy's to the digit."""
    import subprocess
    import zipfile
    from fmpy import read_model_description, simulate_fmu
    if shutil.which("gcc") is None:
        pytest.skip("no C compiler (gcc) for our own C host")
    root = Path(tempfile.mkdtemp(prefix="spurdiff container ü ", dir="/tmp"))
    try:
        os.chmod(root, 0o777)
        exe = root / "fmi2_any_host"
        build_c_host("fmi2_any_host", exe)
        unpacked = root / "scene ü"
        with zipfile.ZipFile(container_fmu) as z:
            z.extractall(unpacked)
        subprocess.run(["chmod", "-R", "a+rX", str(root)], check=True)
        md = read_model_description(str(unpacked))
        outs = [v for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
        so = unpacked / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so"
        steps = int(round(STOP / STEP))
        import shlex
        cmd = " ".join(shlex.quote(a) for a in [str(exe), str(so), md.guid, (unpacked / "resources").as_uri(),
                                                 str(steps), repr(STEP), "1", "get",
                                                 ",".join(str(v.valueReference) for v in outs)])
        r = hidden_run(cmd + " >out.txt 2>&1; echo RC $?\n", root)
        text = (root / "out.txt").read_text(errors="replace")
        assert "RC 0" in r.stdout, r.stdout + r.stderr + text[-3000:]
        import re
        got_by_vr = {int(k): float(v) for k, v in re.findall(r" (\d+)=(\S+)", text)}
        ref = simulate_fmu(str(container_fmu), stop_time=STOP, step_size=STEP, output_interval=STEP)
        assert len(got_by_vr) == len(outs), text[-2000:]
        for v in outs:
            assert got_by_vr[v.valueReference] == pytest.approx(float(ref[v.name][-1]), rel=1e-12, abs=1e-12), v.name
    finally:
        shutil.rmtree(root, ignore_errors=True)


def test_the_fmi3_container_runs_in_our_fmi3_c_host_where_no_python_is(containers):
    """Our own FMI 3.0 C host (tests/c_host/fmi3_host.c: ours, not an independent host) runs the
    unzipped FMI 3.0 container in the hidden namespace; its Float64 outputs after the run equal
    fmpy's (this process) to the digit."""
    import re
    import shlex
    import subprocess
    import zipfile
    from fmpy import read_model_description, simulate_fmu
    if shutil.which("gcc") is None:
        pytest.skip("no C compiler (gcc) for our own C host")
    from harness.build.fmu import _fmi2_headers   # fmpy's FMI headers, 2.0 and 3.0
    container_fmu = containers(3)
    root = Path(tempfile.mkdtemp(prefix="spurdiff container ü ", dir="/tmp"))
    try:
        os.chmod(root, 0o777)
        exe = root / "fmi3_host"
        subprocess.run(["gcc", "-O1", f"-I{_fmi2_headers()}", "-o", str(exe),
                        str(Path(__file__).resolve().parents[1] / "c_host" / "fmi3_host.c"), "-ldl"], check=True)
        unpacked = root / "scene ü"
        with zipfile.ZipFile(container_fmu) as z:
            z.extractall(unpacked)
        subprocess.run(["chmod", "-R", "a+rX", str(root)], check=True)
        md = read_model_description(str(unpacked))
        assert md.fmiVersion == "3.0"
        outs = [v for v in md.modelVariables if v.causality == "output" and v.type == "Float64"]
        so = unpacked / "binaries" / "x86_64-linux" / f"{md.coSimulation.modelIdentifier}.so"
        cmd = " ".join(shlex.quote(a) for a in [str(exe), str(so), md.guid, str(unpacked / "resources"),
                                                 repr(STOP), repr(STEP), *(f"get:{v.valueReference}" for v in outs)])
        r = hidden_run(cmd + " >out.txt 2>&1; echo RC $?\n", root)
        text = (root / "out.txt").read_text(errors="replace")
        assert "RC 0" in r.stdout and "freed" in text, r.stdout + r.stderr + text[-3000:]
        got_by_vr = {int(k): float(v) for k, v in re.findall(r"^get (\d+) (\S+)$", text, re.M)}
        ref = simulate_fmu(str(container_fmu), stop_time=STOP, step_size=STEP, output_interval=STEP)
        assert len(got_by_vr) == len(outs) >= 20, text[-2000:]
        for v in outs:
            assert got_by_vr[v.valueReference] == pytest.approx(float(ref[v.name][-1]), rel=1e-12, abs=1e-12), v.name
    finally:
        shutil.rmtree(root, ignore_errors=True)
