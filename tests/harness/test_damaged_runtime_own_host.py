"""The damaged-runtime cases of tests/harness/test_hosts.py (which ran in fmusim, no longer in
../shared/hosts) in OUR OWN C host (tests/c_host/fmi2_host.c: not an independent host, a host
written here on fmpy's FMI headers), bare environment: each damaged copy of SpurDifferential.fmu
must be refused at instantiation (the host's exit 4, never a signal) with the cause our loader
logged. ecos, the installable C++ host, cannot show this: it exits 0 and writes zeros when an FMU
fails to instantiate (seen with the "no libpython" copy), so it is not used for these cases.
"""
from __future__ import annotations

import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description

from test_hosts import BARE_ENV, CASES, _copy

HERE = Path(__file__).resolve().parents[1]   # tests/

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler (gcc) for our own C host")


@pytest.fixture(scope="module")
def own_host(tmp_path_factory) -> Path:
    exe = tmp_path_factory.mktemp("own host") / "fmi2_host"
    subprocess.run(["gcc", "-o", str(exe), str(HERE / "c_host" / "fmi2_host.c"), "-ldl"], check=True)
    return exe


def _run(exe: Path, fmu: Path, where: Path) -> subprocess.CompletedProcess:
    unpacked = where / "unpacked ü"
    with zipfile.ZipFile(fmu) as z:
        z.extractall(unpacked)
    md = read_model_description(str(unpacked))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    args = [str(exe), str(unpacked / "binaries" / "linux64" / "SpurDifferential.so"), md.guid,
            (unpacked / "resources").as_uri(), str(vr["carrier.w_ref"]), str(vr["left.tau"]), str(vr["right.tau"]),
            str(vr["carrier.tauDrive"])]
    return subprocess.run(args, cwd=where, env=BARE_ENV, capture_output=True, text=True, timeout=120)


def test_the_intact_fmu_runs_in_our_host(own_host, differential_fmu, tmp_path):
    r = _run(own_host, differential_fmu, tmp_path)
    assert r.returncode == 0 and "status 0 tauDrive 2100.000000" in r.stdout, r.stdout[-2000:] + r.stderr[-2000:]


@pytest.mark.parametrize("case", list(CASES))
def test_a_damaged_runtime_is_refused_with_the_cause_in_our_host(case, own_host, differential_fmu, tmp_path):
    change, cause = CASES[case]
    fmu = _copy(differential_fmu, tmp_path / "SpurDifferential.fmu", change)
    r = _run(own_host, fmu, tmp_path)
    text = r.stdout + r.stderr
    assert r.returncode == 4, f"{case}: expected the host's instantiate failure (4), got {r.returncode}\n{text[-3000:]}"
    assert cause in text, f"{case}: the cause is not named\n{text[-3000:]}"


def test_the_hosts_python_variables_and_planted_files_do_not_reach_the_fmu_in_our_host(own_host, differential_fmu,
                                                                                        tmp_path):
    """test_hosts.py's planted-files case (it ran in fmusim): PYTHONHOME, PYTHONPATH, PYTHONSTARTUP
    at a folder with a planted numpy.py and sitecustomize.py, the same files in the working folder:
    none runs, the FMU runs."""
    evil = tmp_path / "evil"
    evil.mkdir()
    marker = tmp_path / "RAN"
    payload = f"open({str(marker)!r}, 'w').write('planted code ran')\n"
    for name in ("numpy.py", "sitecustomize.py", "usercustomize.py", "encodings.py", "startup.py"):
        (evil / name).write_text(payload)
        (tmp_path / name).write_text(payload)
    env = {**BARE_ENV, "PYTHONPATH": str(evil), "PYTHONHOME": str(evil), "PYTHONSTARTUP": str(evil / "startup.py"),
           "PYTHONUSERBASE": str(evil)}
    unpacked = tmp_path / "unpacked"
    with zipfile.ZipFile(differential_fmu) as z:
        z.extractall(unpacked)
    md = read_model_description(str(unpacked))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    args = [str(own_host), str(unpacked / "binaries" / "linux64" / "SpurDifferential.so"), md.guid,
            (unpacked / "resources").as_uri(), str(vr["carrier.w_ref"]), str(vr["left.tau"]), str(vr["right.tau"]),
            str(vr["carrier.tauDrive"])]
    r = subprocess.run(args, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and "status 0 tauDrive 2100.000000" in r.stdout, r.stdout[-2000:] + r.stderr[-2000:]
    assert not marker.exists(), "a planted file ran inside the FMU"
