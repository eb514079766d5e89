"""The bridge's fast fmi2GetReal / fmi2SetReal while stepping (fmu_src/native/fmi/fmi2_pybridge.c: the
slave's value table read and stored in C by the names its fmi2_real_plan gave once per
value-reference vector, each stored value checked against its range) answer as the slave's own
methods do in the other phases: the same values, the same refusals, a bad input named by the next
step whatever path stored it, and any number of value-reference vectors."""
from __future__ import annotations

import math

import pytest

from tests.fmus.fmu_session import start, status_of, steps

H = 1e-3
CASES = {   # inputs of a normal run; an input with a declared range and a value outside it
    "SpurDifferential": ({"carrier.w_ref": 1.389, "left.tau": -1050.0, "right.tau": -1040.0}, ("left.tau", 2e6)),
    "WheelLoad": ({"flange.w": 30.0, "Fz": 4000.0, "mu": 0.9, "vx": 10.0}, ("mu", 11.0)),
    "Vehicle": ({"rearLeft.Fx": 500.0, "rearRight.Fx": 480.0, "speedTarget": 10.0}, ("grade", 0.9)),
}


@pytest.fixture(params=list(CASES))
def case(request, fmu_files):
    return request.param, fmu_files[request.param], *CASES[request.param]


def reals(inst) -> list:
    return [v for v in inst.vars.values() if v.type == "Real"]


def test_reads_while_stepping_equal_the_slaves_own_getter(case):
    """Every Real read while stepping (fast path) equals the read after fmi2Terminate (the
    slave's method), one vector and one reference at a time."""
    name, path, inputs, _ = case
    inst = start(path, "read", inputs=inputs)
    steps(inst, 5, 0.0)
    vrs = [v.valueReference for v in reals(inst)]
    fast = inst.slave.getReal(vrs)
    fast_one = [inst.slave.getReal([vr])[0] for vr in vrs]
    inst.slave.terminate()
    slow = inst.slave.getReal(vrs)
    assert len(fast) == len(vrs) > 10
    assert fast == fast_one == slow
    inst.slave.freeInstance()


def test_values_stored_while_stepping_are_what_the_model_steps_with(case):
    """Inputs changed and set back while stepping (fast path), one vector and one reference at a
    time, give the run of inputs never touched; other values stored so give another run."""
    name, path, inputs, _ = case
    ref, inst, other = (start(path, n, inputs=inputs) for n in ("ref", "fast", "other"))
    t = steps(ref, 1, 0.0)
    steps(inst, 1, 0.0)
    steps(other, 1, 0.0)
    vrs = [inst.var(k).valueReference for k in inputs]
    inst.slave.setReal(vrs, [0.5 * v for v in inputs.values()])
    other.slave.setReal(vrs, [0.5 * v for v in inputs.values()])
    for vr, v in zip(vrs, inputs.values()):
        inst.slave.setReal([vr], [v])
    for x in (ref, inst, other):
        steps(x, 5, t)
    outs = [v.valueReference for v in reals(inst) if v.causality == "output"]
    assert inst.slave.getReal(outs) == ref.slave.getReal(outs)
    assert other.slave.getReal(outs) != ref.slave.getReal(outs)
    for x in (ref, inst, other):
        x.slave.freeInstance()


def test_a_bad_input_stored_while_stepping_is_named_by_the_next_step_unless_replaced(case):
    name, path, inputs, (bad, outside) = case
    inst = start(path, "bad", inputs=inputs)
    t = steps(inst, 3, 0.0)
    vr = inst.var(bad).valueReference
    good = inst.slave.getReal([vr])[0]
    for value, what in ((math.nan, "not a finite number"), (outside, "outside")):
        inst.messages.clear()
        inst.slave.setReal([vr], [value])
        assert status_of(lambda: inst.slave.doStep(t, H)) == 2   # fmi2Discard
        errs = [m for s, m in inst.messages if s >= 2]
        assert len(errs) == 1 and bad in errs[0] and what in errs[0], errs
        assert status_of(lambda: inst.slave.doStep(t, H)) == 2   # still there: refused again
        inst.slave.setReal([vr], [good])
        t = steps(inst, 1, t)                                  # replaced: steps on
    inst.slave.setReal([vr], [math.nan])                       # bad, then good before the step
    inst.slave.setReal([vr], [good])
    steps(inst, 2, t)
    inst.slave.freeInstance()


def test_a_restored_state_with_a_bad_input_is_checked_again(case):
    """fmi2SetFMUstate brings back the values of its time, a bad input among them: the step after
    it checks the inputs again although the step before passed."""
    name, path, inputs, (bad, outside) = case
    inst = start(path, "state", inputs=inputs)
    t = steps(inst, 2, 0.0)
    vr = inst.var(bad).valueReference
    good = inst.slave.getReal([vr])[0]
    inst.slave.setReal([vr], [outside])
    state = inst.slave.getFMUState()
    inst.slave.setReal([vr], [good])
    steps(inst, 1, t)
    inst.slave.setFMUState(state)
    assert status_of(lambda: inst.slave.doStep(t, H)) == 2
    assert bad in inst.last_message()
    inst.slave.freeFMUState(state)
    inst.slave.freeInstance()


def test_more_value_reference_vectors_than_the_bridge_remembers(case):
    """Ten vectors used in turn (the bridge keeps four per function): each reads and stores the
    variables it names."""
    name, path, inputs, _ = case
    inst = start(path, "many", inputs=inputs)
    t = steps(inst, 2, 0.0)
    rs = reals(inst)
    vectors = [[v.valueReference for v in rs[i:i + 3]] for i in range(10)]
    expected = [[inst.slave.getReal([vr])[0] for vr in vec] for vec in vectors]
    for _ in range(3):
        assert [inst.slave.getReal(vec) for vec in vectors] == expected
    ins = [inst.var(k).valueReference for k in inputs]
    for i in range(10):   # stores through as many vectors (every rotation of the inputs)
        vec = ins[i % len(ins):] + ins[:i % len(ins)]
        inst.slave.setReal(vec, [float(i)] * len(vec))
        assert inst.slave.getReal(vec) == [float(i)] * len(vec)
    inst.slave.setReal(ins, list(inputs.values()))
    steps(inst, 1, t)
    inst.slave.freeInstance()


def test_unknown_and_output_references_are_refused_while_stepping(case):
    name, path, inputs, _ = case
    inst = start(path, "vr", inputs=inputs)
    t = steps(inst, 1, 0.0)
    n = max(v.valueReference for v in inst.vars.values())
    out = next(v for v in reals(inst) if v.causality == "output")
    for _ in range(2):   # the second time from the bridge's cache
        assert status_of(lambda: inst.slave.getReal([n + 1000])) == 3
        assert status_of(lambda: inst.slave.setReal([out.valueReference], [1.0])) == 3
    assert "value reference" in inst.last_message()
    steps(inst, 1, t)
    inst.slave.freeInstance()
