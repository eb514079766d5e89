"""The model processes' zygote (fmu_src/native/fmi/fmi2_server.c --zygote, fmi2_remote_spawn.c; issue 44
item 2, memory): the first own-process instance of an FMU folder in a host gets its process started
directly; the ones made while another lives are forked by the folder's zygote, which started the
runtime and imported the package once, and ends with the last instance it forked. Results are those
of processes started directly (SPURDIFF_FMU_ZYGOTE=0), a forked process that dies or stops is named
as a direct one is, and nothing outlives the host. Each host is a Python process of its own (fmpy,
SPURDIFF_FMU_PROCESS=out, SPURDIFF_FMU_START=python: at the defaults the FMU would start natively,
with no model process)."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from tests.harness.test_python_hosts import OWN_PROCESS, _children, _gone

pytestmark = pytest.mark.usefixtures("children_scratch_in_tmp_path")

HOST = r"""
import json, os, signal, sys, time
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
md = read_model_description(sys.argv[1])
vr = {v.name: v.valueReference for v in md.modelVariables}
folder = extract(sys.argv[1])
def children(pid):
    out = []
    for t in os.listdir(f'/proc/{pid}/task'):
        out += [int(x) for x in open(f'/proc/{pid}/task/{t}/children').read().split()]
    return out
def tree():
    return {k: children(k) for k in children(os.getpid())}
def make(i, w):
    f = FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier='SpurDifferential', instanceName=f'd{i}')
    f.instantiate(loggingOn=True)
    f.setupExperiment(startTime=0); f.enterInitializationMode()
    f.setReal([vr['carrier.w_ref'], vr['left.tau'], vr['right.tau']], [w, -1500.0, -600.0])
    f.exitInitializationMode()
    return f
"""

THREE = r"""
fs = [make(i, 1.0 + 0.2 * i) for i in range(3)]
shape = tree()
t = 0.0
for _ in range(20):
    for f in fs:
        f.doStep(t, 1e-3)
    t += 1e-3
values = [f.getReal([vr['lockingTorque'], vr['left.w']]) for f in fs]
for f in fs:
    f.terminate(); f.freeInstance()
time.sleep(0.3)
print(json.dumps({'tree': {str(k): v for k, v in shape.items()}, 'values': values, 'after': children(os.getpid())}))
"""


def _host(fmu, body: str, env: dict | None = None, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", HOST + body, str(fmu)], capture_output=True, text=True,
                          timeout=timeout, env={**os.environ, **OWN_PROCESS, "SPURDIFF_FMU_STEP": "model",
                                                **(env or {})})


def _out(r: subprocess.CompletedProcess) -> dict:
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_instances_made_while_another_lives_are_forked_by_one_zygote_with_the_same_results(differential_fmu):
    forked, direct = _out(_host(differential_fmu, THREE)), _out(_host(differential_fmu, THREE, {"SPURDIFF_FMU_ZYGOTE": "0"}))
    # directly: three processes, the host's children, none with children of its own
    assert len(direct["tree"]) == 3 and all(v == [] for v in direct["tree"].values()), direct["tree"]
    # with the zygote: the first instance's process and the zygote; the zygote's two are the others
    kids = forked["tree"]
    assert len(kids) == 2 and sorted(len(v) for v in kids.values()) == [0, 2], kids
    assert forked["values"] == direct["values"]          # bit for bit
    assert len({tuple(v) for v in forked["values"]}) == 3   # (three different instances)
    assert forked["after"] == [] and direct["after"] == []  # nothing left once all are freed


def test_the_zygote_ends_with_the_last_instance_it_forked_and_comes_again(differential_fmu):
    body = r"""
a = make(0, 1.0)
b = make(1, 1.2)
with_b = tree()
b.terminate(); b.freeInstance()
time.sleep(0.3)
without_b = tree()
c = make(2, 1.4)
with_c = tree()
c.doStep(0.0, 1e-3)
for f in (a, c):
    f.terminate(); f.freeInstance()
time.sleep(0.3)
print(json.dumps([len(with_b), without_b != {} and all(v == [] for v in without_b.values()), len(without_b),
                  len(with_c), children(os.getpid())]))
"""
    with_b, lone_left, n_without, with_c, after = _out(_host(differential_fmu, body))
    assert with_b == 2 and lone_left and n_without == 1, "the zygote did not end with the last instance it forked"
    assert with_c == 2 and after == []


KILL_AND_GO_ON = r"""
a = make(0, 1.0)
b = make(1, 1.2)
zygote = next(k for k, v in tree().items() if v)
os.kill({victim}, signal.{signal})
time.sleep(0.5)
try:
    b.doStep(0.0, 1e-3)
    print('NO ERROR')
except FMICallException as e:
    print('ERROR', e)
a.doStep(0.0, 1e-3)                     # the first instance goes on
c = make(2, 1.4)                        # and a new one is made
c.doStep(0.0, 1e-3)
for f in (a, b, c):
    f.freeInstance()
time.sleep(0.3)
print(json.dumps(children(os.getpid())))
"""


@pytest.mark.parametrize("victim, sig, said", [
    # a forked process that dies is named with its signal (the zygote reaps it and tells the loader)
    ("children(zygote)[0]", "SIGSEGV", "ended with signal 11"),
    # the zygote killed: its processes end (their parent changed), each call of theirs says the process
    # is gone; the first instance goes on, and the next instance is started directly
    ("zygote", "SIGKILL", "the instance is lost"),
])
def test_a_killed_forked_process_or_zygote_leaves_the_host_running(victim, sig, said, differential_fmu):
    r = _host(differential_fmu, KILL_AND_GO_ON.replace("{victim}", victim).replace("{signal}", sig))
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert "ERROR" in r.stdout and said in r.stdout, r.stdout[-3000:]
    assert json.loads(r.stdout.strip().splitlines()[-1]) == []


def test_a_stopped_forked_process_ends_the_call_and_the_others_go_on(differential_fmu):
    body = r"""
a = make(0, 1.0)
b = make(1, 1.2)
zygote = next(k for k, v in tree().items() if v)
os.kill(children(zygote)[0], signal.SIGSTOP)
t0 = time.monotonic()
try:
    b.doStep(0.0, 1e-3)
    print('NO ERROR')
except FMICallException as e:
    print('ERROR', e)
print('ELAPSED', time.monotonic() - t0)
a.doStep(0.0, 1e-3)
a.freeInstance(); b.freeInstance()
time.sleep(0.3)
print(json.dumps(children(os.getpid())))
"""
    r = _host(differential_fmu, body)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert "has been stopped for 1 s" in r.stdout, r.stdout[-3000:]
    elapsed = float(next(ln.split()[1] for ln in r.stdout.splitlines() if ln.startswith("ELAPSED")))
    assert elapsed < 30, elapsed
    assert json.loads(r.stdout.strip().splitlines()[-1]) == []


def test_nothing_outlives_a_killed_host(differential_fmu):
    body = r"""
a = make(0, 1.0)
b = make(1, 1.2)
c = make(2, 1.4)
print(json.dumps(tree()), flush=True)
time.sleep(600)
"""
    p = subprocess.Popen([sys.executable, "-c", HOST + body, str(differential_fmu)], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, env={**os.environ, **OWN_PROCESS})
    try:
        line = ""
        while not line.startswith("{"):
            line = p.stdout.readline()
            assert line or p.poll() is None, p.stderr.read()[-3000:]
        shape = json.loads(line)
        pids = [int(k) for k in shape] + [x for v in shape.values() for x in v]
        assert len(pids) == 4, shape
        p.kill()
        p.wait(10)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and not all(_gone(x) for x in pids):
            time.sleep(0.05)
        assert all(_gone(x) for x in pids), [x for x in pids if not _gone(x)]
    finally:
        if p.poll() is None:
            p.kill()
