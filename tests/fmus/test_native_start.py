"""The native start (fmu_src/native/fmi/native_start.c, spurdiff/fmi/native_start.py): a host that keeps
SpurDifferential's defaults runs it without its Python starting, and sees exactly what it sees with
the Python started at fmi2Instantiate (SPURDIFF_FMU_START=python): every status, every value of every
variable at every step, every message. A call the native start does not answer starts the Python,
replays the calls so far there and goes on, again exactly as the Python-started instance does."""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest
from fmpy.fmi1 import FMICallException

from harness.fmi.instance import Instance

KINDS = ("Real", "Integer", "Boolean", "String")


def _all(inst) -> dict:
    """Every variable's value (its kind's getter, one call per kind), or the failure."""
    out = {}
    for kind in KINDS:
        vs = [v for v in inst.md.modelVariables if v.type == kind]
        try:
            got = getattr(inst.slave, f"get{kind}")([v.valueReference for v in vs])
        except FMICallException as e:
            out[kind] = f"failed: {e}"
            continue
        out.update({v.name: x for v, x in zip(vs, got)})
    return out


def _outputs(inst) -> list:
    vs = [v.valueReference for v in inst.md.modelVariables if v.type == "Real" and v.causality == "output"]
    return list(inst.slave.getReal(vs))


def _run(fmu, mode: str, program, monkeypatch, unzipdir=None, md=None) -> list:
    """The trace of ``program`` (a list of actions) on a new instance started in ``mode``: each action's
    results, then the messages the instance logged."""
    monkeypatch.setenv("SPURDIFF_FMU_START", mode)
    inst = Instance("ns", None, unzipdir=unzipdir, md=md) if unzipdir else Instance("ns", fmu)
    trace, t = [], 0.0
    try:
        for act, *args in program:
            try:
                if act == "setup":
                    inst.slave.setupExperiment(startTime=0.0, stopTime=args[0])
                elif act == "enter":
                    inst.slave.enterInitializationMode()
                elif act == "exit":
                    inst.slave.exitInitializationMode()
                elif act == "set":
                    inst.set_value(*args)
                elif act == "all":
                    trace.append(_all(inst))
                elif act == "steps":
                    n, h = args
                    for _ in range(n):
                        inst.slave.doStep(t, h)
                        t += h
                        trace.append(_outputs(inst))
                elif act == "state":
                    s = inst.slave.getFMUstate()
                    inst.slave.setFMUstate(s)
                    inst.slave.freeFMUstate(s)
                elif act == "reset":
                    inst.slave.reset()
                    t = 0.0
                elif act == "terminate":
                    inst.slave.terminate()
                elif act == "logging":
                    inst.slave.setDebugLogging(args[0], [])
                trace.append((act, "ok"))
            except FMICallException as e:
                trace.append((act, str(e)))
    finally:
        inst.close()
    return trace + [("messages", list(inst.messages))]


START = [("all",), ("setup", 10.0), ("enter",), ("all",), ("exit",), ("all",)]


def _default(changes):
    return START + [("steps", 50, 1e-3), *(("set", k, v) for k, v in changes), ("steps", 50, 2e-3), ("all",),
                    ("terminate",), ("all",)]


DEFAULT = _default([("left.tau", -150.0), ("right.tau", -350.0)])
CHANGES = {"SpurDifferential": [("left.tau", -150.0), ("right.tau", -350.0)],
           "Vehicle": [("speedTarget", 12.0), ("rearLeft.Fx", 300.0)],
           "WheelLoad": [("shaftIn.tau", 50.0), ("Fz", 3500.0)]}


@pytest.mark.parametrize("name", list(CHANGES))
def test_default_run_equals_the_python_start(fmu_files, monkeypatch, name):
    """The whole default experiment with input changes: statuses, every variable before, in and after
    Initialization Mode and at the end, the outputs after each of 100 steps, the messages (each FMU)."""
    program = _default(CHANGES[name])
    native = _run(fmu_files[name], "auto", program, monkeypatch)
    python = _run(fmu_files[name], "python", program, monkeypatch)
    assert native == python
    assert native[-1][1], "the start logs its messages (logging on): the comparison would prove little"
    assert len([x for x in native if isinstance(x, list)]) == 100


@pytest.mark.parametrize("late", [
    [("set", "differential.w_start", 5.0)],                  # a parameter set to another value
    [("set", "left.tau", 1e9)],                              # an input out of range: refused at the step
], ids=["parameter", "input-range"])
def test_a_change_starts_the_python_and_equals_it(differential_fmu, monkeypatch, late):
    program = START[:3] + late + START[3:] + [("steps", 20, 1e-3)] + late + [("steps", 5, 1e-3), ("all",)]
    assert _run(differential_fmu, "auto", program, monkeypatch) == _run(differential_fmu, "python", program,
                                                                         monkeypatch)


@pytest.mark.parametrize("process", ["in", "out"])
@pytest.mark.parametrize("call", ["state", "reset"])
def test_a_call_after_native_steps_replays_them(differential_fmu, monkeypatch, process, call):
    """FMU states and fmi2Reset after 40 native steps: the Python starts (in the host's process or its
    own), replays the 40 steps and the input sets, checks its outputs against the native ones, goes on."""
    monkeypatch.setenv("SPURDIFF_FMU_PROCESS", process)
    program = DEFAULT[:-3] + [("set", "left.tau", -120.0), ("steps", 20, 1e-3), (call,)]
    program += START[1:] if call == "reset" else []
    program += [("steps", 20, 1e-3), ("all",)]
    native = _run(differential_fmu, "auto", program, monkeypatch)
    assert native == _run(differential_fmu, "python", program, monkeypatch)
    assert (call, "ok") in native


@pytest.mark.parametrize("damage", ["truncated", "one byte of a number"])
def test_a_damaged_native_start_warns_and_starts_the_python(differential_fmu, monkeypatch, tmp_path, damage):
    """A file cut short, or with one bit of one of its numbers flipped (which would parse: the CRC-32
    at its end refuses it), is never run: a warning naming it, then the Python start."""
    from fmpy import extract, read_model_description

    unzipdir = extract(str(differential_fmu), str(tmp_path / "x"))
    md = read_model_description(unzipdir)
    f = os.path.join(unzipdir, "resources", "native_start.bin")
    with open(f, "r+b") as fh:
        if damage == "truncated":
            fh.truncate(os.path.getsize(f) // 2)
        else:
            data = bytearray(fh.read())
            data[len(data) // 3] ^= 0x01
            fh.seek(0)
            fh.write(data)
    native = _run(differential_fmu, "auto", DEFAULT, monkeypatch, unzipdir=unzipdir, md=md)
    python = _run(differential_fmu, "python", DEFAULT, monkeypatch, unzipdir=unzipdir, md=md)
    warned = [m for m in native[-1][1] if "the native start is not used" in m[1]]
    assert warned and "native_start.bin is damaged" in warned[0][1]
    assert native[:-1] == python[:-1]


@pytest.mark.parametrize("env, value, other", [("SPURDIFF_FMU_START", "fast", "python"),
                                               ("SPURDIFF_FMU_STEP", "host", "model"),          # the hand-over
                                               ("SPURDIFF_FMU_START_CACHE", "on", "off")])      # the start cache
def test_an_unknown_mode_is_refused_naming_it(differential_fmu, monkeypatch, env, value, other):
    monkeypatch.setenv(env, value)
    inst = Instance("ns", differential_fmu, instantiate=False)
    assert not inst.instantiate(raise_on_null=False)
    assert any(f"{env} = '{value}'; allowed: auto (default), {other}" in m for _, m in inst.messages)


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("name", list(CHANGES))
def test_the_default_run_starts_no_python(fmu_files, tmp_path, name, version):
    """In a fresh fmpy process: after the default experiment (simulate_fmu, every output recorded at
    every step) no module of the FMU's package is loaded with the native start, and the Python-started
    run does load it (the check can fail)."""
    script = textwrap.dedent("""
        import os, sys
        from fmpy import extract, simulate_fmu
        d = str(extract(sys.argv[1], sys.argv[2]))
        r = simulate_fmu(d, output_interval=0.001)
        mine = [m for m, x in list(sys.modules.items()) if str(getattr(x, "__file__", "")).startswith(d)]
        print(len(r), len(mine))
    """)
    if version == 3:
        from harness.build.fmu3 import build

        fmu = build([name], quiet=True)[0]
    else:
        fmu = fmu_files[name]
    counts = {}
    for mode in ("auto", "python"):
        env = {**os.environ, "SPURDIFF_FMU_START": mode}
        r = subprocess.run([sys.executable, "-c", script, str(fmu), str(tmp_path / mode)],
                           capture_output=True, text=True, env=env, timeout=300)
        assert r.returncode == 0, r.stderr
        counts[mode] = tuple(int(x) for x in r.stdout.split())
    assert counts["auto"][0] == counts["python"][0] > 100
    assert counts["auto"][1] == 0 and counts["python"][1] > 20


def test_the_fmi3_default_run_equals_the_python_start(fmu_files, monkeypatch, tmp_path):
    from fmpy import simulate_fmu

    from harness.build.fmu3 import build

    fmu3 = build(["SpurDifferential"], quiet=True)[0]
    results = {}
    for mode in ("auto", "python"):
        monkeypatch.setenv("SPURDIFF_FMU_START", mode)
        results[mode] = simulate_fmu(str(fmu3), output_interval=0.001)
    assert results["auto"].dtype.names == results["python"].dtype.names
    assert len(results["auto"]) > 100
    assert results["auto"].tobytes() == results["python"].tobytes()


@pytest.mark.parametrize("name", list(CHANGES))
def test_every_fmu_carries_a_native_start(fmu_files, name):
    import zipfile

    with zipfile.ZipFile(fmu_files[name]) as z:
        assert z.read("resources/native_start.bin")[:8] == b"SPNS\x03\0\0\0"


def _servers() -> int:
    """This process's model processes (spurdiff_fmu_server children)."""
    from pathlib import Path

    kids = [int(x) for t in Path(f"/proc/{os.getpid()}/task").iterdir()
            for x in (t / "children").read_text().split()]
    return sum("spurdiff_fmu_server" in Path(f"/proc/{k}/cmdline").read_text() for k in kids
               if Path(f"/proc/{k}").exists())


@pytest.mark.parametrize("process", ["in", "out"])
def test_a_long_run_is_handed_over_as_a_state(differential_fmu, monkeypatch, process):
    """Steps and input sets are not on the tape (one record marks where the native start began to
    step): with the tape's limit at 4,000 bytes (which 25 steps with 4 sets each filled when every call
    was recorded), 60 such steps and 100 more stay native, and the FMU state call after them starts the
    Python, which takes the native step's state instead of replaying the steps: the whole run equals
    the Python start's, in the host's process and in the model's own."""
    monkeypatch.setenv("SPURDIFF_FMU_START_TAPE", "4000")
    monkeypatch.setenv("SPURDIFF_FMU_PROCESS", process)
    sets = [("set", "left.tau", -201.0), ("set", "right.tau", -299.0), ("set", "left.tau", -200.0),
            ("set", "right.tau", -300.0)]
    program = START + [x for _ in range(60) for x in (*sets, ("steps", 1, 1e-3))] + [
        ("steps", 100, 1e-3), ("all",), ("state",), ("steps", 20, 1e-3), ("all",)]
    assert _run(differential_fmu, "auto", program, monkeypatch) == _run(differential_fmu, "python", program,
                                                                         monkeypatch)


@pytest.mark.parametrize("process", ["in", "out"])
def test_past_the_tapes_limit_the_python_takes_over(differential_fmu, monkeypatch, process):
    """Calls before the first step are on the tape, which is bounded (64 MB; here
    SPURDIFF_FMU_START_TAPE=4000 bytes, about 140 sets of one value): a host that sets a parameter to
    its start value 300 times in Initialization Mode starts the Python at the set past the limit, which
    replays the calls and goes on: the whole run equals the Python start's."""
    monkeypatch.setenv("SPURDIFF_FMU_START_TAPE", "4000")
    monkeypatch.setenv("SPURDIFF_FMU_PROCESS", process)
    program = (START[:3] + [("set", "left.tau", -200.0)] * 300 + [("exit",), ("all",), ("steps", 20, 1e-3), ("all",)])
    assert _run(differential_fmu, "auto", program, monkeypatch) == _run(differential_fmu, "python", program,
                                                                         monkeypatch)


@pytest.mark.parametrize("limit", [None, "4000"])
def test_no_model_process_starts_however_long_the_run(differential_fmu, monkeypatch, limit):
    """In a host that runs the model in its own process: no model process while the native start
    answers, over 300 steps with two input sets each, under the full tape limit and under 4,000 bytes
    (which 25 such steps filled when every call was recorded)."""
    monkeypatch.setenv("SPURDIFF_FMU_START", "auto")
    monkeypatch.setenv("SPURDIFF_FMU_PROCESS", "out")
    if limit:
        monkeypatch.setenv("SPURDIFF_FMU_START_TAPE", limit)
    before = _servers()
    inst = Instance("tape", differential_fmu)
    try:
        s = inst.slave
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()
        assert _servers() == before
        vrs = [inst.var(n).valueReference for n in ("left.tau", "right.tau")]
        for i in range(300):
            s.setReal(vrs, [-201.0, -299.0])     # near the defaults: no watch logs (which would start it)
            s.setReal(vrs, [-200.0, -300.0])
            s.doStep(i * 1e-3, 1e-3)
        assert _servers() == before
        s.getFMUstate()                          # a call the native start does not answer: the model's
        assert _servers() == before + 1          # process starts now
    finally:
        inst.close()


_MEMORY = textwrap.dedent("""
    import sys
    from fmpy import read_model_description
    from fmpy.fmi2 import FMU2Slave
    md = read_model_description(sys.argv[1])
    s = FMU2Slave(guid=md.guid, unzipDirectory=sys.argv[2], modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName='memory')
    s.instantiate(); s.setupExperiment(startTime=0.0); s.enterInitializationMode(); s.exitInitializationMode()
    reals = [v for v in md.modelVariables if v.type == 'Real']
    ins = [v.valueReference for v in reals if v.causality == 'input']
    outs = [v.valueReference for v in reals if v.causality == 'output']
    values = s.getReal(ins)
    def rss():
        return int(open('/proc/self/statm').read().split()[1])
    t, marks = 0.0, []
    for block in range(3):
        for _ in range(20000):
            s.setReal(ins, values); s.doStep(t, 0.001); s.getReal(outs); t += 0.001
        marks.append(rss())
    print('PAGES', *marks)
    s.terminate(); s.freeInstance()
""")


def test_a_native_start_s_memory_does_not_grow_with_the_run(differential_fmu, tmp_path):
    """The host's resident pages after 20,000, 40,000 and 60,000 native steps (every input set and every
    output read each step) stay within 256 kB: nothing is kept per step (the tape took about 290 bytes
    a step, 11 MB over the last 40,000, when it recorded every call)."""
    import zipfile

    with zipfile.ZipFile(differential_fmu) as z:
        z.extractall(tmp_path)
    r = subprocess.run([sys.executable, "-c", _MEMORY, str(tmp_path / "modelDescription.xml"), str(tmp_path)],
                       capture_output=True, text=True, timeout=300,
                       env={**os.environ, "SPURDIFF_FMU_START": "auto", "SPURDIFF_FMU_PROCESS": "in"})
    assert r.returncode == 0, r.stderr[-2000:]
    first, _, last = (int(x) for x in next(ln for ln in r.stdout.splitlines() if ln.startswith("PAGES")).split()[1:])
    assert (last - first) * os.sysconf("SC_PAGE_SIZE") <= 256 * 1024, r.stdout
