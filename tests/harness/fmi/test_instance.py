"""The one FMU instance wrapper (harness/fmi/instance.py) on ChkGood, the compliance kit's small
well-behaved test FMU: statuses as exceptions or as values, messages per instance, typed setting."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "broken_fmus"))
import chk_build  # noqa: E402

from harness.fmi.instance import CallFailed, Instance, RealPort, status_label  # noqa: E402
from harness.schema import SceneError  # noqa: E402


@pytest.fixture(scope="module")
def good() -> Path:
    return chk_build.pythonfmu_fmu("ChkGood", ["--handle-state", "--serialize-state"])


def _initialized(path: Path, name: str) -> Instance:
    inst = Instance(name, path)
    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    inst.slave.exitInitializationMode()
    return inst


def test_a_refused_call_raises_naming_the_call_the_instance_and_the_status(good):
    inst = Instance("early", good)   # instantiated, not initialized: ChkGood discards a step
    with pytest.raises(CallFailed) as e:
        inst.do_step(0.0, 0.01)
    assert e.value.status == 2 and "fmi2DoStep(t=0, h=0.01) [instance early] returned fmi2Discard" in str(e.value)
    assert inst.step_status(0.0, 0.01) == 2                       # the same call, the status as a value
    assert inst.c_function("fmi2DoStep")(inst.component, 0.0, 0.01, 1) == 2
    inst.close()


def test_values_are_set_by_type_and_read_back_in_order(good):
    inst = _initialized(good, "typed")
    inst.set_value("u", 3)                                        # an int for a Real is converted
    inst.do_step(0.0, 0.01)
    x, y = inst.read([inst.var("x"), inst.var("y")], "outputs")
    assert y == pytest.approx(6.0) and x == pytest.approx(0.06)
    with pytest.raises(SceneError, match=r"typed\.u = 'abc': allowed a number"):
        inst.set_value("u", "abc")
    with pytest.raises(SceneError, match="typed: FMU has no variable 'v'"):
        inst.var("v")
    inst.close()


def test_messages_reach_their_own_instance(good):
    a, b = _initialized(good, "a"), _initialized(good, "b")
    assert a.set_status("k", 5.0) > 1                             # a fixed parameter after initialization
    assert any("fixed parameter" in m for m in a.errors()) and "fixed parameter" in a.last_message()
    assert b.errors() == [] and b.last_messages() == "no message logged"
    a.close()
    b.close()


def test_a_real_port_reads_and_writes_through_the_c_functions_and_reports_a_refusal(good):
    inst = _initialized(good, "port")
    reasons = []

    def fail(reason, t):
        reasons.append((reason, t))
        raise RuntimeError(reason)

    out = RealPort(inst, [inst.var("x").valueReference, inst.var("y").valueReference], False, fail)
    assert out.get() == [0.0, 2.0]
    RealPort(inst, [inst.var("u").valueReference], True, fail).set([0.5], 0.0)
    inst.do_step(0.0, 0.1)
    assert out.get() == pytest.approx([0.1, 1.0])
    bad = RealPort(inst, [inst.var("k").valueReference], True, fail)   # refused: k is fixed now
    with pytest.raises(RuntimeError):
        bad.set([7.0], 0.1)
    assert reasons and reasons[0][0].startswith("fmi2SetReal returned status") and reasons[0][1] == 0.1
    inst.close()


def test_status_labels():
    assert [status_label(s) for s in (0, 2, 4, None, 9)] == ["fmi2OK", "fmi2Discard", "fmi2Fatal", "no status",
                                                            "illegal status 9"]
