"""The one FMU instance wrapper (harness/fmi/instance.py) on the differential FMU: statuses as
exceptions or as values, messages per instance, typed setting, the C-array ports of the master.

(Our own FMU, not the compliance kit's pythonfmu ChkGood: a pythonfmu FMU loaded into the test
process beside ours made a later fmi2Reset of ours crash; the kit runs ChkGood in its own processes.)"""
from __future__ import annotations

import pytest

from harness.fmi.instance import CallFailed, Instance, RealPort, status_label
from harness.scene.schema import SceneError

INPUTS = {"carrier.w_ref": 1.389, "left.tau": -1050.0, "right.tau": -1040.0}
H = 1e-3


def _initialized(path, name: str) -> Instance:
    inst = Instance(name, path)
    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    for k, v in INPUTS.items():
        inst.set_value(k, v)
    inst.slave.exitInitializationMode()
    return inst


def test_a_refused_call_raises_naming_the_call_the_instance_and_the_status(differential_fmu):
    inst = Instance("early", differential_fmu)   # instantiated, not initialized: a step is an error
    with pytest.raises(CallFailed) as e:
        inst.do_step(0.0, H)
    assert e.value.status == 3 and "fmi2DoStep(t=0, h=0.001) [instance early] returned fmi2Error" in str(e.value)
    assert inst.step_status(0.0, H) == 3                       # the same call, the status as a value
    assert inst.c_function("fmi2DoStep")(inst.component, 0.0, H, 1) == 3
    inst.close()


def test_values_are_set_by_type_and_read_back_in_order(differential_fmu):
    inst = _initialized(differential_fmu, "typed")
    inst.do_step(0.0, H)
    tau, w = inst.read([inst.var("left.tau"), inst.var("carrier.w_ref")], "inputs")
    assert (tau, w) == (-1050.0, 1.389)
    with pytest.raises(SceneError, match=r"typed\.left\.tau = 'abc': allowed a number"):
        inst.set_value("left.tau", "abc")
    with pytest.raises(SceneError, match="typed: FMU has no variable 'left.tork'"):
        inst.var("left.tork")
    inst.close()


def test_messages_reach_their_own_instance(differential_fmu):
    a, b = _initialized(differential_fmu, "a"), _initialized(differential_fmu, "b")
    assert a.set_status("mu_pin", 0.5) == 3                      # a fixed parameter after initialization
    assert any("fixed parameter" in m for m in a.errors()) and "fixed parameter" in a.last_message()
    # b logged only its own build note (which implementation runs), none of a's refusal
    assert b.errors() == [] and "fixed parameter" not in b.last_messages()
    a.close()
    b.close()


def test_a_real_port_reads_and_writes_through_the_c_functions_and_reports_a_refusal(differential_fmu):
    inst = _initialized(differential_fmu, "port")
    reasons = []

    def fail(reason, t):
        reasons.append((reason, t))
        raise RuntimeError(reason)

    tau = inst.var("left.tau").valueReference
    RealPort(inst, [tau], True, fail).set([-900.0], 0.0)
    assert RealPort(inst, [tau], False, fail).get() == [-900.0]
    out = [v.valueReference for v in inst.vars.values() if v.causality == "output" and v.type == "Real"][:1]
    with pytest.raises(RuntimeError):                           # an output is not settable: fmi2Error
        RealPort(inst, out, True, fail).set([1.0], 0.002)
    assert reasons[0][0].startswith("fmi2SetReal returned status 3") and reasons[0][1] == 0.002
    inst.close()


def test_the_fast_function_is_the_fmus_c_function_with_arguments_converted_by_the_caller(differential_fmu):
    from ctypes import c_double

    inst = _initialized(differential_fmu, "fast")
    ref = _initialized(differential_fmu, "fast-ref")
    do = inst.fast_function("fmi2DoStep")
    t, h = c_double(0.0), c_double(H)
    assert do(inst.c_component, t, h, 1) == 0                    # a step, as fmpy's call makes it
    ref.do_step(0.0, H)
    assert do(None, t, h, 1) == 3                                # refused by the loader: a status, no raise
    t.value = 5 * H
    assert do(inst.c_component, t, h, 1) == 2                   # not the FMU's time: fmi2Discard
    w = inst.var("left.w").valueReference
    assert inst.slave.getReal([w]) == ref.slave.getReal([w])
    inst.close()
    ref.close()


def test_status_labels():
    assert [status_label(s) for s in (0, 2, 4, None, 9)] == ["fmi2OK", "fmi2Discard", "fmi2Fatal", "no status",
                                                            "illegal status 9"]
