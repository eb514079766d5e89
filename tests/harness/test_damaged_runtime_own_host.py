"""The damaged-runtime cases of tests/harness/test_hosts.py (which ran in fmusim, no longer in
../shared/hosts) in OUR OWN C host (tests/c_host/fmi2_any_host.c: not an independent host, a host
written here on fmpy's FMI headers), bare environment: each damaged copy of SpurDifferential.fmu
must be refused at instantiation (the host's exit 4, never a signal) with the cause our loader
logged. ecos, the installable C++ host, cannot show this: it exits 0 and writes zeros when an FMU
fails to instantiate (seen with a copy without libpython), so it is not used for these cases.
"""
from __future__ import annotations

import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description

from host_cases import build_c_host
from test_hosts import BARE_ENV, CASES, _copy, planted_env


pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler (gcc) for our own C host")


@pytest.fixture(scope="module")
def own_host(tmp_path_factory) -> Path:
    return build_c_host("fmi2_any_host", tmp_path_factory.mktemp("own host") / "fmi2_any_host")


def _run(exe: Path, fmu: Path, where: Path, env: dict = BARE_ENV) -> subprocess.CompletedProcess:
    unpacked = where / "unpacked ü"
    with zipfile.ZipFile(fmu) as z:
        z.extractall(unpacked)
    md = read_model_description(str(unpacked))
    return subprocess.run(straight_line_args(exe, unpacked, md), cwd=where, env=env, capture_output=True, text=True,
                          timeout=120)


def straight_line_args(exe: Path, unpacked: Path, md) -> list[str]:
    """fmi2_any_host's command line for the paper's straight-line case in the unzipped SpurDifferential:
    10 steps of 1 ms, the carrier torque printed ("run 0 status 0 VR=2100...")."""
    vr = {v.name: v.valueReference for v in md.modelVariables}
    return [str(exe), str(unpacked / "binaries" / "linux64" / "SpurDifferential.so"), md.guid,
            (unpacked / "resources").as_uri(), "10", "1e-3", "1", f"{vr['carrier.w_ref']}=1.389",
            f"{vr['left.tau']}=-1050", f"{vr['right.tau']}=-1050", "get", str(vr["carrier.tauDrive"])]


def tau_drive(r: subprocess.CompletedProcess, md) -> float | None:
    """The carrier torque of a run that ended with status 0 (None: no such line)."""
    vr = next(v.valueReference for v in md.modelVariables if v.name == "carrier.tauDrive")
    found = re.findall(rf"^run 0 status 0 {vr}=(\S+)$", r.stdout, re.M)
    return float(found[0]) if len(found) == 1 else None


def test_the_intact_fmu_runs_in_our_host(own_host, differential_fmu, tmp_path):
    r = _run(own_host, differential_fmu, tmp_path)
    drive = tau_drive(r, read_model_description(str(differential_fmu)))
    assert r.returncode == 0 and drive is not None and abs(drive - 2100.0) < 5e-7, r.stdout[-2000:] + r.stderr[-2000:]


@pytest.mark.parametrize("case", list(CASES))
def test_a_damaged_runtime_is_refused_with_the_cause_in_our_host(case, own_host, differential_fmu, tmp_path):
    """With the Python started at fmi2Instantiate (SPURDIFF_FMU_START=python) the damage refuses the
    instance there; with the native start (the default) the run's first set of an input to another
    value needs the Python and fails naming the same cause (a damaged description is read at
    fmi2Instantiate either way)."""
    change, cause = CASES[case]
    fmu = _copy(differential_fmu, tmp_path / "SpurDifferential.fmu", change)
    r = _run(own_host, fmu, tmp_path, {**BARE_ENV, "SPURDIFF_FMU_START": "python"})
    text = r.stdout + r.stderr
    assert r.returncode == 4, f"{case}: expected the host's instantiate failure (4), got {r.returncode}\n{text[-3000:]}"
    assert cause in text, f"{case}: the cause is not named\n{text[-3000:]}"
    (tmp_path / "native").mkdir()
    r = _run(own_host, fmu, tmp_path / "native")
    text = r.stdout + r.stderr
    assert r.returncode > 0 and cause in text, f"{case}, native start: {r.returncode}\n{text[-3000:]}"


def test_the_hosts_python_variables_and_planted_files_do_not_reach_the_fmu_in_our_host(own_host, differential_fmu,
                                                                                        tmp_path):
    """test_hosts.py's planted-files case (it ran in fmusim): PYTHONHOME, PYTHONPATH, PYTHONSTARTUP
    at a folder with a planted numpy.py and sitecustomize.py, the same files in the working folder:
    none runs, the FMU runs."""
    env, marker = planted_env(tmp_path)
    r = _run(own_host, differential_fmu, tmp_path, env)
    drive = tau_drive(r, read_model_description(str(differential_fmu)))
    assert r.returncode == 0 and drive is not None and abs(drive - 2100.0) < 5e-7, r.stdout[-2000:] + r.stderr[-2000:]
    assert not marker.exists(), "a planted file ran inside the FMU"
