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


@pytest.mark.parametrize("process", ["in", "out"])
def test_past_the_tapes_limit_the_python_takes_over(differential_fmu, monkeypatch, process):
    """A run longer than the tape holds (64 MB; here SPURDIFF_FMU_START_TAPE=4000 bytes, about 25
    steps with 4 input sets each) starts the Python at the call past the limit, replays, and goes on:
    the whole run equals the Python start's, in the host's process and in the model's own."""
    monkeypatch.setenv("SPURDIFF_FMU_START_TAPE", "4000")
    monkeypatch.setenv("SPURDIFF_FMU_PROCESS", process)
    sets = [("set", "left.tau", -201.0), ("set", "right.tau", -299.0), ("set", "left.tau", -200.0),
            ("set", "right.tau", -300.0)]
    program = START + [x for _ in range(60) for x in (*sets, ("steps", 1, 1e-3))] + [("steps", 100, 1e-3), ("all",)]
    assert _run(differential_fmu, "auto", program, monkeypatch) == _run(differential_fmu, "python", program,
                                                                         monkeypatch)


@pytest.mark.parametrize("limit", [None, "4000"])
def test_the_model_process_starts_only_past_the_tapes_limit(differential_fmu, monkeypatch, limit):
    """In a host that runs the model in its own process: no model process while the native start
    answers; with the tape's limit at 4,000 bytes one starts within the 60 steps (the same run under
    the full limit starts none)."""
    from pathlib import Path

    def servers() -> int:
        kids = [int(x) for t in Path(f"/proc/{os.getpid()}/task").iterdir()
                for x in (t / "children").read_text().split()]
        return sum("spurdiff_fmu_server" in Path(f"/proc/{k}/cmdline").read_text() for k in kids
                   if Path(f"/proc/{k}").exists())

    monkeypatch.setenv("SPURDIFF_FMU_START", "auto")
    monkeypatch.setenv("SPURDIFF_FMU_PROCESS", "out")
    if limit:
        monkeypatch.setenv("SPURDIFF_FMU_START_TAPE", limit)
    before = servers()
    inst = Instance("tape", differential_fmu)
    try:
        s = inst.slave
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()
        assert servers() == before
        vrs = [inst.var(n).valueReference for n in ("left.tau", "right.tau")]
        for i in range(60):
            s.setReal(vrs, [-201.0, -299.0])     # near the defaults: no watch logs (which would start it)
            s.setReal(vrs, [-200.0, -300.0])
            s.doStep(i * 1e-3, 1e-3)
        assert servers() == before + (1 if limit else 0)
    finally:
        inst.close()
