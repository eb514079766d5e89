"""The vehicle scenes (car + differential + two wheels, through FMI), in shorter runs: the physics
each scene is about, checked from the recorded trajectories."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from harness.measure.bench.coupling import torque_coupled
from harness.run.master import run_scene
from harness.run.report import evaluate_checks, series, stat
from harness.run.runner import prepare_scene

SCENES = ["vehicle-cornering", "split-mu-launch", "tip-in-tip-out", "standstill-launch", "wheel-lift"]
TBR = "{diff.torqueBiasRatio}"   # drive; from the pin-load law (calculated parameter)
# the friction never exceeds what the pins can hold (exact at the rigid level: stick-slip is solved
# exactly); the shaft torques differ from it by the suns' inertia torques
WITHIN_CAPACITY = "abs({diff.lockingTorque}) - {diff.lockingCapacity} * (1 + 1e-9)"


def run(fmu_files, name, duration, **kw):
    scene = prepare_scene(name, duration=duration, **kw)
    scene.record = list(scene.record) + [n for n in ("diff.torqueBiasRatio", "diff.lockingTorque",
                                                     "diff.lockingCapacity", "diff.leftShaft.tauEnd",
                                                     "diff.rightShaft.tauEnd") if n not in scene.record]
    result = run_scene(scene, fmu_files)
    assert result.ok, result.failure
    assert np.all(np.isfinite(result.data)), "NaN or inf recorded"
    return result


def checks_within(result, t_end):
    """The scene's own checks whose windows lie inside the shortened run (all must pass)."""
    out = [o for c, o in zip(result.scene.checks, evaluate_checks(result))
           if c["stat"] != "final" and (not c.get("window") or c["window"][1] <= t_end + 1e-9)]
    assert out
    return out


@pytest.mark.parametrize("name", SCENES)
def test_scene_is_well_formed(name):
    scene = prepare_scene(name)
    assert scene.description and scene.effects == {"meshModel": "rigid"}
    assert {i.fmu for i in scene.instances} == {"Vehicle", "SpurDifferential", "WheelLoad"}
    assert scene.instance("diff").parameters["carrierDrive"] == "torque"
    assert scene.connections["diff.carrier.tau"] == "car.driveTorque"
    bonds = {(c["torque"], c["w_from"], c["w_to"]) for c in scene.couplings}
    assert bonds == {("diff.leftShaft.tau", "diff.left.w", "wheelL.wheel.w"),
                     ("diff.rightShaft.tau", "diff.right.w", "wheelR.wheel.w")}
    assert scene.checks and scene.table
    text = scene.source.read_text()
    assert "Communication step" in text          # the step is explained in the file
    # the robust interface: the differential owns the half-shafts, the wheels send angle and speed
    assert scene.instance("diff").parameters["shaftCoupling"] == "wheel"
    for side, w in (("left", "wheelL"), ("right", "wheelR")):
        assert scene.instance(w).parameters["shaftCoupling"] == "wheel"
        assert scene.connections[f"diff.{side}Wheel.phi"] == f"{w}.wheel.phi"
        assert scene.connections[f"diff.{side}Wheel.w"] == f"{w}.wheel.w"
        assert scene.connections[f"{w}.shaftIn.tau"] == f"diff.{side}Shaft.tau"
        # the first-order hold between car and wheel: the wheel ramps from the car's outputs at the
        # start of the step to those at its end (the car steps first)
        car_side = f"rear{side.capitalize()}"
        for q in ("Fz", "vx"):
            assert scene.connections[f"{w}.{q}"] == f"car.{car_side}.{q}"
            assert scene.connections[f"{w}.{q}Rate"] == f"car.{car_side}.{q}Rate"
        assert scene.instance(w).parameters["wheelLoad.rampAnchor"] == "end"
    # the differential's wheel-side inputs are the values at the communication point
    order = [i.name for i in scene.instances]
    assert order.index("diff") < order.index("wheelL") and order.index("diff") < order.index("wheelR")
    assert order.index("car") < order.index("wheelL") and order.index("car") < order.index("wheelR")
    assert scene.step >= 5e-3


@pytest.mark.parametrize("name", SCENES)
def test_command_rates_are_the_rates_of_the_command_inputs(name):
    """A scene's car.speedTargetRate / car.pathRadiusRate is the rate of its speedTarget /
    pathRadius over every step that starts at a multiple of 0.2 ms (the master samples both at
    the step's start; the rate tables change 1 us before the inputs' corners, so that the sample
    at a corner is the rate after it). Tables that do not ramp have no rate."""
    scene = prepare_scene(name)
    for q in ("speedTarget", "pathRadius"):
        value, rate = scene.inputs[f"car.{q}"], scene.inputs.get(f"car.{q}Rate")
        if rate is None:   # constant or steps only
            segments = zip(zip(value.times, value.values), zip(value.times[1:], value.values[1:]))
            assert not any(t1 > t0 and v1 != v0 for (t0, v0), (t1, v1) in segments), q
            continue
        ts = [k * 2e-4 for k in range(int(round(scene.duration / 2e-4)))]
        slopes = [(value(t + 1e-7) - value(t)) / 1e-7 for t in ts]
        for t, x in zip(ts, slopes):
            assert rate(t) == pytest.approx(x, rel=1e-6, abs=1e-6), (q, t)


def test_vehicle_cornering(fmu_files):
    r = run(fmu_files, "vehicle-cornering", 1.6)
    w = [1.0, 1.6]
    # the car is in its steady turn from the start (consistent start values)
    assert stat(r, "car.vx", "span", [0.0, 1.6]) < 0.01
    assert stat(r, "car.yawRate", "mean", w) == pytest.approx(0.5, rel=5e-3)
    # outer / inner wheel speed: the kinematic ratio (R + t/2) / (R - t/2) less a little tyre slip
    ratio = stat(r, "{wheelR.wheel.w} / {wheelL.wheel.w}", "mean", w)
    assert ratio == pytest.approx(20.8 / 19.2, rel=5e-3)
    assert ratio < 20.8 / 19.2                   # the inner wheel slips more (more torque, less load)
    # w_A + w_B = 2 w_c, and the carrier turns at the mean wheel speed
    assert stat(r, "{diff.left.w} + {diff.right.w} - 2 * {diff.carrier.w}", "absmax") < 1e-9
    assert stat(r, "diff.carrier.w", "mean", w) == pytest.approx(
        stat(r, "({wheelL.wheel.w} + {wheelR.wheel.w}) / 2", "mean", w), rel=1e-4)
    # the slower (inner) wheel gets the larger torque; the difference is K T0 (slipping at capacity)
    assert stat(r, "{diff.leftShaft.tau} - {diff.rightShaft.tau}", "min", w) > 0.0
    assert stat(r, "{diff.leftShaft.tau} - {diff.rightShaft.tau} - {diff.lockingCapacity}", "max", w) < 0.01
    # K at the operating point: the planets' centrifugal pin loads at the carrier speed (issue 27,
    # spurdiff.differential.speed_law), for the scene's gear set (under the 3-D pin law the designed
    # one: 0.2369 against the standstill lockingCoefficient 0.2366; the paper's set 0.2328 against
    # 0.2326: docs/paper-reproduction.md, "The main job with the new default law")
    from spurdiff.differential.inertia import mass_properties
    from spurdiff.differential.locking import pin_friction
    from spurdiff.differential.params import DifferentialParams
    from spurdiff.differential.speed_law import breakaway_at_speed
    from spurdiff.gears.design_sets import gear_set

    assert r.scene.instance("diff").gear_set == "designed"
    p = DifferentialParams(table=gear_set("designed"))
    geo = p.validate()
    mp = mass_properties(p, geo)
    T0 = stat(r, "car.driveTorque", "mean", w)
    K_v = breakaway_at_speed(pin_friction(geo, p.mu_pin, p.r_collar), geo, (mp.m_planet1, mp.m_planet2),
                             stat(r, "diff.carrier.w", "mean", w), T0, -1.0).K
    assert stat(r, "{diff.leftShaft.tau} / {diff.rightShaft.tau}", "mean", w) == pytest.approx(
        (1 + K_v) / (1 - K_v), rel=1e-3)
    assert stat(r, "diff.lockingTorque", "mean", w) == pytest.approx(K_v * T0, rel=1e-2)
    # power balance of both half-shaft couplings over the whole run
    for name, e in r.coupling_energy.items():
        assert e["work_from"] > 1000.0, name
        assert abs(e["work_from"] - e["work_to"]) <= 1e-4 * e["work_from"], name
    assert all(o.passed for o in checks_within(r, 1.6)), [o for o in checks_within(r, 1.6) if not o.passed]


def test_old_coupling_step_above_the_stability_limit_diverges(fmu_files):
    """With the old interface (the wheels own the shafts) 0.5 ms is beyond the Gauss-Seidel limit
    (0.49 ms) for the slipping differential (the paper's locking law; the pin-load law's six times
    larger friction keeps this differential stuck, which damps the sun/shaft mode at this step).
    The limit was measured with the paper's gear set (its suns' and planets' inertia set the mode);
    the scene runs the designed set since issue 27, with which this 0.6 s run at 0.5 ms does not diverge."""
    from harness.scene.spec import parse_scene

    data = torque_coupled("vehicle-cornering", step=5e-4, duration=0.6, output_interval=5e-3)
    data["fmus"]["diff"]["parameters"]["lockingLaw"] = "paper"
    data["fmus"]["diff"]["gearSet"] = "paper"
    r = run_scene(parse_scene(data), fmu_files)
    # the sun/shaft mode grows until a flange speed leaves the wheel FMU's physical input range:
    # it refuses the step (fmi2Discard) rather than go on with a meaningless value
    assert not r.ok and "outside [-10000, 10000]" in str(r.failure)
    assert stat(r, "diff.leftShaft.tau", "absmax") > 1e3   # the steady value is 78 N m


@pytest.fixture(scope="module")
def old_coupling_reference(fmu_files):
    """vehicle-cornering with the old interface at 0.2 ms (its stable step), 1.2 s."""
    from harness.scene.spec import parse_scene

    r = run_scene(parse_scene(torque_coupled("vehicle-cornering", step=2e-4, duration=1.2)), fmu_files)
    assert r.ok, r.failure
    return r


@pytest.mark.parametrize("h", [1e-3, 5e-3, 1e-2, 2e-2])
def test_vehicle_cornering_at_system_simulator_steps(fmu_files, old_coupling_reference, h):
    """Issue 19: stable at 1, 5, 10 and 20 ms; at 1 to 10 ms the wheel-speed ratio agrees with the
    old coupling's 0.2 ms run within 1e-3 and the locking torque within 1 % (means over the
    steady part, same locking law); 20 ms still within 1e-3 and 2 %."""
    r = run(fmu_files, "vehicle-cornering", 1.2, step=h)
    ref = old_coupling_reference
    w = [1.0, 1.2]
    q = "{wheelR.wheel.w} / {wheelL.wheel.w}"
    assert stat(r, q, "mean", w) == pytest.approx(stat(ref, q, "mean", w), abs=1e-3)
    lock, lock_ref = stat(r, "diff.lockingTorque", "mean", w), stat(ref, "diff.lockingTorque", "mean", w)
    assert lock == pytest.approx(lock_ref, rel=1e-2 if h <= 1e-2 else 2e-2)
    # finite and bounded all through: no wheel speed far from the car's
    assert stat(r, "{wheelL.wheel.w} - {car.vx} / 0.3266", "absmax") < 3.0


_OLD_REFS: dict = {}


def old_reference(fmu_files, name, duration):
    """The scene with the old interface at 0.2 ms (its stable step), run once per test session."""
    from harness.scene.spec import parse_scene

    if name not in _OLD_REFS:
        r = run_scene(parse_scene(torque_coupled(name, step=2e-4, duration=duration)), fmu_files)
        assert r.ok, r.failure
        _OLD_REFS[name] = r
    return _OLD_REFS[name]


# (scene, window of the means): issue 19's 1e-3 on the wheel-speed ratio and 1 % on the locking
# torque, met at 1 to 10 ms (measured with python -m harness.cli.tools.coupling_bench: wheel-lift 1.2e-4
# and 1.0e-3 at 10 ms, split-mu-launch 6.3e-4 and 2.7e-4; wheel-lift's ratio was 1.4e-3 before
# its path radius and the car's wheel loads and speeds ramped over the step)
TRANSIENT_CASES = [("split-mu-launch", (1.0, 2.0)), ("wheel-lift", (1.1, 2.2))]


@pytest.mark.parametrize("h", [1e-3, 5e-3, 1e-2])
@pytest.mark.parametrize("name, window", TRANSIENT_CASES)
def test_transient_scenes_at_system_simulator_steps(fmu_files, name, window, h):
    """Issue 19 item 2 in the transient scenes (a wheel spinning up on ice, a wheel lifting): with
    the interface model (the wheel's linear response integrated with the shaft twist) and the
    first-order hold between car and wheels, the means over the scene's window agree with the old
    coupling's 0.2 ms run."""
    ref = old_reference(fmu_files, name, window[1])
    r = run(fmu_files, name, window[1], step=h)
    q = "{wheelR.wheel.w} / {wheelL.wheel.w}"
    assert stat(r, q, "mean", list(window)) == pytest.approx(stat(ref, q, "mean", list(window)), abs=1e-3)
    lock, lock_ref = (stat(x, "diff.lockingTorque", "mean", list(window)) for x in (r, ref))
    assert lock == pytest.approx(lock_ref, rel=1e-2)


@pytest.mark.parametrize("name", SCENES)
def test_scene_stable_at_20_ms(fmu_files, name):
    """Every vehicle scene runs to its end at a 20 ms step (finite, the kinematics hold)."""
    scene = prepare_scene(name, step=2e-2)
    r = run_scene(scene, fmu_files)
    assert r.ok, r.failure
    assert np.all(np.isfinite(r.data))
    assert stat(r, "{diff.left.w} + {diff.right.w} - 2 * {diff.carrier.w}", "absmax") < 1e-9


def test_split_mu_launch(fmu_files):
    r = run(fmu_files, "split-mu-launch", 1.0)
    # the grip side never gets more than the torque bias ratio times the ice side: the friction
    # stays within its capacity, and while slipping the shaft torques split at that ratio
    assert stat(r, WITHIN_CAPACITY, "max", [0.001, 1.0]) <= 0.0
    assert stat(r, "{diff.rightShaft.tau} / {diff.leftShaft.tau}", "mean", [0.5, 1.0]) == pytest.approx(
        stat(r, TBR, "mean"), rel=5e-3)
    # the ice wheel spins up relative to the other, the grippy one keeps rolling
    dw = series(r, "{wheelL.wheel.w} - {wheelR.wheel.w}")
    assert dw[0] == 0.0 and dw[-1] > 20.0
    assert np.all(np.diff(dw[r.time > 0.4]) > 0.0)
    assert stat(r, "wheelR.slip", "absmax") < 0.05
    assert stat(r, "car.vx", "final") > 2.2
    assert all(o.passed for o in checks_within(r, 1.0))


def test_tip_in_tip_out(fmu_files):
    r = run(fmu_files, "tip-in-tip-out", 2.6)
    T = series(r, "car.driveTorque")
    assert T.max() > 500.0 and T.min() < -300.0          # drive, then coast
    for side in ("left", "right"):
        tau = series(r, f"diff.{side}Shaft.tau")
        assert tau.max() > 300.0 and tau.min() < -100.0
    # the inner (slower) sun is always pushed forward by the friction: in drive the inner wheel
    # gets the larger drive torque, in coast the outer wheel the larger braking torque
    after0 = [0.001, 2.6]
    assert stat(r, "{diff.leftShaft.tau} - {diff.rightShaft.tau}", "min", after0) > 0.0
    coast = r.time > 2.3
    tL, tR = series(r, "diff.leftShaft.tau")[coast], series(r, "diff.rightShaft.tau")[coast]
    assert np.all(tR < tL) and np.all(tL < 0.0)
    assert stat(r, WITHIN_CAPACITY, "max", after0) <= 0.0
    assert stat(r, "diff.stuck", "max") == 0.0
    assert all(o.passed for o in checks_within(r, 2.6))


def test_standstill_launch(fmu_files):
    r = run(fmu_files, "standstill-launch", 1.5)
    rest = [0.0, 0.2]
    for q in ("car.vx", "wheelL.wheel.w", "wheelR.wheel.w", "wheelL.slip", "diff.leftShaft.tau"):
        assert stat(r, q, "absmax", rest) == 0.0, q    # rest stays rest: no creep, no NaN
    assert stat(r, "maximum(abs({wheelL.slip}), abs({wheelR.slip}))", "absmax") < 0.18   # below the peak
    assert stat(r, "car.vx", "min") >= 0.0
    assert stat(r, "car.vx", "final") > 1.0 and stat(r, "car.x", "final") > 0.5          # moves off
    assert stat(r, "diff.stuck", "min") == 1.0         # symmetric: the differential never slips
    assert all(o.passed for o in checks_within(r, 1.5))


def test_wheel_lift(fmu_files):
    r = run(fmu_files, "wheel-lift", 1.8)
    Fz = series(r, "car.rearLeft.Fz")
    assert Fz.min() == 0.0 and Fz[0] > 1000.0          # the inner wheel unloads completely
    assert stat(r, "minimum({car.rearLeft.Fz}, {car.rearRight.Fz})", "min") >= 0.0
    lifted = Fz == 0.0
    assert np.all(series(r, "wheelL.Fx")[lifted] == 0.0)
    # the unloaded wheel spins up
    dw = series(r, "{wheelL.wheel.w} - {wheelR.wheel.w}")
    assert dw[0] < 0.0 and dw[-1] > 15.0
    # torques bounded by the locking capacity (plus inertia, see the scene), both at the end of
    # the step (the shaft torque output is the mean over the step, the capacity the end value);
    # after the first 50 ms: the start values are the old coupling's steady state, and the first
    # two 5 ms steps settle the shafts (0.66 N m above the capacity at t = 0.01 s, sun inertia)
    after0 = [0.05, 1.8]
    assert stat(r, "abs({diff.leftShaft.tauEnd} - {diff.rightShaft.tauEnd}) - {diff.lockingCapacity}", "max",
                after0) < 0.5
    # the bias ratio at the operating point: K_v = capacity / |T_A + T_B| carries the planets'
    # centrifugal pin loads (with the standstill torqueBiasRatio the designed set's heavier planet 2
    # left the outer torque 0.55 N m above it)
    K_v = "{diff.lockingCapacity} / abs({diff.left.tauMesh} + {diff.right.tauMesh})"
    assert stat(r, f"{{diff.rightShaft.tauEnd}} - {{diff.leftShaft.tauEnd}} * (1 + {K_v}) / (1 - {K_v})", "max",
                after0) < 0.5
    assert all(o.passed for o in checks_within(r, 1.8))


def test_direct_physics_run_equals_fmi_run_for_the_car(fmu_files):
    """The new interface modules in harness.run.direct: same scene, bit-identical trajectories."""
    from harness.run.direct import run_direct

    scene = replace(prepare_scene("vehicle-cornering", duration=0.02), output_interval=2e-4)
    a, b = run_direct(scene), run_scene(scene, fmu_files)
    assert a.ok and b.ok
    assert np.array_equal(a.data, b.data)


def test_kinematic_checks_state_the_fidelity_they_hold_at():
    """Issue 19 item 6: the exact constraint is checked at rigid; at contact the mesh deflection
    rate replaces it (below 1e-4 rad/s in the steady turn) and the rigid one reports N/A."""
    from harness.run.direct import run_direct
    from harness.run.report import format_checks
    from harness.scene.spec import SceneError, parse_scene, read_scene_data

    for mesh in ("rigid", "contact"):
        r = run_direct(prepare_scene("vehicle-cornering", mesh=mesh, duration=1.2))
        assert r.ok
        out = {o.name: o for o in evaluate_checks(r)}
        rigid = out["kinematics (rigid): w_A + w_B = 2 w_c (to 1e-9 rad/s)"]
        mesh_check = next(o for n, o in out.items() if n.startswith("kinematics (compliant, contact)"))
        applies, na = (rigid, mesh_check) if mesh == "rigid" else (mesh_check, rigid)
        assert applies.passed and np.isfinite(applies.value)
        assert np.isnan(na.value) and na.expectation.startswith(f"not checked at meshModel = {mesh}")
        assert "N/A   " + na.name in format_checks(list(out.values()))
    data = read_scene_data("vehicle-cornering")
    data["checks"][0]["fidelity"] = "rigid"
    with pytest.raises(SceneError, match=r"fidelity = 'rigid'; allowed: a list of rigid, compliant, contact"):
        parse_scene(data)
