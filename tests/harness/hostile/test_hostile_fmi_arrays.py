"""The FMU's getters and setters answer a NULL array with fmi2Error and a logged reason.

A host that passes ``NULL`` for the value-reference or the value array with ``nvr > 0`` made every
getter segfault (the setters already refused). The loader now checks the arrays before the
model sees the call (fmu_src/native/fmi/fmi2_loader.c), whichever side runs the model: in this
process and in its own (``SPURDIFF_FMU_PROCESS=out``). Each case runs in a child process, so a
segfault is a failed test, not a dead test run.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest


# the hosts started here unpack their FMU into a temporary folder they may never remove: tests/conftest.py
pytestmark = pytest.mark.usefixtures("children_scratch_in_tmp_path")


CODE = r"""
import ctypes, json, os, sys
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
md = read_model_description(sys.argv[1])
msgs = []
f = FMU2Slave(guid=md.guid, unzipDirectory=extract(sys.argv[1]), modelIdentifier='SpurDifferential',
              instanceName='d')
f.instantiate(); f.setupExperiment(startTime=0); f.enterInitializationMode(); f.exitInitializationMode()
c = ctypes.c_void_p(f.component)
vr = (ctypes.c_uint * 2)(0, 1)
out = []
for name, size in (('fmi2GetReal', 8), ('fmi2GetInteger', 4), ('fmi2GetBoolean', 4), ('fmi2GetString', 8),
                   ('fmi2SetReal', 8), ('fmi2SetInteger', 4), ('fmi2SetBoolean', 4), ('fmi2SetString', 8)):
    fn = getattr(f.dll, name)
    fn.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p]
    fn.restype = ctypes.c_int
    buf = ctypes.create_string_buffer(2 * size)
    out.append((name, fn(c, vr, 2, None), fn(c, None, 2, buf)))
f.doStep(0.0, 1e-3)   # still usable
f.terminate(); f.freeInstance()
print('RESULT', json.dumps(out))
"""


@pytest.mark.parametrize("where", ["in", "out"])
def test_null_arrays_are_refused_by_every_getter_and_setter(where, differential_fmu):
    r = subprocess.run([sys.executable, "-c", CODE, str(differential_fmu)], capture_output=True, text=True,
                       timeout=120, env={**os.environ, "SPURDIFF_FMU_PROCESS": where})
    assert r.returncode == 0, f"the host died ({r.returncode}):\n{r.stdout[-2000:]}{r.stderr[-2000:]}"
    result = json.loads(r.stdout.split("RESULT", 1)[1])
    assert all(a == 3 and b == 3 for _, a, b in result), result   # fmi2Error for both kinds of NULL
    assert "fmi2GetReal: value is NULL for nvr = 2" in r.stdout and "fmi2GetReal: vr is NULL for nvr = 2" in r.stdout
