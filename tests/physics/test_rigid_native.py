"""The rigid differential's native step without half-shafts (shaftCoupling = torque, the FMU's default
interface; sk_rigid_native in fmu_src/native/kernels/shaft_kernel.c through
spurdiff.differential.rigid_native): the whole communication step in C on one array, built as the FMU
builds the model (spurdiff.fmi.differential_fmu.build_model, its two watches), against the Python
reference (solver.kernel = python: the pin-load solve in Python too): every output the FMU reads
after every step and the model's whole state, bit for bit, through stick-slip, both carrier drives,
the pin friction's static / dynamic split, changing step sizes; a step the C code does not take (a
refused input, a watch that logs) changes nothing and the Python step says why; the switch."""
from __future__ import annotations

import math

import pytest

from spurdiff.differential import rigid_native
from spurdiff.differential.bushing import bushing
from spurdiff.errors import ParameterError
from spurdiff.fmi import differential_fmu
from tests.physics.test_shaft_kernel import _differ, _flat, library  # noqa: F401

_BRONZE = bushing("bronze")
PINS = {"paper": {}, "split": {"mu_pin": 0.26, "mu_pinDynamic": 0.13},
        "bronze": {"mu_pin": _BRONZE.mu_effective, "mu_pinDynamic": _BRONZE.mu_effective_dynamic,
                   "r_collar": _BRONZE.journalRadius},
        "preload": {"lockingPreload": 40.0},
        # the linear capacity K |T_0| + T_pre: the paper's law, with its dynamic coefficient and a preload; no pin friction
        "paper-law": {"lockingLaw": "paper"},
        "paper-law-split": {"lockingLaw": "paper", "mu_pin": 0.26, "mu_pinDynamic": 0.13, "lockingPreload": 30.0},
        "no-pin-friction": {"pinFriction": False}}


def _build(kernel: str, drive: str, native: bool = True, **sets):
    # the paper's gear set from rest (the FMU's default experiment since issue 46 runs the designed set
    # with a start slip): the variants' loads were chosen to stick and slip on it
    from spurdiff.gears.design_sets import fmu_parameters
    values = {v.name: v.start for v in differential_fmu.VARIABLES}
    values.update(fmu_parameters("paper"))
    values.update({"differential.w_start": 0.0, "left.tau": -1050.0, "right.tau": -1050.0, "solver.kernel": kernel, "shaftCoupling": "torque", "carrierDrive": drive,
                   "solver.nativeStep": native, "carrier.w_start": 20.0, **sets})
    m = differential_fmu.build_model(values)
    return m, values


def _inputs(i: int, t: float) -> tuple[float, float, float, float]:
    """w_ref, tau_c, tau_L, tau_R: a drive and flange loads that make it stick, break away, slip
    both ways and re-stick."""
    tau_c = 400.0 * math.sin(1.3 * t) + (150.0 if i % 97 < 50 else -80.0)
    tau_L = -0.5 * tau_c + 60.0 * math.sin(3.1 * t) + (0.0, 250.0, -250.0)[(i // 60) % 3]
    tau_R = -0.5 * tau_c - 60.0 * math.sin(3.1 * t)
    return 20.0 + 2.0 * math.sin(0.9 * t), tau_c, tau_L, tau_R


def _outputs(plan, m) -> dict:
    from spurdiff.attrpath import resolve
    return {k: float(resolve(m, k)) for k in plan.outputs} | {k: float(getattr(m, k)) for k in plan.integers}


def _native_outputs(plan) -> dict:
    n = len(plan.inputs)
    assert n == 20 and plan.v[61:81] == plan.v[0:20]
    return dict(zip(plan.outputs, plan.v[n:n + len(plan.outputs)])) | {k: plan.v[i] for k, i in plan.integers.items()}


CASES = [(d, pins, hs) for d in ("torque", "speed") for pins in PINS for hs in ("fixed", "varying")]


@pytest.mark.parametrize("drive, pins, hs", CASES)
def test_native_step_is_the_python_reference(library, drive, pins, hs):
    ref, _ = _build("python", drive, **PINS[pins])
    nat, _ = _build("auto", drive, **PINS[pins])
    assert ref.native_step() is None and ref._rk is None
    plan = nat.native_step()
    assert isinstance(plan, rigid_native.RigidNative)
    assert (plan.rk is not None) == (pins not in ("paper-law", "paper-law-split", "no-pin-friction"))
    assert plan.load(nat)
    t, taken, modes = 0.0, 0, set()
    for i in range(700):
        h = 0.005 if hs == "fixed" else (0.005 if i % 7 else 0.0131) * (1.0 + 0.1 * (i % 3))
        u = _inputs(i, t)
        ref.w_ref, ref.tau_c, ref.tau_L, ref.tau_R = u
        ref.do_step(t, h)
        plan.v[0:4] = u
        plan.v[4:20] = [1e300 * (-1) ** k for k in range(16)]   # the wheel-side inputs: carried, not used
        ok = plan.step(t, h)
        if not ok:                       # a watch would log: the Python step takes it
            plan.store(nat)
            nat.w_ref, nat.tau_c, nat.tau_L, nat.tau_R = u
            nat.do_step(t, h)
            assert plan.load(nat)
        else:
            taken += 1
        t += h
        got, want = _native_outputs(plan), _outputs(plan, ref)
        assert not _differ(want, got), (i, _differ(want, got))   # every output the FMU reads, bit for bit
        modes.add(ref.slip_dir)
        if i % 50 == 0 or i > 690:
            plan.store(nat)
            sa, sb = _flat(ref.get_state()), _flat(nat.get_state())
            assert not _differ(sa, sb), (i, _differ(sa, sb))
            assert plan.load(nat)
    assert taken > 650
    if pins == "no-pin-friction":     # nothing holds it: the differential speed crosses zero
        assert ref.n_mode_switches >= 1 and ref.energy_loss == 0.0
    else:
        assert modes >= {0.0, 1.0, -1.0} and ref.n_mode_switches >= 4 and ref.energy_loss > 0.0


def test_default_interface_has_the_native_step(library):
    """The FMU's defaults (rigid, torque, pin-load law) step natively, and so do the paper's law and the
    rigid level without pin friction; solver.nativeStep = false and solver.kernel = python do not (their
    steps stay in Python)."""
    m, values = _build("auto", "torque")
    assert values["shaftCoupling"] == "torque" and isinstance(m.native_step(), rigid_native.RigidNative)
    assert m.native_step() is m.native_step()
    assert _build("auto", "torque", native=False)[0].native_step() is None
    assert _build("python", "torque")[0].native_step() is None
    assert isinstance(_build("auto", "torque", lockingLaw="paper")[0].native_step(), rigid_native.RigidNative)
    assert isinstance(_build("auto", "speed", pinFriction=False)[0].native_step(), rigid_native.RigidNative)
    assert _build("python", "torque", lockingLaw="paper")[0].native_step() is None


def test_a_step_the_c_code_refuses_changes_nothing(library):
    m, _ = _build("auto", "torque")
    plan = m.native_step()
    plan.load(m)
    for i in range(20):
        plan.v[0:4] = _inputs(i, 0.005 * i)
        assert plan.step(0.005 * i, 0.005)
    before = list(plan.v), list(plan.rs)
    for bad in ((math.nan, 1), (math.inf, 2)):
        v = list(before[0][0:4])
        v[bad[1]] = bad[0]
        plan.v[0:4] = v
        assert plan.fn(plan.const, plan.v, 0.1, 0.005) == 4
        assert list(plan.v)[4:] == before[0][4:] and list(plan.rs) == before[1]
    plan.v[0:4] = before[0][0:4]
    assert plan.fn(plan.const, plan.v, 0.1, -0.005) == 4 and plan.fn(plan.const, plan.v, 0.1, math.inf) == 4
    plan.store(m)
    m.tau_c = math.nan
    with pytest.raises(ParameterError, match="carrier.tau"):
        m.do_step(0.1, 0.005)
