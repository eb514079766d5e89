"""A runtime that fails to start (issue 45 item 5): a C host in a bare environment sees one clean
reason through its logger, not Python's path-configuration dump on its stderr before it (the bridge
holds the C stderr while the FMU's Python starts: fmu_src/native/fmi/fmi2_pybridge.c, stderr_hold)."""
from __future__ import annotations

import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description

HERE = Path(__file__).resolve().parents[1]   # tests/


@pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler")
def test_a_runtime_that_fails_to_start_says_why_in_one_line(differential_fmu, tmp_path):
    exe = tmp_path / "fmi2_host"
    subprocess.run(["gcc", "-o", str(exe), str(HERE / "c_host" / "fmi2_host.c"), "-ldl"], check=True)
    unpacked = tmp_path / "broken"
    with zipfile.ZipFile(differential_fmu) as z:
        z.extractall(unpacked)
    stdlib = unpacked / "resources" / "python" / "lib" / "python311.zip"
    assert stdlib.is_file()
    stdlib.unlink()                      # no standard library: the interpreter cannot start
    md = read_model_description(str(differential_fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    r = subprocess.run([str(exe), str(unpacked / "binaries" / "linux64" / "SpurDifferential.so"), md.guid,
                        (unpacked / "resources").as_uri(), *(str(vr[k]) for k in
                                                             ("carrier.w_ref", "left.tau", "right.tau", "carrier.tauDrive"))],
                       env={"PATH": "/usr/bin:/bin"}, capture_output=True, text=True, timeout=60)
    assert r.returncode != 0
    assert "cannot start the FMU's Python 3.11" in r.stdout, r.stdout + r.stderr
    assert "Python path configuration" not in r.stdout + r.stderr and "sys.path" not in r.stderr, r.stderr
    assert r.stderr.strip() == "", r.stderr
