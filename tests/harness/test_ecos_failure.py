"""ecos (the ecospy wheel's command line) exits 0 and writes a CSV of zeros when our FMU's
instantiation fails: it goes on calling the FMU with a NULL instance. The shared reader of its results
(host_cases.read_ecos_csv, used by every test that runs ecos) must fail on such a run, naming the log
line that says why, or, where the log says nothing (ecos's default log level hides the FMU's
messages), the zeros. Provoked with a damaged copy of SpurDifferential.fmu whose runtime description
has an unknown key (its loader refuses it in fmi2Instantiate / fmi3InstantiateCoSimulation)."""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

from host_cases import ECOS_LOG, STEP, STOP, ecos_binary, ecos_failure, read_ecos_csv
from test_hosts import CASES, _copy

ECOS = ecos_binary()
NO_ECOS = "the ecos command line (pip install ecospy; apt-get install libtbb12) does not run here"
UNKNOWN_KEY = CASES["an unknown key"][0]      # python_runtime.cfg + "executable=/usr/bin/python3"


def _ecos(fmu: Path, work: Path, *log_level: str) -> tuple[int, str]:
    """ecos run on ``fmu`` in ``work`` (its CSV there): exit status and log."""
    exe = work / "ecos"
    shutil.copy(ECOS, exe)
    os.chmod(exe, 0o755)
    r = subprocess.run([str(exe), "simulate", "--path", str(fmu), "--stopTime", repr(STOP), "--stepSize", repr(STEP),
                        *log_level], cwd=work, env={"PATH": "/usr/bin:/bin"}, capture_output=True, text=True,
                       timeout=300)
    return r.returncode, r.stdout + r.stderr


def test_the_log_lines_that_say_an_fmu_failed():
    """What ecos writes (seen here): the FMU's own message at -l debug, FMI 2.0 and 3.0; the container
    runtime's "Solver configure...." line, status fmi2Error on every run (a good one too), is none."""
    fmi2 = ("[2026-11-29 01:39:24.633] [ecos] [debug] [/w/SpurDifferential.fmu] fmi2Error fmi2Instantiate: "
            "/tmp/x/resources/python_runtime.cfg line 19: unknown key 'executable'")
    fmi3 = ("[2026-11-29 01:46:06.588] [ecos] [debug] [instance] Error fmi3InstantiateCoSimulation: "
            "/tmp/x/resources/python_runtime.cfg line 19: unknown key 'executable'")
    noise = "[2026-11-29 01:45:36.236] [ecos] [debug] [/w/scene.fmu] fmi2Error Solver configure...."
    info = "[2026-11-29 01:45:37.250] [ecos] [info] Simulation commencing. Start=0s, stop=0.2s, stepSize=0.005s"
    assert ecos_failure("\n".join([info, fmi2, info])) == fmi2
    assert ecos_failure("\n".join([info, fmi3])) == fmi3
    assert ecos_failure("\n".join([noise, info])) is None
    assert ecos_failure("[2026-11-29 01:45:37.250] [ecos] [error] Failed to load model") is not None


@pytest.mark.skipif(ECOS is None, reason=NO_ECOS)
def test_a_run_whose_fmu_failed_to_instantiate_is_reported(differential_fmu, tmp_path):
    fmu = _copy(differential_fmu, tmp_path / "SpurDifferential.fmu", UNKNOWN_KEY)
    # at ecos's default log level: exit 0, no word of the failure, a CSV of zeros
    (tmp_path / "quiet").mkdir()
    rc, log = _ecos(fmu, tmp_path / "quiet")
    assert rc == 0 and ecos_failure(log) is None, log[-2000:]
    with pytest.raises(AssertionError, match=r"every value it wrote \(\d+ columns\) is 0: nothing came from the FMU"):
        read_ecos_csv(tmp_path / "quiet" / "SpurDifferential.csv", log, "ecos damaged")
    # at ECOS_LOG (what the tests run): the FMU's reason, named
    (tmp_path / "debug").mkdir()
    rc, log = _ecos(fmu, tmp_path / "debug", *ECOS_LOG.split())
    assert rc == 0, log[-2000:]
    with pytest.raises(AssertionError, match=r"ecos damaged: ecos exited 0, but its log says an FMU failed: .*"
                                             r"fmi2Error fmi2Instantiate: .*unknown key 'executable'"):
        read_ecos_csv(tmp_path / "debug" / "SpurDifferential.csv", log, "ecos damaged")


@pytest.mark.skipif(ECOS is None, reason=NO_ECOS)
def test_the_intact_fmu_passes(differential_fmu, tmp_path):
    rc, log = _ecos(differential_fmu, tmp_path, *ECOS_LOG.split())
    got = read_ecos_csv(tmp_path / "SpurDifferential.csv", log, "ecos intact")
    assert rc == 0 and got["carrier.tauDrive"][-1] != 0.0
