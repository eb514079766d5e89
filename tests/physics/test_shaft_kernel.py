"""The compiled step of the differential owning its half-shafts (fmu_src/native/kernels/shaft_kernel.c
through spurdiff.differential.shaft_kernel) against its Python reference: the differential's whole
state (the shafts' and the rigid inner model's, with the Jacobian cache) after every step of the
vehicle scenes, directly and through FMI, with solver.kernel = python (the Python reference all
through) and compiled, bit for bit (with the end-of-step tyre-torque deviations q_end_L/R the FMI 3.0
output derivatives read); a model driven on its own through stick-slip, both carrier drives and
halved sub-steps, with the pin friction's static / dynamic split (mu_pinDynamic below mu_pin, the
bronze set) and the planets' tangential pin loads (the carrier accelerating); the state round
trip; the fallback to Python; the switch."""
from __future__ import annotations

import dataclasses
import logging
import math

import numpy as np
import pytest

import harness.run.direct as hd
from harness.build.fmu import BuildError, kernel_library
from harness.run.direct import run_direct
from harness.run.runner import fmu_files_for, prepare_scene
from spurdiff.differential import shaft_kernel
from spurdiff.differential.bushing import bushing
from spurdiff.differential.derivatives import output_rates
from spurdiff.differential.params import DifferentialParams
from spurdiff.differential.rigid import RigidDifferential
from spurdiff.differential.shafts import ShaftedDifferential, ShaftsParams, WheelSurrogate
from spurdiff.differential.speed_law import breakaway_at_speed
from spurdiff.errors import ParameterError

VEHICLE_SCENES = ["vehicle-cornering", "tip-in-tip-out", "split-mu-launch", "wheel-lift", "standstill-launch"]


@pytest.fixture(scope="module")
def library():
    try:
        kernel_library()          # every kernel for the direct runs, the shaft kernel with them
    except BuildError as e:      # no compiler here: nothing to compare
        pytest.skip(f"the kernels cannot be compiled here: {e}")
    lib, where = shaft_kernel.load()
    assert lib is not None, where
    return where


def _flat(d: dict, pre: str = "") -> dict:
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flat(v, f"{pre}{k}."))
        else:
            out[pre + k] = v
    return out


def _differ(a: dict, b: dict) -> list[str]:
    """The keys whose values differ bit for bit (repr: NaN equal to NaN, 0.0 not -0.0, 1 not 1.0)."""
    return sorted(set(a) ^ set(b)) + [k for k in a if k in b and repr(a[k]) != repr(b[k])]


def _state(m: ShaftedDifferential) -> dict:
    """The model's whole state, flat, with the end-of-step outputs that are not part of it: the
    tyre-torque deviations, the locking capacity, the outputs' time derivatives (FMI 3.0)."""
    return {**_flat(m.get_state()), "q_end_L": m.q_end_L, "q_end_R": m.q_end_R,
            "locking_capacity": m.locking_capacity, **{"rate." + k: v for k, v in output_rates(m).items()}}


def _states_of_scene(name: str, kernel: str, sets: tuple = (), native: bool = False) -> tuple[list[dict], list[str]]:
    """The differential's whole state after every step of a direct run, and its implementation notes;
    ``native``: the differential's native step (spurdiff.native_step) takes the steps, its state stored
    into the model after each (else every step runs through the model's do_step)."""
    states, notes = [], []
    orig = hd.DirectInstance.step

    def step(self, t, h):
        orig(self, t, h)
        if self.name == "diff":
            m = self.model
            if native:
                assert self.native is not None and self._loaded
                self.native.store(m)
            if not notes:
                notes[:] = [m.inner.kernel_note, m.shaft_kernel_note]
            states.append(_state(m))

    hd.DirectInstance.step = step
    try:
        r = run_direct(prepare_scene(name, sets=[f"diff.solver.kernel={kernel}",
                                                 f"diff.solver.nativeStep={'true' if native else 'false'}", *sets]))
    finally:
        hd.DirectInstance.step = orig
    assert r.failure is None, r.failure
    return states, notes


# the scenes as they are, and two with the pin friction's static / dynamic split (mu_pinDynamic < mu_pin):
# tip-in-tip-out slips throughout (the sliding lever), standstill-launch stays stuck while the carrier
# speeds up (the static lever, the tangential pin loads)
SCENE_CASES = [(n, ()) for n in VEHICLE_SCENES] + [("tip-in-tip-out", ("diff.mu_pinDynamic=0.13",)),
                                                   ("standstill-launch", ("diff.mu_pinDynamic=0.13",))]


@pytest.mark.parametrize("name, sets", SCENE_CASES, ids=[n + "".join(s) for n, s in SCENE_CASES])
def test_scene_states_identical(library, name, sets, monkeypatch):
    """Every step of the scene, the differential's state with the compiled step equals the Python
    reference's, and the compiled step took every step (no fallback)."""
    taken = []
    step = shaft_kernel.Kernel.step
    monkeypatch.setattr(shaft_kernel.Kernel, "step", lambda self, *a: taken.append(step(self, *a)) or taken[-1])
    ref, ref_notes = _states_of_scene(name, "python", sets)
    assert not taken
    cmp_, cmp_notes = _states_of_scene(name, "compiled", sets)
    assert ref_notes == ["python (kernel = python)", "python (kernel = python)"]
    assert cmp_notes == ["compiled", "compiled"]
    assert len(ref) == len(cmp_) > 100 and len(taken) == len(cmp_) and all(taken)
    bad = [(i, _differ(a, b)) for i, (a, b) in enumerate(zip(ref, cmp_)) if _differ(a, b)]
    assert not bad, bad[:3]
    assert any(k.startswith("shafts.jac.") for k in ref[-1])      # the Jacobian cache is part of the state


def test_the_scenes_visit_the_stuck_path_and_switch_modes(library):
    """What the comparisons above cover: stuck steps, mode switches inside steps, Jacobians."""
    ref, _ = _states_of_scene("wheel-lift", "compiled")
    assert any(s["inner.slip_dir"] == 0.0 for s in ref) and any(s["inner.slip_dir"] != 0.0 for s in ref)
    assert ref[-1]["inner.n_mode_switches"] >= 2 and ref[-1]["shafts.n_jacobians"] > 0


# ---------------------------------------------------------------- a model on its own
def _model(kernel: str, drive: str = "torque", h_max: float = 0.005, apart: float = 0.0,
           **diff) -> ShaftedDifferential:
    """A shafted rigid differential at 20 rad/s, its wheel sides ``apart`` rad/s either side (slipping)."""
    p = DifferentialParams(carrierDrive=drive, **diff)
    inner = RigidDifferential(p)
    inner.kernel = kernel
    inner.w_start_carrier = 20.0
    inner.w_start_left = 20.0 + apart
    inner.w_ref = 20.0
    m = ShaftedDifferential(inner, ShaftsParams(h_max=h_max))
    m.wheelL_w, m.wheelR_w = 20.0 + apart, 20.0 - apart
    m.initialize(0.0)
    return m


def _drive(m: ShaftedDifferential, n: int, h: float, every=None, apart: float | None = None) -> list[dict]:
    """n steps with a drive torque and wheel sides that slip apart and come together (stick-slip);
    ``apart`` given: the wheel sides start that far apart and come together at 0.4 s (one re-stick)."""
    out = []
    pL = pR = 0.0
    for i in range(n):
        t = i * h
        if apart is None:
            wL = 20.0 + 3.0 * math.sin(2.0 * t) + (2.0 if (i // 40) % 2 else 0.0)
            wR = 20.0 - 3.0 * math.sin(2.0 * t)
        else:
            wL = 20.0 + apart * max(0.0, 1.0 - t / 0.4)
            wR = 40.0 - wL
        m.wheelL_phi, m.wheelL_w, m.wheelR_phi, m.wheelR_w = pL, wL, pR, wR
        m.tau_c = 400.0 * math.sin(1.3 * t) + (150.0 if i % 97 < 50 else -80.0)
        m.w_ref = 20.0 + 2.0 * math.sin(0.9 * t)
        m.wheelL_model = WheelSurrogate(a_free=5.0 * math.sin(t), inv_J=0.8, dadw=-2.0, q_rate=30.0 * math.cos(t),
                                        c_t=400.0, r_t=20.0)
        m.wheelR_model = WheelSurrogate(a_free=-3.0, inv_J=0.8, dadw=-1.0, q_rate=0.0, c_t=300.0, r_t=10.0)
        m.do_step(t, h)
        pL += wL * h
        pR += wR * h
        out.append(_state(m))
        if every is not None:
            every(i, m)
    return out


_BRONZE = bushing("bronze")
PIN_SETS = {
    "paper": {},
    "split": {"mu_pin": 0.26, "mu_pinDynamic": 0.13},
    "bronze": {"mu_pin": _BRONZE.mu_effective, "mu_pinDynamic": _BRONZE.mu_effective_dynamic,
               "r_collar": _BRONZE.journalRadius},
}
STEPS = (("torque", 0.005, 0.005), ("speed", 0.005, 0.005), ("torque", 0.004, 0.001), ("speed", 0.0023, 0.001))


def _covers_speed_loads_and_q(a: list[dict], drive: str, h: float, h_max: float) -> None:
    """What a comparison covers: the carrier accelerating (the tangential pin loads, in every mode
    visited), the wheel sides' tyre-torque deviations. The state after a step holds the carrier
    acceleration of its last inner step: with the speed drive and sub-steps that is 0 (the carrier
    reaches its target in the first sub-step, the only one with the tangential loads)."""
    if drive == "torque" or h == h_max:
        for sd in {x["inner.slip_dir"] for x in a}:
            assert any(x["inner.slip_dir"] == sd and x["inner._g_ac"] != 0.0 and any(x["inner._gt"]) for x in a)
        assert len({x["inner._g_ac"] for x in a}) > 100
    assert any(x["q_end_L"] != 0.0 for x in a) and any(x["q_end_R"] != 0.0 for x in a)


@pytest.mark.parametrize("drive, h, h_max", STEPS)
def test_model_state_after_every_step(library, drive, h, h_max):
    ref, cmp_ = _model("python", drive, h_max), _model("compiled", drive, h_max)
    assert ref._sk is None and cmp_._sk is not None and cmp_.shaft_kernel_note == "compiled"
    a, b = _drive(ref, 600, h), _drive(cmp_, 600, h)
    bad = [(i, _differ(x, y)) for i, (x, y) in enumerate(zip(a, b)) if _differ(x, y)]
    assert not bad, bad[:3]
    assert {x["inner.slip_dir"] for x in a} >= {0.0, 1.0} or {x["inner.slip_dir"] for x in a} >= {0.0, -1.0}
    assert a[-1]["inner.n_mode_switches"] >= 1                       # it sticks and slips
    assert a[-1]["shafts.n_substeps"] > a[-1]["shafts.n_steps"] or h_max == h
    _covers_speed_loads_and_q(a, drive, h, h_max)


SPLIT_CASES = [(*STEPS[0], "split", 3.0), (*STEPS[1], "split", -3.0), (*STEPS[2], "split", -3.0),
               (*STEPS[3], "split", 3.0), (*STEPS[0], "bronze", -3.0), (*STEPS[3], "bronze", 3.0)]


@pytest.mark.parametrize("drive, h, h_max, pins, apart", SPLIT_CASES)
def test_model_with_the_pin_friction_split(library, drive, h, h_max, pins, apart):
    """mu_pinDynamic below mu_pin (0.13 against 0.26; the bronze set): slipping at the sliding lever,
    re-stuck at the static one, held stuck under the drive's changing loads (the static lever and the
    tangential pin loads in the stuck test), after every step the same state."""
    diff = PIN_SETS[pins]
    ref, cmp_ = _model("python", drive, h_max, apart, **diff), _model("compiled", drive, h_max, apart, **diff)
    assert cmp_._sk is not None and ref.inner.c_slide < ref.inner.pf.c           # the split is on: two levers
    a, b = _drive(ref, 400, h, apart=apart), _drive(cmp_, 400, h, apart=apart)
    bad = [(i, _differ(x, y)) for i, (x, y) in enumerate(zip(a, b)) if _differ(x, y)]
    assert not bad, bad[:3]
    modes = [x["inner.slip_dir"] for x in a]
    assert modes[0] == math.copysign(1.0, apart) and modes.count(0.0) > 200 and a[-1]["inner.n_mode_switches"] >= 1
    # the capacity reported: the sliding lever's while slipping, the static lever's while stuck
    slip = next(x for x in a if x["inner.slip_dir"] != 0.0)
    assert slip["locking_capacity"] == slip["inner.cap"] and slip["inner._slip_val"][5] == slip["inner.cap"]
    _covers_speed_loads_and_q(a, drive, h, h_max)


@pytest.mark.parametrize("drive, h, h_max", STEPS)
def test_model_with_the_split_breaking_away(library, drive, h, h_max):
    """The stick-slip drive of test_model_state_after_every_step with mu_pinDynamic 0.13, stuck at the
    start: it breaks away from stuck again and again (the break-away sub-step at the static lever,
    rigid.py's c_break; with the sliding lever there the shafts' sub-step had no root and the run
    stopped at the first break-away), and the compiled model follows state for state.

    The start is held by a locking preload: the shafts start untwisted, so the suns carry almost no
    torque in the first step (with the speed drive none from the carrier either) and the capacity
    there is the planets' centrifugal pin loads alone at 20 rad/s, which the planets without their
    bores (issue 41) no longer make larger than the first step's torque difference (the speed drive
    slipped from step 0). The preload is twice the torque difference of that first step with the
    differential locked (preload 1e5 N m), so the start is stuck whatever the speed loads; the
    differences that follow (tens of N m) break away past it at the static lever."""
    locked = _drive(_model("python", drive, h_max, lockingPreload=1e5, **PIN_SETS["split"]), 1, h)[0]
    assert locked["inner.slip_dir"] == 0.0
    d0 = abs(locked["shafts.tau_end_L"] - locked["shafts.tau_end_R"])
    pins = {**PIN_SETS["split"], "lockingPreload": 2.0 * d0}
    if drive == "speed":
        # without it the start holds exactly where the speed loads' break-away torque at 20 rad/s
        # (speed_law, T0 = 0, either sun ahead) exceeds d0: at h = 5 ms it does not
        bare = _model("python", drive, h_max, **PIN_SETS["split"])
        geo, masses = bare.inner.geometry, (bare.inner.mass.m_planet1, bare.inner.mass.m_planet2)
        cap = min(breakaway_at_speed(bare.inner.pf, geo, masses, 20.0, 0.0, s).locking_torque for s in (1.0, -1.0))
        stuck = _drive(bare, 1, h)[0]["inner.slip_dir"] == 0.0
        assert stuck == (cap > d0) and stuck == (h != 0.005), (cap, d0, stuck)
    a = _drive(_model("python", drive, h_max, **pins), 600, h)
    m = _model("compiled", drive, h_max, **pins)
    b = _drive(m, 600, h)
    assert m.inner.c_break == m.inner.pf.c > m.inner.c_slide
    bad = [(i, _differ(x, y)) for i, (x, y) in enumerate(zip(a, b)) if _differ(x, y)]
    assert not bad, bad[:3]
    assert len(a) == len(b) == 600
    modes = [x["inner.slip_dir"] for x in a]
    breakaways = sum(1 for p, q in zip(modes, modes[1:]) if p == 0.0 and q != 0.0)
    assert modes[0] == 0.0 and breakaways >= 1 and a[-1]["inner.n_mode_switches"] >= 1


def test_state_round_trip_and_rollback(library):
    """get_state / set_state around compiled steps, and a Python step in between (the kernel packs the
    state again): the same trajectory as the reference."""
    ref, cmp_ = _model("python"), _model("compiled")
    saved = {}

    def meddle(i, m):
        if i == 100:
            saved["s"] = m.get_state()
        if i == 200:
            m.set_state(saved["s"])          # back to step 100; the driver's inputs go on
        if i == 300:
            m._sk, sk = None, m._sk         # one step of the Python code, then the kernel again
            m.do_step(1.5, 0.005)
            m._sk = sk

    a, b = _drive(ref, 400, 0.005, meddle), _drive(cmp_, 400, 0.005, meddle)
    bad = [(i, _differ(x, y)) for i, (x, y) in enumerate(zip(a, b)) if _differ(x, y)]
    assert not bad, bad[:3]


def test_a_step_the_kernel_refuses_runs_in_python(library, caplog):
    """An error the Python code names (a non-finite drive torque) comes from the Python code, the
    state kept; a Jacobian cache key the kernel has no slot for: the Python code steps."""
    m = _model("compiled")
    _drive(m, 20, 0.005)
    before = _flat(m.get_state())
    m.tau_c = math.nan
    with pytest.raises(ParameterError, match="carrier.tau"):
        m.do_step(0.1, 0.005)
    assert _differ(before, _flat(m.get_state())) == ["inner.tau_c"]      # the input only
    m.tau_c = 10.0
    m.jac = {**m.jac, "m": [0.0, 0.0, 0.0, 0.0]}
    n = m.n_steps
    sk_step = m._sk.step
    taken = []
    m._sk.step = lambda *a: taken.append(sk_step(*a)) or taken[-1]
    m.do_step(0.1, 0.005)
    assert taken == [False] and m.n_steps == n + 1 and "m" in m.jac


def test_switch_and_missing_library(library, monkeypatch, caplog):
    m = _model("python")
    assert m._sk is None and m.shaft_kernel_note == "python (kernel = python)"
    # a rigid kernel of another ABI than the one the transcription was written for: not called
    monkeypatch.setattr(shaft_kernel.rigid_kernel, "ABI", shaft_kernel.RIGID_ABI + 1)
    m = _model("auto")
    assert m._sk is None and m.shaft_kernel_note.startswith("python (the half-shaft kernel is written for")
    with pytest.raises(ParameterError, match="solver.kernel"):
        _model("compiled")
    monkeypatch.setattr(shaft_kernel.rigid_kernel, "ABI", shaft_kernel.RIGID_ABI)
    monkeypatch.setattr(shaft_kernel, "_LIB", None)
    monkeypatch.setattr(shaft_kernel, "_candidates", lambda: [])
    monkeypatch.setattr(shaft_kernel, "_REPORTED", set())
    with caplog.at_level(logging.WARNING, logger="spurdiff.shafts"):
        for _ in range(2):
            m = _model("auto")
            assert m._sk is None and m.shaft_kernel_note == f"python ({shaft_kernel.MISSING})"
    assert sum(shaft_kernel.MISSING in r.getMessage() for r in caplog.records) == 1
    with pytest.raises(ParameterError, match="solver.kernel"):
        _model("compiled")


def test_fmu_interface_names_the_half_shafts_implementation(library):
    from spurdiff.fmi import differential_fmu

    for kernel, want in (("auto", "compiled; half-shafts: compiled"),
                         ("python", "python (kernel = python); half-shafts: python (kernel = python)")):
        values = {v.name: v.start for v in differential_fmu.VARIABLES}
        values.update({"solver.kernel": kernel, "shaftCoupling": "wheel", "carrierDrive": "torque"})
        differential_fmu.build_model(values)
        assert values["solver.kernelInUse"] == want
    values = {v.name: v.start for v in differential_fmu.VARIABLES}
    values["shaftCoupling"] = "torque"
    differential_fmu.build_model(values)
    assert "half-shafts" not in values["solver.kernelInUse"]


# ---------------------------------------------------------------- through FMI
@pytest.mark.parametrize("name", ["vehicle-cornering", "wheel-lift"])
def test_scene_through_fmi_identical(library, name):
    """The scene through FMI (the SpurDifferential FMU carries the shaft kernel): every recorded
    variable identical with the differential's solver.kernel = python and compiled, and the FMU says
    which runs."""
    from harness.run.master import run_scene

    runs = {}
    for kernel in ("python", "compiled"):
        scene = prepare_scene(name, sets=[f"diff.solver.kernel={kernel}"])
        r = run_scene(scene, fmu_files_for(scene))
        assert r.failure is None, r.failure
        runs[kernel] = r
    a, b = runs["python"].data, runs["compiled"].data
    assert a.shape == b.shape and a.shape[0] > 100
    assert np.array_equal(a, b), float(np.nanmax(np.abs(a - b)))


@pytest.mark.parametrize("name, sets", SCENE_CASES, ids=[n + "".join(s) for n, s in SCENE_CASES])
def test_scene_states_identical_with_the_native_step(library, name, sets):
    """The differential's native step (sk_native: the step above, its input checks, the watches and
    the outputs in C) leaves after every step of the scene the state the Python reference has."""
    ref, _ = _states_of_scene(name, "python", sets)
    nat, notes = _states_of_scene(name, "compiled", sets, native=True)
    assert notes == ["compiled", "compiled"] and len(ref) == len(nat) > 100
    bad = [(i, _differ(a, b)) for i, (a, b) in enumerate(zip(ref, nat)) if _differ(a, b)]
    assert not bad, bad[:3]
