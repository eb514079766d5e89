"""The runtime description's path rules (fmu_src/native/fmi/runtime_cfg.h, cfg_relative_ok) through
fmpy, so they are exercised where fmusim is absent (tests/harness/test_hosts.py then skips): a
``path`` with a ``..`` component, an absolute one and one with a backslash are refused at
instantiation with the key named; the unchanged description instantiates. Issue 47 (the mutation
runtime-cfg-dotdot of tests/mutations.toml)."""
from __future__ import annotations

import subprocess
import sys
import zipfile

import pytest

CFG = "resources/python_runtime.cfg"
CODE = ("import sys\nfrom fmpy import read_model_description\nfrom fmpy.fmi2 import FMU2Slave\n"
        "md = read_model_description(sys.argv[1])\n"
        "f = FMU2Slave(guid=md.guid, unzipDirectory=sys.argv[1], modelIdentifier='SpurDifferential')\n"
        "try:\n    f.instantiate(loggingOn=True)\n    print('INSTANTIATED')\n    f.freeInstance()\n"
        "except Exception as e:\n    print('REFUSED', e)\n")   # fmpy prints the FMU's log to stdout


@pytest.fixture(scope="module")
def unpacked(differential_fmu, tmp_path_factory):
    out = tmp_path_factory.mktemp("fmu")
    with zipfile.ZipFile(differential_fmu) as z:
        z.extractall(out)
    return out


def instantiate(folder, cfg: bytes) -> str:
    (folder / CFG).write_bytes(cfg)
    r = subprocess.run([sys.executable, "-c", CODE, str(folder)], capture_output=True, text=True, timeout=120)
    return r.stdout + r.stderr


@pytest.mark.parametrize("value", ["python/../../../../tmp", "../python", "python/..", "/tmp/python",
                                   "python\\..\\..\\tmp"])
def test_a_path_out_of_the_resources_is_refused_naming_the_key(unpacked, value):
    original = (unpacked / CFG).read_bytes()
    try:
        lines = [ln for ln in original.split(b"\n") if not ln.startswith(b"path=")]
        assert len(lines) < len(original.split(b"\n")), "the description has a path key"
        text = instantiate(unpacked, b"\n".join(lines) + b"\npath=" + value.encode() + b"\n")
    finally:
        (unpacked / CFG).write_bytes(original)
    assert "REFUSED" in text and "'path' must be a relative" in text, text[-2000:]


def test_the_unchanged_description_instantiates(unpacked):
    text = instantiate(unpacked, (unpacked / CFG).read_bytes())
    assert "INSTANTIATED" in text, text[-2000:]
