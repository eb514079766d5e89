"""No host waits without bound on the model's own process (fmu_src/native/fmi/fmi2_remote.c, issue 45
item 3 / issue 44 item 4): a stopped model process (SIGSTOP) ends the call with fmi2Error naming it
within about a second, a blocked one that uses no CPU within about ten, any call at the deadline
SPURDIFF_FMU_CALL_TIMEOUT; the process is then gone. A host that forks: the child's calls are
refused with the reason logged, its fmi2FreeInstance leaves the parent's model process running, and
the model process ends when the parent dies even while the child lives. Each host is a Python
process of its own (fmpy, SPURDIFF_FMU_PROCESS=out)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from tests.harness.test_python_hosts import OWN_PROCESS, _children, _gone, _misbehaving_copy


# the hosts started here unpack their FMU into a temporary folder they may never remove: tests/conftest.py
pytestmark = pytest.mark.usefixtures("children_scratch_in_tmp_path")


HOST = r"""
import os, signal, sys, time
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
md = read_model_description(sys.argv[1])
f = FMU2Slave(guid=md.guid, unzipDirectory=extract(sys.argv[1]), modelIdentifier='SpurDifferential', instanceName='d')
f.instantiate(loggingOn=True)   # fmpy's default logger prints the FMU's messages on stdout
f.setupExperiment(startTime=0); f.enterInitializationMode(); f.exitInitializationMode()
f.doStep(0.0, 1e-3)
def server():
    kids = []
    for t in os.listdir('/proc/self/task'):
        kids += open(f'/proc/self/task/{t}/children').read().split()
    assert len(kids) == 1, kids
    return int(kids[0])
"""


# every step goes to the model's process (SPURDIFF_FMU_STEP=model): the waits are on its answer (by
# default the loader steps a compiled model in the host's process: tests/fmus/test_handover.py)
MODEL_STEPS = {"SPURDIFF_FMU_STEP": "model"}


def _host(fmu, body: str, env: dict | None = None, timeout: float = 90) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", HOST + body, str(fmu)], capture_output=True, text=True,
                          timeout=timeout, env={**os.environ, **OWN_PROCESS, **MODEL_STEPS, **(env or {})})


STEP_TIMED = r"""
t0 = time.monotonic()
try:
    f.doStep(1e-3, 1e-3)
    print('NO ERROR')
except FMICallException as e:
    print('ERROR', e)
print('ELAPSED', time.monotonic() - t0)
print('SERVER', pid)
f.freeInstance()
print('FREED')
"""
STOP_AND_STEP = "pid = server()\nos.kill(pid, signal.SIGSTOP)" + STEP_TIMED   # a stopped model process


def _elapsed(out: str) -> float:
    return float(next(ln.split()[1] for ln in out.splitlines() if ln.startswith("ELAPSED")))


def _server(out: str) -> int:
    return int(next(ln.split()[1] for ln in out.splitlines() if ln.startswith("SERVER")))


def test_a_stopped_model_process_ends_the_call_with_an_error(differential_fmu):
    r = _host(differential_fmu, STOP_AND_STEP)
    assert r.returncode == 0, r.stdout + r.stderr
    out = r.stdout + r.stderr
    assert "ERROR" in r.stdout and "NO ERROR" not in r.stdout, out
    assert "fmi2DoStep: the model's process" in out and "has been stopped for 1 s (SIGSTOP" in out, out
    assert 0.9 < _elapsed(r.stdout) < 5.0, out          # stated: 1 s stopped (+ one 50 ms slice)
    assert "FREED" in r.stdout and _gone(_server(r.stdout))


def test_the_call_deadline(differential_fmu):
    """SPURDIFF_FMU_CALL_TIMEOUT bounds any call (here before the 1 s of the stopped rule)."""
    r = _host(differential_fmu, "os.environ['SPURDIFF_FMU_CALL_TIMEOUT'] = '0.3'   # read at each call\n"
              + STOP_AND_STEP)
    out = r.stdout + r.stderr
    assert r.returncode == 0 and "NO ERROR" not in r.stdout, out
    assert "has not answered within 0.3 s (SPURDIFF_FMU_CALL_TIMEOUT)" in out, out
    assert 0.25 < _elapsed(r.stdout) < 3.0 and _gone(_server(r.stdout)), out


def _sleeping_copy(fmu, out):
    """The FMU with a do_step that blocks for good (sleeps, no CPU) after the first steps."""
    return _misbehaving_copy(fmu, out, 0.5e-3, "time", "_m.sleep(3600)")


def test_a_silent_model_process_ends_the_call_with_an_error(differential_fmu, tmp_path):
    r = _host(_sleeping_copy(differential_fmu, tmp_path / "SpurDifferential.fmu"), "pid = server()" + STEP_TIMED)
    out = r.stdout + r.stderr
    assert r.returncode == 0 and "NO ERROR" not in r.stdout, out
    assert "has not answered and has used no CPU for 10 s (blocked: hung)" in out, out
    assert 9.5 < _elapsed(r.stdout) < 20.0 and _gone(_server(r.stdout)), out


@pytest.mark.parametrize("step", ["model", "auto"])   # auto: the child's step on the host's copy is refused too
def test_a_forked_child_is_refused_and_its_free_leaves_the_parent_running(differential_fmu, step):
    body = r"""
pid = server()
child = os.fork()
if child == 0:
    try:
        f.doStep(1e-3, 1e-3)
        os.write(1, b'CHILD NO ERROR\n')
    except FMICallException:
        os.write(1, b'CHILD ERROR\n')
    f.freeInstance()
    sys.stdout.flush()
    os._exit(0)
os.waitpid(child, 0)
t = 1e-3
for i in range(20):
    f.doStep(t, 1e-3)
    t += 1e-3
print('PARENT STEPPED', server() == pid)
f.terminate(); f.freeInstance()
print('SERVER', pid)
"""
    r = _host(differential_fmu, body, env={"SPURDIFF_FMU_STEP": step})
    out = r.stdout + r.stderr
    assert r.returncode == 0, out
    assert "CHILD ERROR" in r.stdout and "CHILD NO ERROR" not in r.stdout, out
    assert "is a fork of the one that instantiated the FMU" in out, out
    assert "this process's copy is freed, the model's process goes on" in out, out
    assert "PARENT STEPPED True" in r.stdout and _gone(_server(r.stdout)), out


def test_the_model_process_ends_with_its_host_while_a_forked_child_lives(differential_fmu):
    body = r"""
pid = server()
child = os.fork()
if child == 0:
    time.sleep(60)
    os._exit(0)
print('SERVER', pid, flush=True)
print('CHILD', child, flush=True)
time.sleep(60)
"""
    p = subprocess.Popen([sys.executable, "-c", HOST + body, str(differential_fmu)], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, env={**os.environ, **OWN_PROCESS})
    child = None
    try:
        lines = []
        for line in p.stdout:
            lines.append(line)
            if line.startswith("CHILD"):
                break
        server = _server("".join(lines))
        child = int(lines[-1].split()[1])
        assert _children(p.pid) == [server, child] or sorted(_children(p.pid)) == sorted([server, child])
        p.send_signal(signal.SIGKILL)
        p.wait(timeout=30)
        deadline = time.monotonic() + 5
        while not _gone(server) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _gone(server), "the model's process outlived its host (a forked child holds the pipe)"
        assert not _gone(child)
    finally:
        if p.poll() is None:
            p.kill()
        if child:
            try:
                os.kill(child, signal.SIGKILL)
            except ProcessLookupError:
                pass
