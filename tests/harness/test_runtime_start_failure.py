"""A runtime that fails to start (issue 45 item 5): a C host in a bare environment sees one clean
reason through its logger, not Python's path-configuration dump on its stderr before it (the bridge
holds the C stderr while the FMU's Python starts: fmu_src/native/fmi/fmi2_pybridge.c, stderr_hold)."""
from __future__ import annotations

import shutil
import subprocess
import zipfile

import pytest
from fmpy import read_model_description

from host_cases import build_c_host
from test_damaged_runtime_own_host import straight_line_args


@pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler")
def test_a_runtime_that_fails_to_start_says_why_in_one_line(differential_fmu, tmp_path):
    exe = build_c_host("fmi2_any_host", tmp_path / "fmi2_any_host")
    unpacked = tmp_path / "broken"
    with zipfile.ZipFile(differential_fmu) as z:
        z.extractall(unpacked)
    stdlib = unpacked / "resources" / "python" / "lib" / "python311.zip"
    assert stdlib.is_file()
    stdlib.unlink()                      # no standard library: the interpreter cannot start
    md = read_model_description(str(differential_fmu))
    r = subprocess.run(straight_line_args(exe, unpacked, md), env={"PATH": "/usr/bin:/bin"}, capture_output=True,
                       text=True, timeout=60)
    assert r.returncode != 0
    assert "cannot start the FMU's Python 3.11" in r.stdout, r.stdout + r.stderr
    assert "Python path configuration" not in r.stdout + r.stderr and "sys.path" not in r.stderr, r.stderr
    assert r.stderr.strip() == "", r.stderr
