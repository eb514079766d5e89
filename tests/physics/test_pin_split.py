"""The static / dynamic split of the pin friction in the dynamics (mu_pin at break-away and while
stuck, mu_pinDynamic while slipping) at every level, against hand computations with the
quasi-static pin-load law of spurdiff.differential.locking; the re-stick at mu_s without chattering;
the parameter's range; kernel and Python reference bit for bit with the split."""
from __future__ import annotations

import math

import pytest

from spurdiff.differential.locking import breakaway, locking_coefficients, pin_friction
from spurdiff.differential.params import DifferentialParams
from spurdiff.differential.rigid import RigidDifferential
from spurdiff.errors import ParameterError

MU_S, MU_D = 0.26, 0.13
T0 = 1000.0        # N m, total sun torque (drive)
TINY = 1e-15       # kg m^2: planet spin inertia negligible, so the planets' balances are the quasi-static law's


def _params(tiny: bool = True) -> DifferentialParams:
    J = {"J_planet1": TINY, "J_planet2": TINY} if tiny else {}
    return DifferentialParams(mu_pin=MU_S, mu_pinDynamic=MU_D, carrierDrive="speed", **J)


def _K(mu: float) -> float:
    p = DifferentialParams()
    return locking_coefficients(pin_friction(p.validate(), mu, p.r_collar))[0]


def _rigid(kernel: str, D: float) -> RigidDifferential:
    m = RigidDifferential(_params())
    m.kernel = kernel
    m.w_ref = 0.0                                  # carrier held: no speed loads, a_c = 0
    _load(m, D)
    m.initialize()
    return m


def _load(m, D: float) -> None:
    """Sun torques T0 in total, D apart (sun A the more loaded)."""
    m.tau_L, m.tau_R = -(T0 + D) / 2.0, -(T0 - D) / 2.0


def test_the_parameter_and_its_range():
    assert DifferentialParams().mu_pinDynamic == 0.0 and DifferentialParams().mu_sliding == DifferentialParams().mu_pin
    assert DifferentialParams(mu_pinDynamic=0.1).mu_sliding == 0.1
    for bad in (-0.01, 0.27, math.nan):
        with pytest.raises(ParameterError, match=r"mu_pinDynamic = .* allowed between 0 and mu_pin = 0.26"):
            DifferentialParams(mu_pinDynamic=bad).validate()


def test_one_coefficient_is_the_old_law():
    """mu_pinDynamic = 0 or = mu_pin: the sliding K is the break-away K, exactly."""
    for mu_d in (0.0, 0.26):
        m = RigidDifferential(DifferentialParams(mu_pinDynamic=mu_d))
        m.initialize()
        assert (m.K_slide, m.K_slide_coast) == (m.K, m.K_coast) and m.c_slide == m.pf.c


@pytest.mark.parametrize("kernel", ["python", "compiled"])
def test_rigid_breaks_away_at_mu_s_and_slips_at_mu_d(kernel):
    """Held sun torques: stuck at 0.999 K_s T0, break-away at 1.001 K_s T0 (K_s: the hand law with
    mu_s); then the locking while slipping is the hand law with mu_d on the sun torques the meshes
    carry, to rounding; the model's K and K_slide are those of the hand law."""
    Ks, Kd = _K(MU_S), _K(MU_D)
    m = _rigid(kernel, 0.999 * Ks * T0)
    if kernel == "compiled" and m._rk is None:
        pytest.skip("no compiled rigid kernel here")
    assert (m.K, m.K_slide) == (pytest.approx(Ks, rel=1e-12), pytest.approx(Kd, rel=1e-12))
    for k in range(20):
        m.do_step(k * 1e-3, 1e-3)
    assert m.stuck and m.wd == 0.0 and m.n_mode_switches == 0
    _load(m, 1.001 * Ks * T0)
    pf_d = pin_friction(m.geometry, MU_D, m.params.r_collar)
    for k in range(20, 40):
        m.do_step(k * 1e-3, 1e-3)
        TA, TB = m.tau_mesh_L, m.tau_mesh_R
        hand = breakaway(pf_d, TA + TB, m.slip_dir)          # the hand law at these sun torques, mu_d
        assert abs(TA - TB) / abs(TA + TB) == pytest.approx(hand.K, rel=1e-9)
        assert abs(m.locking_torque) == pytest.approx(hand.K * abs(TA + TB), rel=1e-9)
        assert m.locking_capacity == abs(m.locking_torque)  # the limit of the present mode: sliding
    assert m.slip_dir != 0.0 and m.n_mode_switches == 1
    # the jump: the locking falls from the break-away torque to the sliding one (about Kd/Ks of it)
    assert abs(m.locking_torque) < 0.6 * Ks * T0


@pytest.mark.parametrize("kernel", ["python", "compiled"])
def test_rigid_hysteresis_no_chattering(kernel):
    """Slipping, a torque difference between the sliding and the break-away torque keeps it
    slipping (it accelerates); below the sliding torque it slows down, re-sticks once at mu_s
    and stays stuck: exactly one mode switch each way, none more."""
    Ks, Kd = _K(MU_S), _K(MU_D)
    m = _rigid(kernel, 0.0)
    if kernel == "compiled" and m._rk is None:
        pytest.skip("no compiled rigid kernel here")
    _load(m, 1.01 * Ks * T0)
    m.do_step(0.0, 1e-3)
    assert m.slip_dir != 0.0 and m.n_mode_switches == 1
    D = 0.5 * (Ks + Kd) * T0                       # between the two: keeps slipping
    _load(m, D)
    w0 = abs(m.wd)
    for k in range(1, 50):
        m.do_step(k * 1e-3, 1e-3)
    assert m.slip_dir != 0.0 and abs(m.wd) > w0 and m.n_mode_switches == 1
    D = 0.5 * Kd * T0                              # below the sliding torque: slows, re-sticks
    m.tau_L, m.tau_R = -(T0 + D) / 2.0, -(T0 - D) / 2.0
    for k in range(50, 2000):
        m.do_step(k * 1e-3, 1e-3)
        if m.stuck:
            break
    assert m.stuck and m.n_mode_switches == 2
    for k in range(k + 1, k + 200):
        m.do_step(k * 1e-3, 1e-3)
    assert m.stuck and m.wd == 0.0 and m.n_mode_switches == 2
    # stuck, the break-away value holds up to mu_s again: 0.99 K_s holds, 1.01 breaks away
    D = 0.99 * Ks * T0
    m.tau_L, m.tau_R = -(T0 + D) / 2.0, -(T0 - D) / 2.0
    m.do_step(5.0, 1e-3)
    assert m.stuck and m.n_mode_switches == 2


def test_rigid_paper_law_split():
    """lockingLaw = paper: capacity K_s |T0| stuck, K_d |T0| slipping (the paper's K with mu_d)."""
    p = DifferentialParams(mu_pin=MU_S, mu_pinDynamic=MU_D, lockingLaw="paper", carrierDrive="speed")
    m = RigidDifferential(p)
    m.w_ref = 0.0
    m.initialize()
    assert m.K_slide == pytest.approx(m.K * MU_D / MU_S, rel=1e-14)
    for frac, stuck in ((0.999, True), (1.001, False)):
        m = RigidDifferential(p)
        m.w_ref = 0.0
        m.initialize()
        D = frac * m.K * T0
        m.tau_L, m.tau_R = -(T0 + D) / 2.0, -(T0 - D) / 2.0
        for k in range(10):
            m.do_step(k * 1e-3, 1e-3)
        assert m.stuck == stuck
    TA, TB = m.tau_mesh_L, m.tau_mesh_R
    assert abs(m.locking_torque) == pytest.approx(m.K_slide * abs(TA + TB), rel=1e-12)
    assert m.locking_capacity == pytest.approx(abs(m.locking_torque), rel=1e-12)


# ------------------------------------------------------------------ the mesh levels
def _mesh(kernel: str, level: str, D: float, wd0: float = 0.0):
    """The mesh levels with the planets' own inertia (the stick-slip of planets of no inertia on
    mesh springs is a stiff toggle that says nothing about the split)."""
    from spurdiff.differential.mesh import MeshDifferential, MeshParams

    m = MeshDifferential(_params(tiny=False), MeshParams(level=level, kernel=kernel))
    m.w_ref = 0.0
    m.w_start_left = wd0
    _load(m, D)
    m.initialize()
    return m


def _pins(m):
    """|F_pin,i| from the outputs' mesh forces (the layout's pin force; carrier at rest: no speed loads)."""
    f = m.mesh_forces
    lay = m._pf.layout
    return lay.pin_force(0, f.F_A1, f.F_12)[0], lay.pin_force(1, f.F_B2, f.F_12)[0]


@pytest.mark.parametrize("level", ["compliant", "contact"])
def test_mesh_levels_break_away_at_mu_s_and_slip_at_mu_d(level):
    """Stuck at 0.99 K_s T0, break-away at 1.01 K_s T0; once both planets slip, the locking
    torque is n sum_i |rho_i| mu_d r_d |F_pin,i| of the meshes' forces (to rounding) while the
    static capacity at the same pin loads would be mu_s / mu_d times it."""
    Ks = _K(MU_S)
    m = _mesh("python", level, 0.99 * Ks * T0)
    for k in range(30):
        m.do_step(k * 1e-3, 1e-3)
    assert m.stuck
    m = _mesh("python", level, 1.01 * Ks * T0)
    r = m.params.r_collar
    seen = 0
    for k in range(40):
        m.do_step(k * 1e-3, 1e-3)
        if m.planet_modes[0] != 0 and m.planet_modes[1] != 0:
            p1, p2 = _pins(m)
            n = m.n
            sliding = n * (abs(m.rho1) * MU_D * r * p1 + abs(m.rho2) * MU_D * r * p2)
            assert abs(m.locking_torque) == pytest.approx(sliding, rel=1e-12)
            assert m.locking_capacity == pytest.approx(sliding, rel=1e-12)
            seen += 1
    assert seen > 20 and not m.stuck


def test_mesh_re_stick_uses_mu_s():
    """Started slipping below the sliding torque, the compliant level slows down, its planets
    re-stick (at the static capacity) and stay stuck: the mode switches stop (no chattering)."""
    Kd = _K(MU_D)
    m = _mesh("python", "compliant", 0.5 * Kd * T0, 0.5)
    assert m.planet_modes[0] != 0 and m.planet_modes[1] != 0
    for k in range(400):
        m.do_step(k * 1e-3, 1e-3)
        if m.stuck:
            break
    assert m.stuck
    switches = m.n_mode_switches
    for k in range(k + 1, k + 300):
        m.do_step(k * 1e-3, 1e-3)
    assert m.stuck and m.n_mode_switches == switches and m.wd == pytest.approx(0.0, abs=1e-12)


def test_mesh_kernel_agrees_with_the_reference_with_the_split():
    from spurdiff.differential.mesh import kernel as mk

    if mk.load()[0] is None:
        pytest.skip("no compiled mesh kernel here")
    Ks = _K(MU_S)
    runs = {}
    for kernel in ("compiled", "python"):
        m = _mesh(kernel, "compliant", 1.01 * Ks * T0)
        assert m.kernel_in_use.startswith(kernel)
        out = []
        for k in range(60):
            if k == 30:                            # back below the sliding torque: re-stick
                D = 0.3 * Ks * T0
                m.tau_L, m.tau_R = -(T0 + D) / 2.0, -(T0 - D) / 2.0
            m.do_step(k * 1e-3, 1e-3)
            out.append((m.wd, m.locking_torque, m.locking_capacity, m.mesh_forces.F_12, tuple(m.planet_modes)))
        runs[kernel] = out
    assert runs["compiled"] == runs["python"]
    assert any(o[4] != (0, 0) for o in runs["python"])
