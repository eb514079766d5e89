"""Vehicle (spurdiff.vehicle.car): planar body, lateral tyres, load transfer, steering and speed control."""
from __future__ import annotations

import json
import math

import pytest
from scipy.integrate import solve_ivp

from spurdiff.errors import ParameterError
from spurdiff.vehicle.tyre import slip_for_force_ratio
from spurdiff.vehicle.car import G, STEER_ANGLE, Vehicle, VehicleParams

H = 1e-3


def params(**over) -> VehicleParams:
    """Default data with overrides by structured name, e.g. ``vehicle__vx_start=10``."""
    p = VehicleParams.defaults()
    for key, value in over.items():
        group, name = key.split("__")
        setattr(getattr(p, group), name, value)
    return p


def drive_by_torque_balance(v: Vehicle) -> None:
    """Test-side stand-in for differential + wheels: each rear tyre pushes half the axle torque / R."""
    F = v.driveTorque / (2.0 * v.params.vehicle.R_wheel)
    v.rearLeft_Fx = v.rearRight_Fx = F


def run(v: Vehicle, n: int, h: float = H, inputs=drive_by_torque_balance) -> None:
    for i in range(n):
        if inputs is not None:
            inputs(v)
        v.do_step(i * h, h)


def test_data_file_and_dataclass_defaults_agree():
    a, b = VehicleParams.defaults(), VehicleParams()
    assert a == b


def test_unknown_data_key_is_named():
    with pytest.raises(ParameterError) as e:
        VehicleParams.from_data({"steering": {"gain": 1.0}})
    assert e.value.name == "steering.gain"


def test_standstill_with_zero_inputs_stays_at_rest_and_finite():
    v = Vehicle(params())
    v.initialize()
    run(v, 2000, inputs=None)
    state = v.get_state()
    assert all(math.isfinite(x) for x in state.values())
    for k in ("vx", "vy", "r", "psi", "x", "y", "alpha_f", "alpha_r", "I_v", "I_r"):
        assert state[k] == 0.0, k
    b = v.params.vehicle
    assert v.frontAxle_Fz == pytest.approx(b.m * G * (b.L - b.l_f) / b.L, rel=1e-14)
    assert v.rearLeft_Fz == v.rearRight_Fz == pytest.approx(0.5 * b.m * G * b.l_f / b.L, rel=1e-14)


def test_straight_coast_down_decelerates_as_the_drag_and_rolling_resistance_say():
    p = params(vehicle__vx_start=30.0)
    b = p.vehicle
    v = Vehicle(p)
    v.initialize()
    # at t0: deceleration from aero drag and front rolling resistance, with the front load that
    # this deceleration itself shifts (the load-transfer filter starts at its fixed point)
    ax0 = -(0.5 * b.rho_air * b.CdA * 30.0 ** 2 + b.f_rr * v.frontAxle_Fz * math.tanh(30.0 / b.v_rr)) / b.m
    assert v.ax == pytest.approx(ax0, rel=1e-12)
    assert v.frontAxle_Fz == pytest.approx(b.m * G * (b.L - b.l_f) / b.L - b.m * v.ax * b.h_cg / b.L, rel=1e-10)
    axf0 = v.get_state()["axs_f"]
    speeds = []
    run(v, 10_000, inputs=lambda veh: speeds.append(veh.vx))
    assert all(s1 < s0 for s0, s1 in zip(speeds, speeds[1:]))
    assert v.vy == 0.0 and v.psi == 0.0 and v.y == 0.0   # symmetric: stays straight

    def rhs(t, y):   # the same straight-line physics as a 2-state ODE
        vx, axf = y
        Fzf = b.m * G * (b.L - b.l_f) / b.L - b.m * axf * b.h_cg / b.L
        ax = (-0.5 * b.rho_air * b.CdA * vx * abs(vx) - b.f_rr * Fzf * math.tanh(vx / b.v_rr)) / b.m
        return [ax, (ax - axf) / b.tau_load]

    ref = solve_ivp(rhs, (0.0, 10.0), [30.0, axf0], method="DOP853", rtol=1e-12, atol=1e-12)
    assert v.vx == pytest.approx(ref.y[0, -1], rel=1e-10)


def test_coasting_to_a_stop_does_not_reverse():
    # only the front rolling resistance brakes: f_rr Fz_f / m = 0.074 m/s^2, stopped after about 27 s
    v = Vehicle(params(vehicle__vx_start=2.0))
    v.initialize()
    speeds = []
    run(v, 4000, h=1e-2, inputs=lambda veh: speeds.append(veh.vx))
    assert min(speeds) >= 0.0
    assert 0.0 <= v.vx < 0.01


@pytest.mark.parametrize("radius", [20.0, -20.0])
def test_steady_turn_yaw_rate_lateral_acceleration_and_outer_wheel_load(radius):
    speed = 10.0
    p = params(vehicle__vx_start=speed)
    b = p.vehicle
    v = Vehicle(p)
    v.speedTarget, v.pathRadius = speed, radius
    v.initialize()
    run(v, 8000)
    assert v.vx == pytest.approx(speed, rel=2e-3)
    assert v.yawRate == pytest.approx(v.vx / radius, rel=5e-3)
    assert v.ay == pytest.approx(v.vx ** 2 / radius, rel=5e-3)
    # load transfer to the outer wheel (the right one in a left turn), by roll-stiffness share
    outer, inner = (v.rearRight_Fz, v.rearLeft_Fz) if radius > 0 else (v.rearLeft_Fz, v.rearRight_Fz)
    assert outer > inner > 0.0
    dFz = b.rollStiffnessShareRear * b.m * abs(v.ay) * b.h_cg / b.trackRear
    assert outer - inner == pytest.approx(2.0 * dFz, rel=1e-4)
    assert outer + inner == pytest.approx(v.rearAxle_Fz, rel=1e-14)
    # the outer rear wheel centre moves faster
    fast, slow = (v.rearRight_vx, v.rearLeft_vx) if radius > 0 else (v.rearLeft_vx, v.rearRight_vx)
    assert fast - slow == pytest.approx(b.trackRear * abs(v.yawRate), rel=1e-14)


def test_direct_steering_angle_gives_the_single_track_steady_state():
    """Cornering stiffness proportional to load makes this car neutral steer: r = v delta / L, and
    the rear slip angle carries the rear share of m a_y (single-track model)."""
    speed, delta = 15.0, 0.01
    p = params(vehicle__vx_start=speed, steering__mode=STEER_ANGLE)
    b, lt = p.vehicle, p.lateralTyre
    v = Vehicle(p)
    v.speedTarget, v.steering_angle_cmd = speed, delta
    v.initialize()
    run(v, 8000)
    assert v.steering_angle == delta
    assert v.yawRate == pytest.approx(v.vx * delta / b.L, rel=2e-3)
    ay = v.vx * v.yawRate
    alpha_r = slip_for_force_ratio(b.m * ay * b.l_f / b.L / (v.mu * v.rearAxle_Fz), lt.B, lt.C, lt.E)
    assert v.vy == pytest.approx((b.L - b.l_f) * v.yawRate - v.vx * alpha_r, rel=1e-2)


def test_rear_force_difference_yaws_the_car():
    v = Vehicle(params(steering__mode=STEER_ANGLE))
    v.initialize()
    v.rearLeft_Fx, v.rearRight_Fx = 100.0, 300.0
    b = v.params.vehicle
    v.do_step(0.0, 1e-4)
    # from rest, the yaw acceleration is (t_r / 2)(Fx_R - Fx_L) / Iz (no side forces yet)
    assert v.yawRate / 1e-4 == pytest.approx(0.5 * b.trackRear * 200.0 / b.Iz, rel=1e-3)
    assert v.yawRate > 0.0


def test_acceleration_moves_load_to_the_rear_axle():
    v = Vehicle(params(steering__mode=STEER_ANGLE))
    v.initialize()
    run(v, 1000, inputs=lambda veh: setattr(veh, "rearLeft_Fx", 1500.0) or setattr(veh, "rearRight_Fx", 1500.0))
    b = v.params.vehicle
    static = b.m * G * b.l_f / b.L
    assert v.rearAxle_Fz - static == pytest.approx(b.m * v.ax * b.h_cg / b.L, rel=1e-3)
    assert v.frontAxle_Fz + v.rearAxle_Fz == pytest.approx(b.m * G, rel=1e-14)


def test_a_lifting_wheel_has_zero_load_never_negative():
    p = params(vehicle__h_cg=1.2, vehicle__vx_start=12.0)
    v = Vehicle(p)
    v.mu, v.pathRadius, v.speedTarget = 1.2, 15.0, 12.0
    v.initialize()
    loads = []
    run(v, 3000, inputs=lambda veh: (drive_by_torque_balance(veh), loads.append((veh.rearLeft_Fz, veh.rearRight_Fz))))
    assert min(min(pair) for pair in loads) == 0.0
    assert v.rearLeft_Fz == 0.0 and v.rearRight_Fz == v.rearAxle_Fz


def test_speed_controller_limits_torque_and_does_not_wind_up():
    p = params()
    sc = p.speedControl
    v = Vehicle(p)
    v.speedTarget = 20.0
    v.initialize()
    torques, integrators, speeds = [], [], []

    def inputs(veh):
        drive_by_torque_balance(veh)
        torques.append(veh.driveTorque)
        integrators.append(veh.get_state()["I_v"])
        speeds.append(veh.vx)

    run(v, 20_000, inputs=inputs)
    assert max(torques) == sc.driveTorqueMax and min(torques) >= sc.driveTorqueMin
    assert max(integrators) <= sc.driveTorqueMax           # the integrator stopped while saturated
    assert max(speeds) < 20.0 * 1.06                        # small overshoot after 8 s at full torque
    assert v.vx == pytest.approx(20.0, rel=1e-3)


def test_start_on_a_grade_holds_with_the_holding_torque():
    v = Vehicle(params())
    v.grade = 0.1
    v.initialize()
    b = v.params.vehicle
    assert v.driveTorque == pytest.approx(b.R_wheel * b.m * G * math.sin(0.1), rel=1e-12)


def test_1e_2_step_matches_1e_3_step():
    results = []
    for h in (1e-2, 1e-3):
        v = Vehicle(params(vehicle__vx_start=20.0))
        v.speedTarget, v.pathRadius = 20.0, -50.0
        v.initialize()
        run(v, int(round(6.0 / h)), h=h)
        results.append((v.yawRate, v.ay, v.vx, v.vy, v.rearLeft_Fz, v.rearRight_Fz, v.x, v.y))
    for coarse, fine in zip(*results):
        assert coarse == pytest.approx(fine, rel=1e-4)


def test_rollback_reproduces_the_continuation_bit_for_bit():
    v = Vehicle(params(vehicle__vx_start=10.0))
    v.speedTarget, v.pathRadius = 12.0, 30.0
    v.initialize()
    run(v, 300)
    saved = json.loads(json.dumps(v.get_state()))
    run(v, 300)
    end_first = v.get_state()
    v.set_state(saved)
    run(v, 300)
    assert v.get_state() == end_first


@pytest.mark.parametrize("group,field,value,name", [
    ("vehicle", "m", -1250.0, "vehicle.m"),
    ("vehicle", "Iz", math.nan, "vehicle.Iz"),
    ("vehicle", "l_f", 3.0, "vehicle.l_f"),
    ("vehicle", "rollStiffnessShareRear", 1.5, "vehicle.rollStiffnessShareRear"),
    ("lateralTyre", "C", 3.0, "lateralTyre.C"),
    ("lateralTyre", "sigma", 0.0, "lateralTyre.sigma"),
    ("steering", "mode", 2, "steering.mode"),
    ("speedControl", "driveTorqueMin", 100.0, "speedControl.driveTorqueMin"),
])
def test_bad_parameters_are_named(group, field, value, name):
    v = Vehicle(params(**{f"{group}__{field}": value}))
    with pytest.raises(ParameterError) as e:
        v.initialize()
    assert e.value.name == name
    assert "allowed" in str(e.value)


@pytest.mark.parametrize("attr,value,name", [
    ("rearLeft_Fx", math.nan, "rearLeft.Fx"), ("rearRight_Fx", math.inf, "rearRight.Fx"),
    ("speedTarget", math.nan, "speedTarget"), ("pathRadius", math.nan, "pathRadius"),
    ("grade", 2.0, "grade"), ("mu", -1.0, "mu"), ("steering_angle_cmd", math.nan, "steeringAngleCommand"),
])
def test_bad_inputs_are_named_and_leave_the_state_unchanged(attr, value, name):
    v = Vehicle(params(vehicle__vx_start=5.0))
    v.initialize()
    run(v, 10)
    before = v.get_state()
    setattr(v, attr, value)
    with pytest.raises(ParameterError) as e:
        v.do_step(0.01, H)
    assert e.value.name == name
    after = v.get_state()
    after[attr] = before[attr]
    assert after == before


def test_straight_path_radius_can_be_zero_or_infinite():
    for radius in (0.0, math.inf, -math.inf):
        v = Vehicle(params(vehicle__vx_start=10.0))
        v.speedTarget, v.pathRadius = 10.0, radius
        v.initialize()
        run(v, 200)
        assert v.steering_angle == 0.0 and v.yawRate == 0.0


def test_a_step_with_a_non_finite_result_is_refused_and_leaves_state_and_outputs_unchanged():
    # ATOMIC_STEP: the FMU adapter takes no snapshot, so do_step itself must commit nothing when
    # its result is not finite (a finite but absurd tyre force overflows the body speed)
    from spurdiff.errors import StepError

    v = Vehicle(params(vehicle__vx_start=5.0))
    v.initialize()
    run(v, 10)
    assert Vehicle.ATOMIC_STEP
    before = v.get_state()
    v.rearLeft_Fx = v.rearRight_Fx = 1e306
    with pytest.raises(StepError, match="non-finite"):
        v.do_step(0.01, 0.1)
    after = v.get_state()
    after["rearLeft_Fx"], after["rearRight_Fx"] = before["rearLeft_Fx"], before["rearRight_Fx"]
    assert after == before
    v.rearLeft_Fx = v.rearRight_Fx = 0.0
    v.do_step(0.01, H)                        # and it steps on from the kept state
    assert math.isfinite(v.vx) and v.t == pytest.approx(0.01 + H)
