"""A non-Python FMI host (tests/c_host/fmi2_host.c, built with the C compiler) runs the FMU."""
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description

from harness.build import find_patchelf

HERE = Path(__file__).parent


@pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler")
def test_c_host_runs_the_fmu(differential_fmu, tmp_path):
    exe = tmp_path / "fmi2_host"
    subprocess.run(["gcc", "-o", str(exe), str(HERE / "c_host" / "fmi2_host.c"), "-ldl"], check=True)
    with zipfile.ZipFile(differential_fmu) as z:
        z.extractall(tmp_path / "fmu")
    md = read_model_description(str(differential_fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    lib = Path(sysconfig.get_config_var("LIBDIR")) / sysconfig.get_config_var("INSTSONAME")
    so = tmp_path / "fmu" / "binaries" / "linux64" / "SpurDifferential.so"
    # the binary names libpython as a dependency (DT_NEEDED), so dlopen itself succeeds
    assert lib.name in subprocess.run([find_patchelf(), "--print-needed", str(so)], capture_output=True, text=True).stdout
    args = [str(exe), str(so), md.guid, (tmp_path / "fmu" / "resources").as_uri(),
            str(vr["carrier.w_ref"]), str(vr["left.tau"]), str(vr["right.tau"]), str(vr["carrier.tauDrive"])]
    # numpy's extension modules need libpython's symbols global: preload it, as documented
    # and the embedded interpreter must find its standard library and numpy/scipy (site-packages)
    env = {"LD_PRELOAD": str(lib), "PATH": "/usr/bin:/bin", "PYTHONHOME": sys.base_prefix,
           "PYTHONPATH": os.pathsep.join(p for p in sys.path if p.endswith("site-packages"))}
    r = subprocess.run(args, capture_output=True, text=True, env=env, timeout=120)
    assert "status 0 tauDrive 2100.000000" in r.stdout, r.stdout + r.stderr
    assert "freed" in r.stdout
    # Known, documented in the README: Python's finalisation with numpy/scipy loaded in an
    # embedded interpreter can crash at process exit, after fmi2FreeInstance returned. Any
    # other failure (or a crash before the instance was freed) fails here.
    assert r.returncode in (0, -11), r.stdout + r.stderr
