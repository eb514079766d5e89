"""The hand-over (fmu_src/native/fmi/fmi2_loader.c: take_step, give_back; native_start.c: ns_open_live;
spurdiff/fmi/native_start.py: live, restore): a model running in its own process whose step is compiled
hands the step's arrays to the host's process, which steps them there with the native start's rules and
gives them back before any call it does not answer. A host sees exactly what it sees with every step in
the model's process (SPURDIFF_FMU_STEP=model) and with the model in its own process not at all: every
status, every value of every variable, every message, bit for bit; and the steps, sets and gets after the
hand-over do not reach the model's process at all (it can be stopped meanwhile)."""
from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

from harness.fmi.instance import Instance
from tests.fmus.test_native_start import CHANGES, START, _default, _outputs, _run


def _three(fmu, program, monkeypatch, start: str = "python") -> dict:
    """The trace of ``program`` with the model in its own process, stepped in the host's (auto) and in the
    model's (model), and with the model in the host's process (in)."""
    traces = {}
    for name, process, step in (("auto", "out", "auto"), ("model", "out", "model"), ("in", "in", "auto")):
        monkeypatch.setenv("SPURDIFF_FMU_PROCESS", process)
        monkeypatch.setenv("SPURDIFF_FMU_STEP", step)
        traces[name] = _run(fmu, start, program, monkeypatch)
    return traces


def _same(traces: dict) -> list:
    assert traces["auto"] == traces["model"]
    assert traces["auto"] == traces["in"]
    return traces["auto"]


@pytest.mark.parametrize("name", list(CHANGES))
def test_each_fmus_run_is_the_same_whichever_process_steps_it(fmu_files, monkeypatch, name):
    trace = _same(_three(fmu_files[name], _default(CHANGES[name]), monkeypatch))
    assert len([x for x in trace if isinstance(x, list)]) == 100
    assert trace[-1][1], "the run logs its messages (logging on): the comparison would prove little"


@pytest.mark.parametrize("calls", [
    [("state",), ("steps", 10, 1e-3)],                                  # an FMU state: given back, then again
    [("reset",), *START[1:], ("steps", 10, 1e-3)],                      # fmi2Reset: given back, then again
    [("set", "left.tau", 1e9), ("steps", 3, 1e-3), ("set", "left.tau", -100.0), ("steps", 5, 1e-3)],  # refused
    [("steps", 1, 1e-3), ("state",)] * 12,                             # given back at every step
    [("logging", False), ("reset",), *START[1:], ("steps", 5, 1e-3)],  # the model's messages follow the switch
], ids=["state", "reset", "input-range", "each-step", "logging"])
def test_a_call_the_host_cannot_answer_gives_the_step_back(differential_fmu, monkeypatch, calls):
    program = START + [("steps", 20, 1e-3)] + calls + [("steps", 10, 2e-3), ("all",), ("terminate",), ("all",)]
    trace = _same(_three(differential_fmu, program, monkeypatch))
    if calls[0] == ("set", "left.tau", 1e9):
        assert any("input left.tau = 1000000000.0 is outside" in m[1] for m in trace[-1][1])


@pytest.mark.parametrize("name, value", [("differential.w_start", 5.0), ("shaftCoupling", "wheel")])
def test_a_python_start_at_a_changed_parameter_then_steps_in_the_host(differential_fmu, monkeypatch, name, value):
    """The native start's tape replayed into the model's own process at the parameter set, then the
    hand-over (the differential owning its half-shafts too: shaft_kernel.py's DiffNative)."""
    program = START[:3] + [("set", name, value)] + START[3:] + [("steps", 40, 1e-3), ("all",)]
    _same(_three(differential_fmu, program, monkeypatch, start="auto"))


def test_a_model_without_a_compiled_step_stays_in_its_process(differential_fmu, monkeypatch):
    program = START[:3] + [("set", "meshModel", "compliant")] + START[3:] + [("steps", 10, 1e-3), ("all",)]
    _same(_three(differential_fmu, program, monkeypatch))


def _servers() -> set[int]:
    """This process's model processes: the servers among its descendants (a zygote's children too), the
    zygotes left out; one that ends meanwhile is passed over."""
    found, todo = set(), [os.getpid()]
    while todo:
        for task in Path(f"/proc/{todo.pop()}/task").iterdir():
            try:
                kids = [int(x) for x in (task / "children").read_text().split()]
            except OSError:
                continue
            for k in kids:
                try:
                    cmd = Path(f"/proc/{k}/cmdline").read_bytes().split(b"\0")
                except OSError:
                    continue
                todo.append(k)
                if any(b"spurdiff_fmu_server" in c for c in cmd) and b"--zygote" not in cmd:
                    found.add(k)
    return found


def _server(before: set[int]) -> int:
    """The model process an instance made after ``before`` (a :func:`_servers`) runs in: the one new server
    (a process another test left ending, or a zygote, is not it)."""
    new = _servers() - before
    assert len(new) == 1, f"model processes started by this instance: {sorted(new)}"
    return new.pop()


def test_the_steps_sets_and_gets_do_not_reach_the_stopped_model_process(differential_fmu, monkeypatch):
    """With the model's process stopped (SIGSTOP) after three steps, 200 more steps with their sets and
    gets answer fmi2OK with the in-process values; an FMU state then gives the arrays back (continued),
    and the run goes on equal to the in-process one."""
    def run(process: str, stop: bool) -> list:
        monkeypatch.setenv("SPURDIFF_FMU_PROCESS", process)
        monkeypatch.setenv("SPURDIFF_FMU_START", "python")
        before = _servers()
        inst = Instance("ho", differential_fmu)
        trace, t = [], 0.0
        try:
            s = inst.slave
            s.setupExperiment(startTime=0.0)
            s.enterInitializationMode()
            s.exitInitializationMode()
            pid = _server(before) if stop else None
            for k in range(203):
                if k == 3 and stop:
                    os.kill(pid, signal.SIGSTOP)
                inst.set_value("left.tau", -200.0 - k)   # both alike: no watch logs (that step needs the Python)
                inst.set_value("right.tau", -200.0 - k)
                s.doStep(t, 1e-3)
                t += 1e-3
                trace.append(_outputs(inst))
            if stop:
                assert Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "T"
                os.kill(pid, signal.SIGCONT)
            st = s.getFMUstate()
            s.doStep(t, 1e-3)
            s.setFMUstate(st)
            s.freeFMUstate(st)
            trace.append(_outputs(inst))
        finally:
            inst.close()
        return trace

    monkeypatch.setenv("SPURDIFF_FMU_STEP", "auto")
    assert run("out", stop=True) == run("in", stop=False)


def test_the_arrays_brought_back_must_fit_the_plan():
    """spurdiff.fmi.native_start.restore refuses bytes that are not the plan's arrays, naming both sizes."""
    import ctypes
    import struct

    from spurdiff.fmi import native_start

    class Plan:
        v = (ctypes.c_double * 3)()
        const = (ctypes.c_double * 2)()

        def layout(self):
            return (None, "f"), [(1, self.const), (0,)], False

    class Slave:
        _native_key = (None, Plan())

    with pytest.raises(ValueError, match="brings back 32 bytes; the plan's arrays take 40"):
        native_start.restore(Slave(), bytes(32))
    native_start.restore(Slave(), struct.pack("=5d", 1, 2, 3, 4, 5))
    p = Slave._native_key[1]
    assert list(p.v) == [1.0, 2.0, 3.0] and list(p.const) == [4.0, 5.0]
