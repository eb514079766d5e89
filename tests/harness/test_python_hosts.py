"""Any Python host process runs the FMUs with no setup and the same results.

fmpy (with only its own dependencies) under this machine's other interpreters: Python 3.11 from
pyenv (another environment than the one that built the FMUs), Debian's own ``/usr/bin/python3``,
and Python 3.12 and 3.13 (pyenv). fmpy is installed with ``pip install --target`` into a folder
per interpreter (wheels for that interpreter's version), the interpreter runs isolated (``-I``)
with only that folder added. A host of the runtime's version runs the model in process on its own
interpreter; any other runs it in the model's own process (fmi2_remote.c). Interpreters that are
not on this machine are skipped with that reason. Also here: a crash of the model in its own
process is fmi2Error in the host, and the model's process never outlives its host.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu

from harness.build import fmu_contents
from host_cases import CASES, STEP, STOP


# the hosts started here unpack their FMU into a temporary folder they may never remove: tests/conftest.py
pytestmark = pytest.mark.usefixtures("children_scratch_in_tmp_path")


# the model in its own process, its Python started at fmi2Instantiate (at the defaults the FMU would
# start natively, with no model process to test: fmu_src/native/fmi/native_start.c)
OWN_PROCESS = {"SPURDIFF_FMU_PROCESS": "out", "SPURDIFF_FMU_START": "python"}

INTERPRETERS = {
    "pyenv 3.11": "/root/.pyenv/versions/3.11.7/bin/python3.11",
    "debian 3.11": "/usr/bin/python3.11",
    "pyenv 3.12": "/root/.pyenv/versions/3.12.1/bin/python3.12",
    "pyenv 3.13": "/root/.pyenv/versions/3.13.0/bin/python3.13",
}
SIMULATE = """
import json, sys
from fmpy import simulate_fmu
cases = json.loads(sys.argv[1])
out = {}
for name, (path, inputs) in cases.items():
    r = simulate_fmu(path, stop_time=%r, output_interval=%r, start_values=inputs)
    out[name] = {n: [float(x) for x in r[n]] for n in r.dtype.names}
print(json.dumps({'version': sys.version.split()[0], 'results': out}))
""" % (STOP, STEP)


def _version(exe: str) -> str | None:
    if not os.access(exe, os.X_OK):
        return None
    r = subprocess.run([exe, "-I", "-c", "import sys; print('%d.%d' % sys.version_info[:2])"],
                       capture_output=True, text=True)
    return r.stdout.strip() if r.returncode == 0 else None


@pytest.fixture(scope="module")
def fmpy_targets(tmp_path_factory):
    """fmpy installed for each interpreter present (in parallel: the downloads overlap)."""
    root = tmp_path_factory.mktemp("fmpy-targets")
    jobs = {}
    for label, exe in INTERPRETERS.items():
        v = _version(exe)
        if v is None:
            continue
        target = root / label.replace(" ", "-")
        cmd = [sys.executable, "-m", "pip", "install", "-q", "--disable-pip-version-check", "--target", str(target),
               "--python-version", v, "--only-binary=:all:", "--implementation", "cp", "fmpy"]
        jobs[label] = (exe, target, subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                                     text=True))
    out = {}
    for label, (exe, target, p) in jobs.items():
        text, _ = p.communicate(timeout=600)
        out[label] = (exe, target, p.returncode, text)
    return out


@pytest.mark.parametrize("label", list(INTERPRETERS))
def test_fmpy_under_each_python_gives_the_same_results(label, fmpy_targets, fmu_files):
    if label not in fmpy_targets:
        pytest.skip(f"{INTERPRETERS[label]} is not on this machine")
    exe, target, rc, text = fmpy_targets[label]
    if rc != 0:
        pytest.skip(f"fmpy could not be installed for {label} (no package index?): {text.strip()[-300:]}")
    cases = {name: (str(fmu_files[name]), CASES[name]) for name in CASES}
    code = f"import sys; sys.path.insert(0, {str(target)!r}); exec(compile(sys.argv.pop(1), 'simulate', 'exec'))"
    r = subprocess.run([exe, "-I", "-c", code, SIMULATE, json.dumps(cases)], capture_output=True, text=True,
                       timeout=600, env={"PATH": "/usr/bin:/bin", "HOME": str(target)})
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-3000:]
    got = json.loads(r.stdout.strip().splitlines()[-1])
    for name in CASES:
        ref = simulate_fmu(str(fmu_files[name]), stop_time=STOP, output_interval=STEP, start_values=CASES[name])
        for n in ref.dtype.names:
            assert np.allclose(got["results"][name][n], ref[n], rtol=1e-12, atol=0), f"{label} {name} {n}"


def _misbehaving_copy(fmu: Path, out: Path, after: float, module: str, action: str) -> Path:
    """The FMU with a model whose steps past t = ``after`` run ``action`` (with ``module`` imported as
    ``_m``) before stepping; every step goes through fmi2_do_step (no native step)."""
    def edit(name: str, data: bytes) -> bytes:
        if name != "spurdiff/_fmu_entry.py":
            return data
        return data + (f"\nimport {module} as _m\n_base = SpurDifferential\n"
                       "class SpurDifferential(_base):\n"
                       "    def fmi2_native_enter(self):\n"
                       "        return False\n"
                       "    def fmi2_do_step(self, t, h, nsp):\n"
                       f"        if t > {after!r}:\n"
                       f"            {action}\n"
                       "        return super().fmi2_do_step(t, h, nsp)\n").encode()
    return fmu_contents.edit_package(fmu, out, edit)


def _crashing_copy(fmu: Path, out: Path) -> Path:
    """The FMU with a model that dereferences NULL in its third step."""
    return _misbehaving_copy(fmu, out, 1.5e-3, "ctypes", "_m.string_at(0)")


def test_a_crash_of_the_model_in_its_own_process_is_an_error_status(differential_fmu, tmp_path):
    crashing = _crashing_copy(differential_fmu, tmp_path / "SpurDifferential.fmu")
    code = """
import sys
from fmpy import simulate_fmu
msgs = []
def logger(env, name, status, category, message):
    msgs.append(message.decode())
try:
    simulate_fmu(sys.argv[1], stop_time=0.01, output_interval=1e-3, logger=logger)
    print('NO ERROR')
except Exception as e:
    print('ERROR', e)
print('\\n'.join(msgs))
"""
    r = subprocess.run([sys.executable, "-c", code, str(crashing)], capture_output=True, text=True, timeout=120,
                       env={**os.environ, **OWN_PROCESS})
    assert r.returncode == 0, f"the host crashed: {r.returncode}\n{r.stdout}{r.stderr}"
    assert "ERROR" in r.stdout and "NO ERROR" not in r.stdout, r.stdout
    assert "ended with signal 11" in r.stdout, r.stdout


def _children(pid: int) -> list[int]:
    kids = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        text = (task / "children").read_text().split()
        kids += [int(x) for x in text]
    return kids


def _gone(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except FileNotFoundError:
        return True
    return state in ("Z", "X")   # exited (a zombie waits for init to reap it)


@pytest.mark.parametrize("how", ["SIGKILL", "exit without freeing", "exception"])
def test_the_models_process_never_outlives_its_host(how, differential_fmu):
    code = f"""
import os, sys, time
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
md = read_model_description(sys.argv[1])
f = FMU2Slave(guid=md.guid, unzipDirectory=extract(sys.argv[1]), modelIdentifier='SpurDifferential', instanceName='d')
f.instantiate(); f.setupExperiment(startTime=0); f.enterInitializationMode(); f.exitInitializationMode()
f.doStep(0.0, 1e-3)
print('READY', flush=True)
how = {how!r}
if how == 'SIGKILL':
    time.sleep(60)
elif how == 'exception':
    sys.stdin.readline()
    raise RuntimeError('the host fails')
else:
    sys.stdin.readline()
    os._exit(0)
"""
    p = subprocess.Popen([sys.executable, "-c", code, str(differential_fmu)], stdin=subprocess.PIPE,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env={**os.environ, **OWN_PROCESS})
    try:
        seen = []                       # the FMU's log lines (fmpy prints them on stdout) come first
        for line in p.stdout:
            seen.append(line)
            if line.strip() == "READY":
                break
        if not seen or seen[-1].strip() != "READY":
            p.kill()                    # never wait on a host that waits on us
            raise AssertionError(f"no READY from the host: {''.join(seen)[-2000:]}{p.stderr.read()[-2000:]}")
        servers = _children(p.pid)
        assert len(servers) == 1, f"expected one model process, found {servers}"
        if how == "SIGKILL":
            p.send_signal(signal.SIGKILL)
        else:
            p.stdin.write("\n")
            p.stdin.flush()
        p.wait(timeout=30)
        deadline = time.monotonic() + 5
        while not _gone(servers[0]) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _gone(servers[0]), f"the model's process {servers[0]} outlived its host ({how})"
    finally:
        if p.poll() is None:
            p.kill()
