"""A runtime that fails to start (issue 45 item 5): a C host in a bare environment sees one clean
reason through its logger, not Python's path-configuration dump on its stderr before it (the bridge
holds the C stderr while the FMU's Python starts: fmu_src/native/fmi/fmi2_pybridge.c, stderr_hold)."""
from __future__ import annotations

import hashlib
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
    # no standard library: the runtime's common archive (resources/runtime/common.zip, which holds only
    # python/lib/python311.zip) made empty, its digest in the description to match; the interpreter cannot start
    common = unpacked / "resources" / "runtime" / "common.zip"
    with zipfile.ZipFile(common) as z:
        assert z.namelist() == ["python/lib/python311.zip"]
    old = hashlib.sha256(common.read_bytes()).hexdigest()
    with zipfile.ZipFile(common, "w"):
        pass
    cfg = unpacked / "resources" / "python_runtime.cfg"
    assert f"archive={old} runtime/common.zip" in cfg.read_text()
    cfg.write_text(cfg.read_text().replace(old, hashlib.sha256(common.read_bytes()).hexdigest()))
    md = read_model_description(str(differential_fmu))
    r = subprocess.run(straight_line_args(exe, unpacked, md), capture_output=True, text=True, timeout=60,
                       env={"PATH": "/usr/bin:/bin", "SPURDIFF_FMU_RUNTIME_DIR": str(tmp_path / "runtime")})
    assert r.returncode != 0
    assert "cannot start the FMU's Python 3.11" in r.stdout, r.stdout + r.stderr
    assert "Python path configuration" not in r.stdout + r.stderr and "sys.path" not in r.stderr, r.stderr
    assert r.stderr.strip() == "", r.stderr
