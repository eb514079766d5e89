"""The model's own process makes one round trip per communication step (issue 44 item 4;
fmu_src/native/fmi/fmi2_remote_batch.c): fmi2SetReal of inputs is deferred to the next call and
fmi2GetReal after fmi2DoStep answers from the values the step brought back. Nothing a host sees
may change: the same results bit for bit as in the host's process, an input out of its range
refused by the step naming it (the set itself is fmi2OK on both sides, as the adapter defines),
a value read after a set and no step the model's new one, a set of something not settable still
refused at the set, and the FMI 3.0 binary (the same loader) likewise."""
from __future__ import annotations

import math
from ctypes import c_double, c_size_t, c_uint

import pytest

from harness.fmi.instance import Instance
from harness.measure.bench.process import model_process

STEPS = 60
H = 5e-3


# the own process with every step there (SPURDIFF_FMU_STEP=model): the batch is of the steps the model's
# process takes (by default the loader steps a compiled model in the host's process, where the same checks
# run: tests/fmus/test_handover.py)
OWN = "out-model"


class Host:
    """A master's step loop on one instance through the C functions (raw statuses), as the bench
    calls them."""

    def __init__(self, path, mode: str):
        with model_process(mode):
            self.inst = Instance(f"batch-{mode}", path)
        self.inst.slave.setupExperiment(startTime=0.0)
        self.inst.slave.enterInitializationMode()
        self.inst.slave.exitInitializationMode()
        reals = [v for v in self.inst.md.modelVariables if v.type == "Real"]
        self.vr = {v.name: v.valueReference for v in reals}
        self.inputs = [v.name for v in reals if v.causality == "input"]
        self.outputs = [v.name for v in reals if v.causality == "output"]
        self.f = {n: self.inst.fast_function(n) for n in ("fmi2SetReal", "fmi2GetReal", "fmi2DoStep")}
        self.c = self.inst.c_component
        self.t = 0.0

    def set(self, names, values) -> int:
        vr = (c_uint * len(names))(*(self.vr[n] for n in names))
        return self.f["fmi2SetReal"](self.c, vr, c_size_t(len(names)), (c_double * len(names))(*values))

    def get(self, names) -> tuple[int, list[float]]:
        vr, x = (c_uint * len(names))(*(self.vr[n] for n in names)), (c_double * len(names))()
        s = self.f["fmi2GetReal"](self.c, vr, c_size_t(len(names)), x)
        return s, list(x)

    def step(self) -> int:
        s = self.f["fmi2DoStep"](self.c, c_double(self.t), c_double(H), 1)
        if s <= 1:
            self.t += H
        return s

    def close(self):
        self.inst.close()


def _torques(k: int) -> list[float]:
    return [40.0 * math.sin(0.3 * k), 100.0 + 5.0 * math.cos(0.2 * k), 80.0 - 3.0 * math.sin(0.1 * k)]


TORQUES = ["carrier.tau", "left.tau", "right.tau"]


def _run(path, mode: str) -> list:
    """Each step: set three torques, step, get every Real output and the torques; then a set with
    no step and the torques read back. Every status and value, in order."""
    host = Host(path, mode)
    try:
        trace = []
        for k in range(STEPS):
            trace.append(("set", host.set(TORQUES, _torques(k))))
            trace.append(("step", host.step()))
            trace.append(("get", *host.get(host.outputs + TORQUES)))
        trace.append(("set", host.set(TORQUES, [1.0, 2.0, 3.0])))
        trace.append(("get after set", *host.get(TORQUES)))
        return trace
    finally:
        host.close()


@pytest.fixture(scope="module")
def runs(differential_fmu):
    return {mode: _run(differential_fmu, mode) for mode in ("in", OWN)}


def test_own_process_gives_this_process_results_bit_for_bit(runs):
    assert runs[OWN] == runs["in"]
    assert all(r[1] == 0 for r in runs["in"])
    outputs = [r[2] for r in runs["in"] if r[0] == "get"]
    assert outputs[0] != outputs[-1]   # the inputs changed the outputs: a run that did something


def test_a_get_after_a_set_and_no_step_reads_the_new_values(runs):
    for mode in ("in", OWN):
        last = runs[mode][-1]
        assert last[0] == "get after set" and last[1] == 0 and last[2] == [1.0, 2.0, 3.0], mode
        assert runs[mode][-3][2][-3:] == _torques(STEPS - 1)   # the step's get read the values then


def test_an_input_out_of_range_is_refused_by_the_step_naming_it_on_both_sides(differential_fmu):
    seen = {}
    for mode in ("in", OWN):
        host = Host(differential_fmu, mode)
        try:
            for k in range(3):   # the references learned (deferred from the second step on)
                assert host.set(TORQUES, _torques(k)) == 0 and host.step() == 0
                assert host.get(host.outputs)[0] == 0
            host.inst.messages.clear()
            set_status = host.set(TORQUES, [0.0, 2e6, 0.0])   # left.tau is declared in [-1e6, 1e6]
            step_status = host.step()
            text = " ".join(m for _, m in host.inst.messages)
            seen[mode] = (set_status, step_status, text)
            assert host.set(TORQUES, [0.0, 10.0, 10.0]) == 0 and host.step() == 0   # the instance goes on
        finally:
            host.close()
    assert seen[OWN] == seen["in"]
    set_status, step_status, text = seen["in"]
    assert set_status == 0 and step_status == 2   # fmi2OK, then fmi2Discard
    assert "input left.tau = 2000000.0 is outside [-1e+06, 1e+06]" in text


def test_a_set_of_an_output_is_refused_at_the_set_after_sets_were_deferred(differential_fmu):
    for mode in ("in", OWN):
        host = Host(differential_fmu, mode)
        try:
            for k in range(3):
                assert host.set(TORQUES, _torques(k)) == 0 and host.step() == 0
            assert host.set(TORQUES, [5.0, 6.0, 7.0]) == 0   # deferred in its own process
            host.inst.messages.clear()
            assert host.set([host.outputs[0]], [1.0]) == 3, mode   # fmi2Error at this call
            assert "not a settable Real variable" in " ".join(m for _, m in host.inst.messages), mode
            assert host.get(TORQUES) == (0, [5.0, 6.0, 7.0]), mode   # the deferred set was made
        finally:
            host.close()


def test_state_restore_and_reset_invalidate_the_values_brought_back(differential_fmu):
    from ctypes import byref, c_void_p

    got = {}
    for mode in ("in", OWN):
        host = Host(differential_fmu, mode)
        get_state, set_state, free_state = (host.inst.fast_function(n) for n in
                                            ("fmi2GetFMUstate", "fmi2SetFMUstate", "fmi2FreeFMUstate"))
        try:
            st = c_void_p()
            host.set(TORQUES, _torques(0))
            host.step()
            assert get_state(host.c, byref(st)) == 0
            first = host.get(host.outputs)
            for k in range(1, 5):
                host.set(TORQUES, _torques(k))
                host.step()
                host.get(host.outputs)
            assert set_state(host.c, st) == 0
            got[mode] = (first, host.get(host.outputs))   # the restored state's, not the last step's
            free_state(host.c, byref(st))
        finally:
            host.close()
    assert got[OWN] == got["in"] and got["in"][1] == got["in"][0]


def test_the_steps_set_and_get_make_no_round_trip(differential_fmu):
    """With the model's process stopped (SIGSTOP), the get after a step and the next set still
    answer (from what the step brought back; deferred): no round trip. The step after them waits
    for the process, which goes on when continued, with the deferred set made."""
    import os
    import signal
    from pathlib import Path

    host = Host(differential_fmu, OWN)
    try:
        kids = {int(x) for t in Path(f"/proc/{os.getpid()}/task").iterdir() for x in (t / "children").read_text().split()}
        server = next(k for k in kids if "spurdiff_fmu_server" in Path(f"/proc/{k}/cmdline").read_text())
        for k in range(3):
            host.set(TORQUES, _torques(k))
            host.step()
            before = host.get(host.outputs)
        os.kill(server, signal.SIGSTOP)
        try:
            assert host.get(host.outputs) == before
            assert host.set(TORQUES, [9.0, 8.0, 7.0]) == 0
        finally:
            os.kill(server, signal.SIGCONT)
        assert host.step() == 0 and host.get(TORQUES) == (0, [9.0, 8.0, 7.0])
    finally:
        host.close()


@pytest.mark.parametrize("step", ["model", "auto"])
@pytest.mark.parametrize("early", [False, True])
def test_fmi3_binary_in_its_own_process_gives_this_process_results_bit_for_bit(fmu_files, early, step):
    """SpurDifferential-fmi3.fmu (fmi3_loader.c on the same loader): fmi3SetFloat64, fmi3DoStep
    (with early return allowed: the loader's spurdiffDoStepEarly), fmi3GetFloat64 of the outputs and
    `time`, the same in both processes; with the steps in the model's process (model) and handed to
    the host's (auto: tests/fmus/test_handover.py)."""
    own = "out-model" if step == "model" else "out"
    from fmpy.fmi3 import FMU3Slave

    from harness.build.fmu3 import build
    from harness.fmi.instance import fmu_cache

    path = build(["SpurDifferential"], quiet=True)[0]
    unzipdir, md = fmu_cache().get(path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outputs = [vr[v.name] for v in md.modelVariables if v.causality == "output" and v.type == "Float64"]
    inputs = [vr[n] for n in TORQUES]
    runs = {}
    for mode in ("in", own):
        with model_process(mode):
            s = FMU3Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
                          instanceName=f"b3-{mode}")
            s.instantiate(loggingOn=False, earlyReturnAllowed=early)
        try:
            s.enterInitializationMode(startTime=0.0)
            s.exitInitializationMode()
            t, trace = 0.0, []
            for k in range(30):
                s.setFloat64(inputs, _torques(k))
                r = s.doStep(t, H)
                t = r[-1] if early else t + H   # lastSuccessfulTime
                trace.append((r, s.getFloat64(outputs + [vr["time"]])))
            runs[mode] = trace
        finally:
            s.terminate()
            s.freeInstance()
    assert runs[own] == runs["in"]


def test_the_load_bench_spins_beside_the_step_and_ends_its_spinners(differential_fmu, capsys):
    """`python -m harness.cli.tools.process_bench --load N`: the step quiet and beside N spinning
    processes, which are gone after it."""
    import os
    from pathlib import Path

    from harness.cli.tools import process_bench
    from harness.measure.bench import process

    def children():
        return {int(x) for t in Path(f"/proc/{os.getpid()}/task").iterdir() for x in (t / "children").read_text().split()}

    started = []
    real_popen = process.subprocess.Popen

    def popen(*a, **k):
        p = real_popen(*a, **k)
        started.append(p.pid)
        return p

    process.subprocess.Popen = popen
    try:
        assert process_bench.main(["--load", "2", "--steps", "20", "--fmu", str(differential_fmu)]) == 0
    finally:
        process.subprocess.Popen = real_popen
    out = capsys.readouterr().out
    assert len(started) == 2 and not set(started) & children()
    assert "quiet   set+doStep+get" in out and "beside 2 spinning processes" in out and out.count("ratio") == 4
