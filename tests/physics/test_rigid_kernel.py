"""The compiled kernel of the rigid level (fmu_src/native/kernels/rigid_kernel.c through
spurdiff.differential.rigid_kernel) against its Python reference: every pin-load solve
(RigidDifferential._slip_exact) of the rigid scenes run both ways from the same state, bit for bit;
the compiled slipping step (RigidDifferential._step_compiled) through the model's state after every
step and whole runs of every rigid scene with solver.kernel = compiled and python identical; the
switch and the fallback."""
from __future__ import annotations

import logging
import math

import numpy as np
import pytest

from harness.build.fmu import BuildError, rigid_kernel_library
from harness.run.direct import run_direct
from harness.run.runner import prepare_scene
from spurdiff.differential import rigid_kernel, shaft_kernel
from spurdiff.errors import ParameterError
from spurdiff.differential.params import DifferentialParams
from spurdiff.differential.rigid import RigidDifferential


@pytest.fixture(scope="module")
def library():
    try:
        return rigid_kernel_library()
    except BuildError as e:          # no compiler here: nothing to compare
        pytest.skip(f"the rigid kernel cannot be compiled here: {e}")


@pytest.fixture
def both_ways(library, monkeypatch):
    """Every _slip_exact call runs the Python reference and then the kernel from the same state;
    returns the record (count, largest relative difference, modes seen)."""
    orig = RigidDifferential._slip_exact
    rec = {"n": 0, "compiled": 0, "maxrel": 0.0, "modes": set(), "static_breakaways": 0}

    def both(self, ac_given, s, lever=None):
        rk = self._rk
        before = (self.F12, self.cap, self._ad_guess)
        self._rk = None
        try:
            ref = orig(self, ac_given, s, lever) + (self.F12, self.cap)
        finally:
            self._rk = rk
        self.F12, self.cap, self._ad_guess = before
        out = orig(self, ac_given, s, lever)
        got = out + (self.F12, self.cap)
        if rk is not None:
            assert rk.const[53] == self.c_slide        # the break-away lever was for that solve only
        rec["n"] += 1
        rec["static_breakaways"] += lever is not None and lever != self.c_slide
        rec["compiled"] += rk is not None
        rec["modes"].add((ac_given is not None, s))
        for a, b in zip(ref, got):
            if not (a == b or (math.isnan(a) and math.isnan(b))):
                rec["maxrel"] = max(rec["maxrel"], abs(a - b) / max(abs(a), abs(b), 1e-300))
        return out

    monkeypatch.setattr(RigidDifferential, "_slip_exact", both)
    # the rigid model's own steps: the differential's compiled step with its half-shafts
    # (spurdiff.differential.shaft_kernel, tests/physics/test_shaft_kernel.py) would take them in C
    monkeypatch.setattr(shaft_kernel, "choose", lambda model: (None, "python (test_rigid_kernel)"))
    return rec


# the rigid scenes (the vehicle scenes: carrier torque-driven, drive and coast, stick and slip),
# one with a preload; the paper's scenes with the pin-load law stay stuck (its capacity holds
# their loads: no solve; with their own lockingLaw = paper there is none either). The speed
# drive (carrier acceleration given) while slipping: test_speed_drive_stick_and_slip.
SCENES = [
    ("vehicle-cornering", []),
    ("split-mu-launch", []),
    ("tip-in-tip-out", []),
    ("tip-in-tip-out", ["diff.lockingPreload=40.0"]),
    ("wheel-lift", []),
    ("standstill-launch", []),
    ("paper-straight", ["diff.lockingLaw=pinFriction"]),
    ("paper-cornering", ["diff.lockingLaw=pinFriction"]),
    ("paper-cornering", []),
    # the static / dynamic split of the pin friction (mu_pinDynamic < mu_pin)
    ("vehicle-cornering", ["diff.mu_pinDynamic=0.15"]),
    ("tip-in-tip-out", ["diff.mu_pinDynamic=0.13"]),
    # and breaking away from stuck with it (the shafted model's break-away solve at the static lever)
    ("split-mu-launch", ["diff.mu_pinDynamic=0.13"]),
    ("wheel-lift", ["diff.mu_pinDynamic=0.13"]),
]
SPLIT = SCENES[-4:]
BREAKAWAY = SCENES[-2:]
STUCK = ("paper-straight", "paper-cornering")


@pytest.mark.parametrize("name,sets", SCENES, ids=[f"{n}{''.join(s)}" for n, s in SCENES])
def test_every_solve_agrees_bit_for_bit(both_ways, name, sets):
    scene = prepare_scene(name, mesh="rigid", sets=sets)
    r = run_direct(scene)
    assert r.failure is None
    assert (both_ways["n"] > 0) == (name not in STUCK) and both_ways["compiled"] == both_ways["n"]
    assert both_ways["maxrel"] == 0.0
    assert (both_ways["static_breakaways"] > 0) == ((name, sets) in BREAKAWAY)


def test_the_vehicle_scenes_slip_both_ways(both_ways):
    for name in ("split-mu-launch", "wheel-lift"):
        assert run_direct(prepare_scene(name, mesh="rigid")).failure is None
    assert both_ways["modes"] == {(False, 1.0), (False, -1.0)}


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(x == y or (x != x and y != y) for x, y in zip(a.values(), b.values()))


@pytest.mark.parametrize("w_ref,preload,mu_d,ramp", [(10.0, 0.0, 0.0, 0.0), (10.0, 5.0, 0.0, 0.0),
                                                    (-10.0, 5.0, 0.0, 0.0), (10.0, 5.0, 0.1, 2000.0)])
def test_speed_drive_stick_and_slip(both_ways, w_ref, preload, mu_d, ramp):
    """Carrier speed-driven (its acceleration given) from stuck through slip either way (and with
    the pin friction split and the carrier speeding up at ``ramp`` rad/s^2: the tangential pin
    loads): every solve agrees, and the compiled and the Python model's states are equal after every step."""
    models = []
    for kernel in ("compiled", "python"):
        m = RigidDifferential(DifferentialParams(carrierDrive="speed", lockingPreload=preload, mu_pinDynamic=mu_d))
        m.kernel = kernel
        m.w_ref = w_ref
        m.initialize()
        models.append(m)
    assert models[0]._rk is not None and models[1]._rk is None
    slips = set()
    for k in range(200):
        t = k * 1e-3
        for m in models:
            m.w_ref = w_ref + ramp * (t + 1e-3)
            d = 300.0 * math.sin(2.0 * math.pi * 5.0 * t)
            m.tau_L, m.tau_R = -200.0 + d, -200.0 - d
            m.do_step(t, 1e-3)
        assert _same(models[0].get_state(), models[1].get_state())
        slips.add(models[0].slip_dir)
    assert slips == {-1.0, 0.0, 1.0}
    assert {(True, 1.0), (True, -1.0)} <= both_ways["modes"] and both_ways["maxrel"] == 0.0


@pytest.mark.parametrize("name,sets", SCENES[:6] + SPLIT, ids=[f"{n}{''.join(s)}" for n, s in SCENES[:6] + SPLIT])
def test_whole_runs_identical(library, monkeypatch, name, sets):
    """Every recorded variable of the scene, through the compiled step and solve and through the
    Python reference, equal bit for bit; the compiled step is taken in most steps that start slipping."""
    used = {"steps": 0, "compiled": 0}
    orig = RigidDifferential._step_compiled

    def counted(self, rk, t, h):
        done = orig(self, rk, t, h)
        used["steps"] += 1
        used["compiled"] += done
        return done

    monkeypatch.setattr(RigidDifferential, "_step_compiled", counted)
    monkeypatch.setattr(shaft_kernel, "choose", lambda model: (None, "python (test_rigid_kernel)"))   # the rigid steps
    out = {}
    for kernel in ("compiled", "python"):
        out[kernel] = run_direct(prepare_scene(name, sets=sets + [f"diff.solver.kernel={kernel}"]))
        assert out[kernel].failure is None
    assert np.array_equal(out["compiled"].data, out["python"].data)
    # standstill-launch starts each step stuck (its slips begin and end inside steps): Python's path
    assert used["compiled"] > 0.5 * used["steps"] > 0 or (name == "standstill-launch" and used["compiled"] == 0)


@pytest.mark.parametrize("mu_d", [0.0, 0.12])
def test_torque_drive_states_equal_after_every_step(library, mu_d):
    """Carrier torque-driven through stick and slip either way with a preload (and with the pin
    friction split, mu_pinDynamic 0.12 against mu_pin 0.26; the carrier's acceleration in the
    tangential pin loads): the compiled and the Python model's whole states equal after every step."""
    models = []
    for kernel in ("compiled", "python"):
        m = RigidDifferential(DifferentialParams(carrierDrive="torque", lockingPreload=5.0, J_carrier=5.0,
                                                 mu_pinDynamic=mu_d))
        m.kernel = kernel
        m.initialize()
        models.append(m)
    slips = set()
    for k in range(300):
        t = k * 1e-3
        for m in models:
            d = 300.0 * math.sin(2.0 * math.pi * 5.0 * t)
            m.tau_c, m.tau_L, m.tau_R = 100.0 * math.cos(3.0 * t), -200.0 + d, -200.0 - d
            m.do_step(t, 1e-3)
        assert _same(models[0].get_state(), models[1].get_state())
        slips.add(models[0].slip_dir)
    assert slips == {-1.0, 0.0, 1.0}


def test_switch_and_fallback(library, monkeypatch, caplog):
    def model(kernel, **kw):
        m = RigidDifferential(DifferentialParams(**kw))
        m.kernel = kernel
        m.initialize()
        return m

    assert model("python")._rk is None and model("python").kernel_note == "python (kernel = python)"
    assert model("auto")._rk is not None and model("auto").kernel_note == "compiled"
    assert model("auto", lockingLaw="paper")._rk is None          # no pin-load solve to run
    with pytest.raises(ParameterError, match="solver.kernel"):
        model("fast")
    # no library: auto falls back with the reason logged, compiled refuses
    monkeypatch.setattr(rigid_kernel, "_candidates", lambda: [])
    monkeypatch.setattr(rigid_kernel, "_REPORTED", set())
    rigid_kernel.reset()
    try:
        with caplog.at_level(logging.WARNING, logger="spurdiff.rigid"):
            m = model("auto")
        assert m._rk is None and m.kernel_note.startswith("python (no compiled rigid kernel found")
        assert "Python reference" in caplog.text
        with pytest.raises(ParameterError, match="solver.kernel"):
            model("compiled")
    finally:
        rigid_kernel.reset()


def test_stale_library_not_used(library, tmp_path, monkeypatch):
    """A library is looked up under the digest of the C source: another source digest finds none."""
    names = {p.name for p in rigid_kernel._candidates()}
    assert library.name in names
    monkeypatch.setattr(rigid_kernel.native_library, "source_digest", lambda native, stem: "0" * 16)
    assert library.name not in {p.name for p in rigid_kernel._candidates()}


def test_the_fmu_ships_the_kernel(differential_fmu):
    """The SpurDifferential FMU carries the library beside its binding (solver.kernel = compiled
    refuses to start without it) and gives the Python reference's results bit for bit."""
    import zipfile

    from fmpy import simulate_fmu

    with zipfile.ZipFile(differential_fmu) as z:
        assert "resources/spurdiff/differential/librigid_kernel.so" in z.namelist()
    start = {"meshModel": "rigid", "carrierDrive": "speed", "carrier.w_ref": 1.389, "left.tau": -1500.0,
             "right.tau": -600.0}
    runs = {k: simulate_fmu(str(differential_fmu), stop_time=0.05, output_interval=1e-3,
                            start_values={**start, "solver.kernel": k})
            for k in ("python", "compiled")}
    assert np.any(runs["compiled"]["left.w"] != runs["compiled"]["right.w"])     # it slips
    for name in ("carrier.tauDrive", "left.tauMesh", "left.w", "energyLoss"):
        assert np.array_equal(runs["python"][name], runs["compiled"][name]), name


def test_the_fmu_reports_which_implementation_runs_the_rigid_solve(differential_fmu):
    """solver.kernelInUse names the rigid level's implementation too (it said 'none' at rigid)."""
    import shutil

    from harness.fmi.instance import Instance

    seen = {}
    for kernel in ("python", "auto"):
        inst = Instance(f"k{kernel}", differential_fmu)
        inst.slave.setupExperiment(startTime=0.0)
        inst.slave.enterInitializationMode()
        inst.set_value("solver.kernel", kernel)
        inst.slave.exitInitializationMode()
        seen[kernel] = inst.slave.getString([inst.var("solver.kernelInUse").valueReference])[0].decode()
        inst.close()
    assert seen["python"] == "python (kernel = python)", seen
    if shutil.which("cc") or shutil.which("gcc"):   # the build shipped the library
        assert seen["auto"] == "compiled", seen
