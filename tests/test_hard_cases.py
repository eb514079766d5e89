"""Hard cases that try to break the numerics (issue 5).

Each case asserts finite results, bounded energy (no energy gain in a passive subsystem) and the
physical expectation, at the default and at the coarsest supported communication step (1e-2 s).
"""
import math

import numpy as np
import pytest

from spurdiff.errors import ParameterError
from spurdiff.params import DifferentialParams
from spurdiff.rigid import RigidDifferential

STEPS = [1e-3, 1e-2]  # default and coarsest supported communication step


def rigid(drive="speed", J_carrier=0.0, **inputs):
    m = RigidDifferential(DifferentialParams(carrierDrive=drive, J_carrier=J_carrier))
    m.w_ref = inputs.get("w_ref", 1.389)
    m.tau_c = inputs.get("tau_c", 0.0)
    m.tau_L = inputs.get("tau_L", 0.0)
    m.tau_R = inputs.get("tau_R", 0.0)
    m.w_start_carrier = inputs.get("w0", 0.0)
    m.initialize()
    return m


def finite(*xs):
    return all(math.isfinite(x) for x in xs)


@pytest.mark.parametrize("h", STEPS)
def test_stick_slip_at_zero_relative_speed_holds_breaks_away_at_capacity_without_chattering(h):
    """Load difference ramped slowly through the capacity: stuck exactly until K |T0|, then one
    break-away; ramped back down: one re-stick. Count the mode switches."""
    m = rigid(tau_L=-1050.0, tau_R=-1050.0)
    cap = m.K * 2100.0
    n = int(round(2.0 / h))
    broke_at = None
    for k in range(n):
        t = k * h
        d = 1.5 * cap * (t / 1.0) if t < 1.0 else 1.5 * cap * (2.0 - t) / 1.0 - 0.6 * cap  # up, then below
        m.tau_L, m.tau_R = -1050.0 - d / 2, -1050.0 + d / 2
        m.do_step(t, h)
        assert finite(m.wc, m.wd, m.locking_torque)
        if broke_at is None:
            if m.wd != 0.0:
                broke_at = d
            else:
                assert m.w_L == m.w_R == 1.389  # truly stuck: not a slow creep
                assert abs(m.locking_torque) <= m.locking_capacity * (1 + 1e-12)
    assert broke_at is not None
    # the break-away happens at the capacity (within one step of the ramp)
    assert broke_at == pytest.approx(cap, abs=1.5 * cap * h + 1e-9)
    assert m.wd == 0.0  # the reversed difference stopped the relative motion and it stuck again
    assert m.n_mode_switches == 2


@pytest.mark.parametrize("h", STEPS)
def test_torque_step_of_ten_times_rated(h):
    """Carrier torque-driven, 10 x the paper's 2100 N m applied as a step against the loads.

    The carrier carries a reflected driveline inertia (13 kg m^2, as in the vehicle scenes);
    without it the carrier would accelerate at 5e5 rad/s^2 and the unequal sun inertias alone
    would break the differential loose (a real effect, tested in the rigid-model tests)."""
    m = rigid(drive="torque", J_carrier=13.0, tau_c=0.0, tau_L=-1050.0, tau_R=-950.0, w0=1.389)
    ke0 = m.kinetic_energy
    wc_before = None
    for k in range(int(0.2 / h)):
        m.tau_c = 21000.0 if k * h >= 0.05 else 2000.0
        m.do_step(k * h, h)
        assert abs(m.locking_torque) <= m.locking_capacity * (1 + 1e-12)
        if k * h < 0.05:
            wc_before = m.wc
    assert finite(m.wc, m.wd, m.tau_mesh_L, m.tau_mesh_R, m.energy_loss)
    # the step accelerates the carrier (and its driveline) at (21000 - 2000) / J
    assert (m.wc - wc_before) == pytest.approx(19000.0 / m.Mcc * 0.15, rel=0.01)
    assert m.w_L + m.w_R == pytest.approx(2 * m.wc, rel=1e-12)
    # passive: all work in is kinetic energy or loss, nothing is created
    assert m.work_in - (m.kinetic_energy - ke0) - m.energy_loss == pytest.approx(0.0, abs=1e-9 * abs(m.work_in))
    # the torque through the gears is what the suns pass on (the loads): the capacity stays
    # K x 2000 N m < the 100 N m imbalance, so the differential keeps slipping, at capacity
    assert not m.stuck and abs(m.locking_torque) == pytest.approx(m.locking_capacity, rel=1e-12)


@pytest.mark.parametrize("bad,name", [
    ({"tau_L": float("nan")}, "left.tau"), ({"tau_R": float("inf")}, "right.tau"),
    ({"w_ref": float("-inf")}, "carrier.w_ref"),
])
def test_non_finite_inputs_are_refused_with_their_name(bad, name):
    m = rigid(tau_L=-1050.0, tau_R=-1050.0)
    for k, v in bad.items():
        setattr(m, k, v)
    with pytest.raises(ParameterError, match=name.replace(".", r"\.")):
        m.do_step(0.0, 1e-3)


@pytest.mark.parametrize("h", [0.0, -1e-3, float("nan"), float("inf")])
def test_bad_communication_steps_are_refused(h):
    with pytest.raises(ParameterError, match="communicationStepSize"):
        rigid().do_step(0.0, h)


def test_bad_step_through_fmi_is_discarded_not_fatal(differential_fmu):
    from fmpy.fmi1 import FMICallException

    from harness.master import Instance

    inst = Instance("h0", differential_fmu)
    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    inst.slave.exitInitializationMode()
    for h in (0.0, -1e-3):
        with pytest.raises(FMICallException) as e:
            inst.slave.doStep(0.0, h)
        assert "status 2" in str(e.value)  # fmi2Discard, not fmi2Fatal (4)
    inst.slave.doStep(0.0, 1e-3)  # still usable
    assert np.isfinite(inst.slave.getReal([inst.var("carrier.tauDrive").valueReference])[0])
    inst.slave.terminate()
    inst.slave.freeInstance()
