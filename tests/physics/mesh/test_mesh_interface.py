"""Mesh dynamics, the model's interface: variable and state counts, get/set state continuing exactly, a
refused step keeping the state, bad parameters and inputs named, the pin-friction power balance while
slipping (split from test_mesh_dynamics.py)."""
import json

import numpy as np
import pytest

from spurdiff.errors import ParameterError
from spurdiff.differential.mesh import MeshDifferential, MeshParams
from spurdiff.differential.params import DifferentialParams
from spurdiff.differential.rigid import StepError
from tests.physics.mesh.mesh_cases import W0, energy_balance, model, outputs, run


# ------------------------------------------------------------------ interface, state, errors
def test_interface_and_state_counts():
    m = model("contact", drive="torque", tau_c=2100.0, backlash=True, flankFriction=True)
    assert m.n_states == 10
    assert m.active_effects == ("contact", "backlash", "pinFriction", "flankFriction")
    assert model("compliant").n_states == 8
    e0 = m.kinetic_energy + m.potential_energy
    run(m, 0.05)
    assert m.tau_drive == 2100.0 and m.wc == pytest.approx(W0, rel=1e-9)  # balanced torques
    assert abs(energy_balance(m, e0)) < 1e-9 + 1e-6 * abs(m.work_in)
    assert m.n_internal_steps >= 50 and m.potential_energy > 0.5


def test_get_set_state_reproduces_the_continuation_exactly():
    # a continuation with impacts, stick/slip switches and flank friction
    m = model("contact", backlash=True, flankFriction=True, preload=False)

    def reverse(mm):
        mm.tau_L, mm.tau_R = 1000.0, 1040.0

    run(m, 0.015, 1e-3)
    snap = json.loads(json.dumps(m.get_state()))  # JSON round trip
    counts = (m.n_contact_transitions, m.n_mode_switches)
    first = run(m, 0.04, 1e-3, t0=0.015, events={5: reverse})
    assert m.n_contact_transitions > counts[0] and m.n_mode_switches > counts[1]
    end = m.get_state()
    m.set_state(snap)
    second = run(m, 0.04, 1e-3, t0=0.015, events={5: reverse})
    assert np.array_equal(first, second)
    assert m.get_state() == end
    # also on a fresh instance
    m2 = MeshDifferential(m.params, m.mesh)
    m2.initialize()
    m2.set_state(snap)
    assert np.array_equal(run(m2, 0.04, 1e-3, t0=0.015, events={5: reverse}), first)
    assert m2.get_state() == end


def test_step_error_leaves_the_state_unchanged():
    m = model("contact", backlash=True, maxInternalSteps=20)
    run(m, 0.01)
    m.tau_L = m.tau_R = 1050.0  # torque reversal: impacts need many internal steps
    before = json.dumps(m.get_state())
    out_before = outputs(m)
    with pytest.raises(StepError):
        m.do_step(0.01, 1e-3)
    assert json.dumps(m.get_state()) == before
    assert np.array_equal(outputs(m), out_before)


@pytest.mark.parametrize("field,value", [
    ("level", "rigid"), ("tolerance", 0.0), ("tolerance", float("nan")), ("backlashA1", -1e-4),
    ("stiffness12", -1.0), ("dampingRatio", 20.0), ("contactExponent", 0.5), ("contactDepth", 0.0),
    ("contactStiffnessB2", 0.0), ("muStatic", 1.5), ("muDynamic", 0.06), ("vStiction", 0.0),
    ("vTransition", 1e-5), ("maxInternalSteps", 2), ("pinFriction", "yes"), ("youngsModulus", 1.0),
])
def test_bad_parameters_name_the_field(field, value):
    m = MeshDifferential(DifferentialParams(), MeshParams(**{field: value}))
    with pytest.raises(ParameterError) as e:
        m.initialize()
    assert e.value.name == field


def test_bad_inputs_and_steps():
    m = model("contact")
    m.tau_L = float("nan")
    with pytest.raises(ParameterError) as e:
        m.do_step(0.0, 1e-3)
    assert e.value.name == "tau_L"
    m.tau_L = -1050.0
    with pytest.raises(ParameterError):
        m.do_step(0.0, 0.0)
    with pytest.raises(ParameterError):
        MeshDifferential(DifferentialParams(mu_pin=-1.0), MeshParams()).initialize()
    with pytest.raises(StepError):
        MeshDifferential().do_step(0.0, 1e-3)


@pytest.mark.parametrize("sign", [1.0, -1.0], ids=["drive", "coast"])
def test_contact_level_pin_friction_power_balance_while_slipping(sign):
    # pin-load law, difference 2 % above K T0: the contact level slips, the friction works at
    # n sum_i mu r_d |F_pin,i| |w_i| from its own mesh forces, and the sun torques carry it:
    # (T_B - T_A) dw = friction power (planet and sun inertia aside)
    ref = model("contact")
    K = ref.K if sign > 0 else ref.K_coast
    D = 1.02 * K * 2100.0
    m = model("contact", (-1050.0 * sign - D / 2, -1050.0 * sign + D / 2))
    run(m, 0.02)
    assert 0 not in m.planet_modes and m.wd < 0.0
    f = m.mesh_forces
    Fp = (m._pin_force(0, f.F_A1, f.F_12)[0], m._pin_force(1, f.F_B2, f.F_12)[0])
    w = (m.y[6], m.y[7])
    P = 3 * sum(0.26 * 0.012 * F * abs(wi) for F, wi in zip(Fp, w))
    assert abs(m.locking_torque * m.wd) == pytest.approx(P, rel=1e-3)
    # the 2 % excess accelerates suns and planets: their inertia torques are in T_B - T_A
    assert (m.tau_mesh_R - m.tau_mesh_L) * m.wd == pytest.approx(P, rel=0.01)
