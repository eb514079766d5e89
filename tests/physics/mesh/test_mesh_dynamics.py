"""Mesh dynamics (compliant / contact levels): paper cases, consistency with the rigid level,
convergence, energy, locking, backlash, mesh-phase effects, large steps, state, errors."""
import json
import math

import numpy as np
import pytest

from spurdiff.errors import ParameterError
from spurdiff.differential.mesh import MeshDifferential, MeshParams, N_PER_MM15
from spurdiff.differential.mesh.laws import friction_coefficient, impact, elasto_backlash, iso6336_stiffness, step
from spurdiff.differential.params import DifferentialParams
from spurdiff.differential.rigid import RigidDifferential, StepError

W0 = 1.389
STRAIGHT = (-1050.0, -1050.0)
CORNER = (-1110.201, -989.799)
F_THEORY = 6897.45  # N, normal force per pair at T0 = 2100 N m (statics, exact radii)
LEVELS = ("compliant", "contact")


def model(level="contact", loads=STRAIGHT, drive="speed", tau_c=0.0, w_left=float("nan"), law="pinFriction",
          locking_preload=0.0, **mesh):
    m = MeshDifferential(DifferentialParams(carrierDrive=drive, lockingLaw=law, lockingPreload=locking_preload),
                         MeshParams(level=level, **mesh))
    m.w_ref, m.tau_c = W0, tau_c
    m.tau_L, m.tau_R = loads
    m.w_start_carrier = W0
    m.w_start_left = w_left
    m.initialize()
    return m


def outputs(m):
    f = m.mesh_forces
    return np.array([m.tau_drive, m.tau_mesh_L, m.tau_mesh_R, f.F_A1, f.F_B2, f.F_12, m.w_L, m.w_R])


def run(m, t_end=0.3, h=1e-3, t0=0.0, events=None):
    """Step to t_end; returns the sampled outputs (rows: t = t0, t0 + h, ...)."""
    n = int(round((t_end - t0) / h))
    rows = [outputs(m)]
    for k in range(n):
        if events and k in events:
            events[k](m)
        m.do_step(t0 + k * h, h)
        rows.append(outputs(m))
    return np.array(rows)


def means(rows, h):
    """Time averages (trapezoidal rule), as the harness computes them."""
    return np.trapezoid(rows, dx=h, axis=0) / (h * (len(rows) - 1))


def energy_balance(m, e0):
    """work in - (change of kinetic + elastic energy) - loss (+ parametric work of the stiffness wave)."""
    return m.work_in + m.parametric_work - (m.kinetic_energy + m.potential_energy - e0) - m.energy_loss


# ------------------------------------------------------------------ the paper's two cases
@pytest.mark.parametrize("level", LEVELS)
def test_paper_straight_meets_targets_and_matches_rigid(level):
    m = model(level)
    rows = run(m)
    mean = means(rows, 1e-3)
    # targets: within ADAMS's errors vs theory (0.34 / 0.57 / 1.63 %), mesh forces within 2 %
    assert abs(mean[0] / 2100.0 - 1.0) < 0.0034
    assert abs(mean[1] / 1050.0 - 1.0) < 0.0057
    assert abs(mean[2] / 1050.0 - 1.0) < 0.0163
    for F in mean[3:6]:
        assert abs(F / F_THEORY - 1.0) < 0.02
    # both suns at the carrier speed
    assert np.allclose(rows[:, 6:8], W0, rtol=1e-9)
    # consistency with the rigid level in this quasi-static case
    r = RigidDifferential(DifferentialParams())
    r.w_ref, r.tau_L, r.tau_R = W0, *STRAIGHT
    r.initialize()
    rrows = []
    for k in range(300):
        r.do_step(k * 1e-3, 1e-3)
        f = r.mesh_forces
        rrows.append([r.tau_drive, r.tau_mesh_L, r.tau_mesh_R, f.F_A1, f.F_B2, f.F_12])
    assert mean[:6] == pytest.approx(np.mean(rrows, axis=0), rel=1e-6)
    assert m.stuck and m.n_mode_switches == 0


@pytest.mark.parametrize("level", LEVELS)
def test_paper_cornering_slips_like_the_rigid_level(level):
    # the paper's law (as its scene selects): the loads differ by twice its K T0
    m = model(level, CORNER, law="paper")
    rows = run(m)
    mean = means(rows, 1e-3)
    r = RigidDifferential(DifferentialParams(lockingLaw="paper"))
    r.w_ref, r.tau_L, r.tau_R = W0, *CORNER
    r.initialize()
    rrows = [[r.tau_drive, r.tau_mesh_L, r.tau_mesh_R]]
    for k in range(300):
        r.do_step(k * 1e-3, 1e-3)
        rrows.append([r.tau_drive, r.tau_mesh_L, r.tau_mesh_R])
    rmean = means(np.array(rrows), 1e-3)
    # the load difference is twice the locking capacity: the differential slips, sun A (more
    # load) runs backwards, sun B races ahead, w_A + w_B = 2 w_c up to the mesh deflection rates
    assert m.planet_modes == (1, -1) and not m.stuck
    assert m.w_L < -1000.0 and m.w_R > 1000.0
    assert m.w_L + m.w_R == pytest.approx(2 * W0, abs=1e-6)
    assert m.w_L == pytest.approx(r.w_L, rel=0.01)
    # the friction works at its (load-dependent) capacity
    assert m.locking_torque == pytest.approx(m.locking_capacity, rel=1e-9)
    assert m.locking_capacity == pytest.approx(m.K * (m.tau_mesh_L + m.tau_mesh_R), rel=0.02)
    # mean torques agree with the rigid level's to 0.1 %
    assert mean[:3] == pytest.approx(rmean, rel=1e-3)


# ------------------------------------------------------------------ convergence
def _transient_means(tol, h, t_end=0.1, level="contact", method="auto"):
    m = model(level, preload=False, tolerance=tol, method=method)  # unloaded meshes: a real transient
    return means(run(m, t_end, h), h)[:6]


@pytest.mark.parametrize("method", ["ros34pw2", "rodas5p"])
def test_contact_means_converge_with_tolerance(method):
    ref = _transient_means(1e-10, 1e-3, method=method)
    errs = [np.max(np.abs(_transient_means(tol, 1e-3, method=method) - ref) / np.abs(ref))
            for tol in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7)]
    if method == "ros34pw2":
        assert all(b < a for a, b in zip(errs, errs[1:])), errs
        assert errs[-1] < 1e-8
    else:
        # RODAS5P (the contact level's default): every tolerance below 1e-3 gives a smaller error,
        # each two decades of tolerance a smaller one again, and 1e-7 reaches 4.9e-11. Not decade
        # by decade: since issue 41 (the pins' end reactions, mesh B2's width) the mean of F_12
        # carries planet 2's brief slip at the unloaded start (re-stuck at the end of an accepted
        # step, not at a located root) and at 1e-4 falls to 1.7e-11 by a cancellation (1.4e-9 at
        # 1e-5; the drive torque and sun B's mesh stay monotone, sun A's sits at 1e-11). The reference is converged
        # (1e-11 and 1e-12 give the same errors to 2 digits).
        assert all(e < errs[0] for e in errs[1:]), errs
        assert all(errs[k + 2] < errs[k] for k in range(3)), errs
        assert errs[4] < 1e-10, errs
    # the start transient matters: the means are not those of the preloaded start
    assert abs(ref[0] / 2100.0 - 1.0) > 1e-3


def test_contact_means_converge_as_the_step_shrinks():
    # the internal integration is adaptive; what changes with h is the sampling of the outputs,
    # whose trapezoidal mean converges (first order here: the outputs jump at the unloaded start)
    ref = _transient_means(1e-9, 1.25e-4)
    errs = [np.max(np.abs(_transient_means(1e-9, h) - ref)) for h in (4e-3, 2e-3, 1e-3)]
    orders = [math.log2(a / b) for a, b in zip(errs, errs[1:])]
    assert all(0.8 < p < 1.5 for p in orders), (errs, orders)


# ------------------------------------------------------------------ energy
def test_compliant_level_conserves_energy_without_dissipation():
    # dissipation off: no mesh damping, no pin or flank friction. A 10 % load step from the
    # preloaded state leaves the mesh modes (several kHz) ringing undamped for 0.3 s.
    m = model("compliant", dampingRatio=0.0, pinFriction=False, tolerance=1e-5)
    assert m.active_effects == ("compliant",)
    e0 = m.kinetic_energy + m.potential_energy
    m.tau_L = m.tau_R = -1155.0
    worst = 0.0
    force = []
    for k in range(300):
        m.do_step(k * 1e-3, 1e-3)
        worst = max(worst, abs(energy_balance(m, e0)))
        force.append(m.mesh_forces.F_A1)
    assert m.energy_loss == 0.0
    assert np.ptp(force[-50:]) > 200.0      # N: still ringing at the end (step: 690 N per mesh)
    assert worst < 1e-3                     # J: < 1 % of the step's work, 0.1 % of the stored 0.8 J


def test_free_differential_conserves_energy_while_spinning_up():
    # cornering loads, no friction, no damping: 95 kJ of work go into kinetic energy
    m = model("compliant", CORNER, dampingRatio=0.0, pinFriction=False)
    e0 = m.kinetic_energy + m.potential_energy
    run(m)
    assert m.work_in > 9e4
    assert abs(energy_balance(m, e0)) < 1e-8 * m.work_in


def test_loss_never_decreases_and_balances():
    m = model("compliant", backlash=True, flankFriction=True)
    e0 = m.kinetic_energy + m.potential_energy
    losses = []

    def reverse(mm):
        mm.tau_L, mm.tau_R = 1050.0, 1000.0

    for k in range(150):
        if k == 30:
            reverse(m)
        m.do_step(k * 1e-3, 1e-3)
        losses.append(m.energy_loss)
        assert m.power_loss >= 0.0
    assert np.all(np.diff(losses) >= 0.0)
    assert losses[-1] > 1.0
    assert abs(energy_balance(m, e0)) < 1e-4 * losses[-1]


# ------------------------------------------------------------------ pin friction (locking)
def _loads(sign: float, dirn: float, D: float) -> tuple[float, float]:
    return -1050.0 * sign - dirn * D / 2, -1050.0 * sign + dirn * D / 2


def _breakaway(m, sign: float, dirn: float, D0: float, dstep: float, n: int = 400) -> float:
    """Ramp the sun-load difference from D0 (the model starts statically loaded with it) in
    steps of dstep (1 ms each) until the differential breaks away (rigid: relative motion;
    mesh levels: both planets slip)."""
    for k in range(n):
        D = D0 + dstep * k
        m.tau_L, m.tau_R = _loads(sign, dirn, D)
        m.do_step(k * 1e-3, 1e-3)
        moving = m.wd != 0.0 if isinstance(m, RigidDifferential) else 0 not in m.planet_modes
        if moving:
            return D
    raise AssertionError("no break-away")


@pytest.mark.parametrize("sign,dirn", [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)],
                         ids=["drive-A-loaded", "drive-B-loaded", "coast-A-loaded", "coast-B-loaded"])
def test_rigid_and_contact_break_away_together_in_drive_and_coast(sign, dirn):
    # the pin-load law, mu and r_d as given: the rigid level (closed-form pin loads from the sun
    # torques) and the contact level (pin loads from its mesh forces) break away within 0.5 %
    # of each other and of the quasi-static K T0 (drive: K, coast: K_coast); ramp resolution 0.1 %
    ref = model("contact")
    # K of the direction it breaks away in (issue 41: with planet 2's pin couple the leading sun
    # matters, 0.7 % in drive): the more loaded sun falls behind, the other one leads
    from spurdiff.differential.locking import locking_coefficients
    K = locking_coefficients(ref._pf, "B" if dirn > 0 else "A")[0 if sign > 0 else 1]
    assert K >= (ref.K if sign > 0 else ref.K_coast)
    KT0 = K * 2100.0
    D0 = 0.97 * KT0
    c = model("contact", _loads(sign, dirn, D0))
    r = RigidDifferential(DifferentialParams())
    r.w_ref, (r.tau_L, r.tau_R) = W0, _loads(sign, dirn, D0)
    r.initialize()
    Dc = _breakaway(c, sign, dirn, D0, 1e-3 * KT0)
    Dr = _breakaway(r, sign, dirn, D0, 1e-3 * KT0)
    assert abs(Dc / Dr - 1.0) < 5e-3
    assert abs(Dr / KT0 - 1.0) < 5e-3
    assert (c.K, c.K_coast) == (r.K, r.K_coast)
    # drive and coast differ (the pins are loaded differently), both far above the paper's K; with
    # planet 2's pin couple (issue 41, end reactions) drive is the larger: 0.2326 against 0.2182
    assert c.K > 1.05 * c.K_coast > 6 * c.K_paper


@pytest.mark.parametrize("level", LEVELS)
def test_paper_law_breaks_away_at_the_papers_K_in_drive_and_19_percent_higher_in_coast(level):
    # the paper's law at the mesh levels: the pin lever is scaled to its K in drive; the pin
    # loads then give a larger coast capacity, while the rigid level keeps K in both
    m = model(level, law="paper")
    KT0 = m.K * 2100.0
    assert m.locking_capacity == pytest.approx(KT0, rel=1e-12)
    m = model(level, _loads(1.0, 1.0, 0.98 * KT0), law="paper")
    assert _breakaway(m, 1.0, 1.0, 0.98 * KT0, 1e-3 * KT0) == pytest.approx(KT0, rel=3e-3)
    m = model(level, _loads(-1.0, 1.0, 1.17 * KT0), law="paper")
    D = _breakaway(m, -1.0, 1.0, 1.17 * KT0, 1e-3 * KT0)
    assert D / KT0 == pytest.approx(1.189, rel=3e-3)   # the review: 71.0 against 59.5 N m


@pytest.mark.parametrize("level", LEVELS)
def test_quasi_static_locking_reproduces_K(level):
    m = model(level, law="paper")
    KT0 = m.K * 2100.0
    assert m.locking_capacity == pytest.approx(KT0, rel=1e-12)
    # ramp the load difference slowly: the differential breaks away (both planets slip) at K T0
    dstep = 0.002 * KT0
    for k in range(2000):
        D = dstep * k
        m.tau_L, m.tau_R = -1050.0 - D / 2, -1050.0 + D / 2
        m.do_step(k * 1e-3, 1e-3)
        if 0 not in m.planet_modes:
            break
    assert D == pytest.approx(KT0, abs=2 * dstep)


@pytest.mark.parametrize("level", LEVELS)
def test_stick_below_capacity_is_exact(level):
    # difference 0.9 K T0, the meshes preloaded with it: the planets do not move at all (exact
    # stuck mode, not creep), the friction holds the difference
    D = 0.9 * model(level).K * 2100.0
    loads = (-1050.0 - D / 2, -1050.0 + D / 2)
    m = model(level, loads)
    for k in range(300):
        m.do_step(k * 1e-3, 1e-3)
        assert m.y[6] == 0.0 and m.y[7] == 0.0
    assert m.stuck and m.n_mode_switches == 0
    # the suns only see the rounding of the static deflections (F = K d^e inverted)
    assert m.w_L == pytest.approx(W0, abs=1e-12) and m.w_R == pytest.approx(W0, abs=1e-12)
    assert m.locking_torque == pytest.approx(D, rel=1e-9)
    assert abs(m.locking_torque) <= m.locking_capacity
    # the same difference applied as a step to the preloaded straight state: the weaker planet
    # (smaller pin force) slips while the load redistributes, then both stick for good
    m = model(level)
    m.tau_L, m.tau_R = loads
    run(m, 0.1)
    n_sw = m.n_mode_switches
    assert m.stuck and 0 < n_sw <= 20
    for k in range(200):
        m.do_step(0.1 + k * 1e-3, 1e-3)
        assert m.y[6] == 0.0 and m.y[7] == 0.0
    assert m.n_mode_switches == n_sw
    assert m.locking_torque == pytest.approx(D, rel=1e-6)


# ------------------------------------------------------------------ backlash
@pytest.mark.parametrize("level", LEVELS)
def test_backlash_torque_reversal(level):
    m = model(level, backlash=True)
    e0 = m.kinetic_energy + m.potential_energy
    ct, fmax = [], 0.0

    def reverse(mm):
        mm.tau_L = mm.tau_R = 1050.0

    rows = run(m, 0.3, 1e-3, events={50: reverse})
    fmax = np.max(np.abs(rows[:, 3:6]))
    assert np.all(np.isfinite(rows))
    # every mesh lost its drive flank and engaged its coast flank (>= 2 transitions per mesh) ...
    assert m.n_contact_transitions >= 6
    # ... without chattering: a bounded number of impacts, then at rest on the coast flanks
    assert m.n_contact_transitions <= 60
    assert rows[-1, 3:5] == pytest.approx([-F_THEORY] * 2, rel=1e-5)
    assert rows[-1, 0] == pytest.approx(-2100.0, rel=1e-6)
    # the planet-planet force differs from the others by what the stuck pins hold
    if m.stuck:
        assert abs(rows[-1, 5] + F_THEORY) * m.rb1 <= max(m._out[9], m._out[10]) * (1 + 1e-6) + 1e-3
    else:
        assert rows[-1, 5] == pytest.approx(-F_THEORY, rel=1e-5)
    # bounded impacts: peak below three times the static force
    assert fmax < 3.0 * F_THEORY
    assert abs(energy_balance(m, e0)) < 1e-4 * m.energy_loss
    # no contact transition and no stick/slip switch in the last 0.15 s (no chattering)
    n_ct, n_sw = m.n_contact_transitions, m.n_mode_switches
    assert n_sw <= 150
    run(m, 0.45, 1e-3, t0=0.3)
    assert m.n_contact_transitions == n_ct and m.n_mode_switches == n_sw


def test_contact_never_pulls_and_damping_is_zero_at_first_touch():
    K = 3.9e5 * N_PER_MM15
    F, dFp, dFv, Fc = impact(1e-12, 10.0, K, 1.5, 50e3, 1e-4)   # first touch at 10 m/s
    assert Fc == pytest.approx(K * 1e-18) and F - Fc < 1e-9      # damping ~ STEP = 3e-16 C: none
    assert dFv == pytest.approx(50e3 * 3e-16, rel=1e-6)
    assert impact(5e-5, -10.0, K, 1.5, 50e3, 1e-4)[0] == 0.0       # fast separation: no pull
    assert impact(-1e-6, 1.0, K, 1.5, 50e3, 1e-4) == (0.0, 0.0, 0.0, 0.0)
    # ElastoBacklash: damping limited to the spring force at contact onset, never pulls
    F, _, _, Fc = elasto_backlash(1e-6, 100.0, 3e8, 1e4)
    assert F == pytest.approx(2 * Fc)
    assert elasto_backlash(1e-6, -100.0, 3e8, 1e4)[0] == 0.0
    assert step(0.05, 0.0, 0.0, 0.1, 1.0) == pytest.approx(0.5)


# ------------------------------------------------------------------ mesh-phase effects
def test_mesh_stiffness_wave_follows_the_contact_ratio():
    # the differential turns slowly (1 rad/s relative, no friction, equal loads) for two mesh
    # periods of mesh A1: its deflection alternates between single contact (stiffness k / eps) and
    # double contact (2 k / eps); the switches ring briefly (damping ratio 0.2)
    m = model("compliant", w_left=W0 + 1.0, pinFriction=False, meshStiffnessVariation=True, dampingRatio=0.2)
    me = m.md[0]
    period = me.pb / (m.rbA * 1.0)
    h = 2e-4
    n = int(round(2 * period / h))
    dA = []
    for k in range(n):
        m.do_step(k * h, h)
        dA.append(m.y[1])
    dA = np.array(dA)
    single = me.eps * F_THEORY / me.k
    double = single / 2
    near_single = np.abs(dA / single - 1) < 0.01
    near_double = np.abs(dA / double - 1) < 0.01
    assert near_single.mean() + near_double.mean() > 0.9     # settled on the two levels
    frac_double = near_double.sum() / (near_single.sum() + near_double.sum())
    assert frac_double == pytest.approx(me.eps - 1.0, abs=0.03)
    # the wave keeps the mean stiffness: the factor averaged over one mesh period is 1
    xs = np.linspace(0.0, 1.0, 100001)[:-1]
    assert np.mean([m.phase_obj.factor(me, x) for x in xs]) == pytest.approx(1.0, rel=1e-4)


def test_flank_friction_loses_power_only_when_the_gears_roll():
    # straight line: the contact sits at the pitch point, no sliding, no effect on the means
    a, b = model("contact"), model("contact", flankFriction=True)
    ma, mb = means(run(a, 0.05), 1e-3), means(run(b, 0.05), 1e-3)
    assert mb[:3] == pytest.approx(ma[:3], rel=1e-9)
    assert b.energy_loss < 1e-9
    # cornering without pin friction: only the flanks dissipate; sliding friction brakes the slip
    c = model("contact", CORNER, pinFriction=False)
    d = model("contact", CORNER, pinFriction=False, flankFriction=True)
    e0 = d.kinetic_energy + d.potential_energy
    run(c, 0.03)
    run(d, 0.03)
    assert c.energy_loss < 1e-6 < 1.0 < d.energy_loss
    assert c.w_L < d.w_L < -100.0
    assert abs(energy_balance(d, e0)) < 1e-6 * d.energy_loss
    mu, dmu = friction_coefficient(0.0, 0.05, 0.03, 1e-4, 1e-2)
    assert mu == 0.0 and dmu > 0.0
    assert friction_coefficient(-1e-4, 0.05, 0.03, 1e-4, 1e-2)[0] == pytest.approx(-0.05)
    assert friction_coefficient(1.0, 0.05, 0.03, 1e-4, 1e-2)[0] == pytest.approx(0.03)


def test_iso6336_stiffness_of_mesh_A1():
    # planet 1 (pinion) z = 13, x = +0.3 with sun A z = 36, x = -1.0099, usable eps 1.575
    _, cg = iso6336_stiffness(36, -1.0099, 13, 0.3, 1.575, 2.06e11)
    assert cg == pytest.approx(15.4, rel=0.01)   # N/(mm um), model-references.md
    # the model feeds the usable contact ratio from the form circles (involute to tip): 1.515 for
    # A1 (sun A's tip stops at planet 1's form circle), 1.011 for B2 and 12 (planet 2 undercut)
    m = model("compliant")
    assert [round(md.eps, 3) for md in m.md] == [1.515, 1.011, 1.011]
    # times each mesh's face width, the axial overlap of its gears (issue 41): B2 17 mm (sun B 24 .. 46 mm,
    # planet 2 1 .. 41 mm in the paper set's assumed layout), A1 and 12 22 mm
    for md, (z1, x1, z2, x2), b in zip(m.md, ((36, -1.0099, 13, 0.3), (36, 1.2296, 13, -0.3), (13, 0.3, 13, -0.3)),
                                       (0.022, 0.017, 0.022)):
        _, c = iso6336_stiffness(z1, x1, z2, x2, md.eps, 2.06e11)
        assert md.k == pytest.approx(c * 1e9 * b, rel=1e-12)
    # the 0.9 factor of ISO 6336 for eps < 1.2 applies to B2 and 12 now
    assert iso6336_stiffness(36, 1.2296, 13, -0.3, 1.011, 2.06e11)[1] == pytest.approx(
        0.9 * iso6336_stiffness(36, 1.2296, 13, -0.3, 1.2, 2.06e11)[1] * (0.75 * 1.011 + 0.25) / (0.75 * 1.2 + 0.25))


# ------------------------------------------------------------------ numerics
@pytest.mark.parametrize("level", LEVELS)
def test_large_communication_steps_are_stable_and_accurate(level):
    def reverse(mm):
        mm.tau_L, mm.tau_R = 1050.0, 1040.0

    results = []
    for h in (1e-2, 1e-3):
        m = model(level, backlash=True, preload=False)
        rows = run(m, 0.3, h, events={int(round(0.1 / h)): reverse})
        assert np.all(np.isfinite(rows))
        results.append((rows[-1], m.energy_loss))
    (ra, la), (rb, lb) = results
    # all but F_12 (index 5) to 1e-4. The run ends stuck, and a stuck pair's F_12 is statically
    # indeterminate (anything inside both planets' friction intervals holds): it keeps the mesh-12
    # deflection of the moment the planets stuck, which depends on the step. Measured over h = 0.5 ..
    # 10 ms: a spread of 1.0e-4 with planar pins, 4.9e-4 with the end reactions (issue 41); held
    # to 1e-3 here
    keep = [0, 1, 2, 3, 4, 6, 7]
    assert ra[keep] == pytest.approx(rb[keep], rel=1e-4, abs=1e-6)
    assert ra[5] == pytest.approx(rb[5], rel=1e-3)
    assert la == pytest.approx(lb, rel=1e-4)


def test_tiny_communication_steps():
    m = model("contact", CORNER)
    rows = run(m, 2e-3, 1e-5)
    ref = model("contact", CORNER)
    run(ref, 2e-3, 1e-3)
    assert rows[-1] == pytest.approx(outputs(ref), rel=1e-6)


def test_rosenbrock_w_method_has_order_3_even_with_a_wrong_jacobian():
    from spurdiff.differential.mesh.integrator import RosenbrockW

    def f(y, out, J):  # oscillator driving a stiff component (eigenvalue -1e4)
        out[0], out[1], out[2] = -y[1], y[0], -1e4 * (y[2] - math.sin(y[0]))
        if J is not None:
            J[:] = 0.0
            J[0, 1], J[1, 0], J[2, 2], J[2, 0] = -1.0, 1.0, -1e4, 1e4 * math.cos(y[0])

    for wrong in (False, True):
        errs = []
        for n in (20, 40, 80, 160):
            r = RosenbrockW(3, f)
            y, h, f0 = np.array([1.0, 0.0, math.sin(1.0)]), 2.0 / n, np.zeros(3)
            for _ in range(n):
                f(y, f0, r.J)
                if wrong:
                    r.J[2, 0] = 0.0
                    r.J[0, 1] *= 0.5
                assert r.step(y, f0, h)
                y = r.y_new.copy()
            errs.append(np.max(np.abs(y[:2] - [math.cos(2.0), math.sin(2.0)])))
        orders = [math.log2(a / b) for a, b in zip(errs, errs[1:])]
        assert all(2.9 < p < 3.1 for p in orders), (wrong, orders)


def test_rodas5p_has_order_5_and_its_estimate_and_dense_output_order_4():
    """RODAS5P with the exact Jacobian (it is not a W-method) on the same problem: global order 5;
    over one step from the exact solution, the embedded estimate and the dense output at the
    midpoint and the quarter points have local errors of order 5 (methods of order 4)."""
    from spurdiff.differential.mesh.integrator import RODAS5P, RosenbrockW

    def f(y, out, J):
        out[0], out[1], out[2] = -y[1], y[0], -1e4 * (y[2] - math.sin(y[0]))
        if J is not None:
            J[:] = 0.0
            J[0, 1], J[1, 0], J[2, 2], J[2, 0] = -1.0, 1.0, -1e4, 1e4 * math.cos(y[0])

    errs = []
    for n in (5, 10, 20, 40):     # (at 80 steps the error, 1e-14, is rounding)
        r = RosenbrockW(3, f, RODAS5P)
        y, h, f0 = np.array([1.0, 0.0, math.sin(1.0)]), 2.0 / n, np.zeros(3)
        for _ in range(n):
            f(y, f0, r.J)
            assert r.step(y, f0, h)
            y = r.y_new.copy()
        errs.append(np.max(np.abs(y[:2] - [math.cos(2.0), math.sin(2.0)])))
    orders = [math.log2(a / b) for a, b in zip(errs, errs[1:])]
    assert all(4.7 < p < 6.5 for p in orders), orders     # (about 6 here: 6.0, 5.9, 5.9)
    est, dense = [], []
    for h in (0.2, 0.1, 0.05):
        r = RosenbrockW(3, f, RODAS5P)
        y, f0 = np.array([1.0, 0.0, math.sin(1.0)]), np.zeros(3)
        f(y, f0, r.J)
        assert r.step(y, f0, h)
        est.append(np.max(np.abs(r.err[:2])))
        exact = lambda th: np.array([math.cos(th * h), math.sin(th * h)])   # noqa: E731
        pts = [(0.5, r.midpoint(y)), (0.25, r.dense_at(RODAS5P.dquarter[0], y, np.zeros(3))),
               (0.75, r.dense_at(RODAS5P.dquarter[1], y, np.zeros(3)))]
        dense.append(max(np.max(np.abs(v[:2] - exact(th))) for th, v in pts))
    for e in (est, dense):
        rates = [math.log2(a / b) for a, b in zip(e, e[1:])]
        assert all(4.5 < p < 5.7 for p in rates), (e, rates)


def test_the_five_point_loss_quadrature_is_exact_to_degree_5_and_estimates_beyond_3():
    """loss_quadrature5 (RODAS5P's): Boole's rule, exact for polynomials of degree <= 5; its
    estimate |Simpson(halves) - Simpson| vanishes to degree 3 and not for degree 4."""
    from spurdiff.differential.mesh.stepper import E_REF, loss_quadrature5

    h = 0.37
    for deg in range(6):
        P = lambda t: 2.0 + sum((k + 1) * t ** k for k in range(1, deg + 1))   # noqa: E731
        exact = 2.0 * h + sum((k + 1) * h ** (k + 1) / (k + 1) for k in range(1, deg + 1))
        d, e = loss_quadrature5(P(0.0), P(h / 4), P(h / 2), P(3 * h / 4), P(h), h, 1e-6)
        assert d == pytest.approx(exact, rel=1e-13), deg
        assert (e < 1e-6) if deg <= 3 else (e > 1.0), (deg, e)
    assert E_REF > 0.0


def test_rhs_is_the_integrated_ode():
    # the same ODE integrated by scipy's Radau (analytic Jacobian) gives the same state
    from scipy.integrate import solve_ivp

    m = model("contact", preload=False, pinFriction=False, tolerance=1e-9)
    y0 = m.state_vector()
    sol = solve_ivp(m.rhs, (0.0, 0.02), y0, method="Radau", jac=m.jac, rtol=1e-10,
                    atol=1e-10 * np.array([1, 1e-5, 1e-5, 1e-5, 1, 1, 1, 1]))
    run(m, 0.02, 1e-3)
    scale = np.array([1, 1e-5, 1e-5, 1e-5, 1, 1, 1, 1])
    assert np.max(np.abs(m.state_vector() - sol.y[:, -1]) / scale) < 1e-6


def test_analytic_jacobian_matches_finite_differences():
    rng = np.random.default_rng(3)
    for drive in ("speed", "torque"):
        for mesh in (dict(level="compliant"), dict(level="contact", backlash=True)):
            mesh = dict(mesh)
            m = model(mesh.pop("level"), CORNER, drive, 2000.0, **mesh)
            for modes in ([0, 0], [1, -1], [0, 1]):
                m.s = modes
                y = m.state_vector()
                y[4:8] += rng.normal(0.0, 0.5, 4)
                y[1:4] *= 1.0 + rng.normal(0.0, 0.05, 3)
                y[6] = 0.0 if modes[0] == 0 else y[6]
                y[7] = 0.0 if modes[1] == 0 else y[7]
                J = m.jac(0.0, y)
                for j in range(len(y)):
                    e = np.zeros(len(y))
                    e[j] = 1e-7 * max(1e-4 if j in (1, 2, 3) else 1.0, abs(y[j]))
                    col = (m.rhs(0.0, y + e) - m.rhs(0.0, y - e)) / (2 * e[j])
                    assert J[:, j] == pytest.approx(col, rel=1e-5, abs=1e-6 * np.abs(J).max())


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


def test_the_integrators_lu_solves_with_partial_pivoting_and_refuses_a_singular_matrix():
    from spurdiff.differential.mesh.integrator import lu_factor, lu_solve

    rng = np.random.default_rng(3)
    for n in (1, 8, 10):
        A = rng.standard_normal((n, n))
        A[0, 0] = 0.0 if n > 1 else 2.0    # needs a row exchange
        b = rng.standard_normal(n)
        lu, piv = lu_factor(A.tolist())
        assert np.allclose(lu_solve(lu, piv, b.tolist()), np.linalg.solve(A, b), rtol=1e-10, atol=1e-12)
    S = np.ones((3, 3))
    assert lu_factor(S.tolist()) == (None, None)


def test_the_split_solve_of_w_is_the_solve_of_the_whole_matrix():
    """W = I/(gamma h) - J through the Schur complement on the velocities (integrator.split_factor,
    split_solve; the compiled kernel's solve) equals numpy's solve of the whole W, for the model's
    own Jacobian (the carrier's speed imposed; contact with flank friction) at step sizes from far
    below to far above the mesh period; the carrier free takes the general LU (no split); and
    Gauss-Jordan refuses a singular Schur complement."""
    from spurdiff.differential.mesh import MeshDifferential, MeshParams
    from spurdiff.differential.mesh.integrator import RODAS5P, gj_inverse, split_factor, split_solve
    from spurdiff.differential.mesh.layout import split
    from spurdiff.differential.params import DifferentialParams

    rng = np.random.default_rng(5)
    assert split(10) is None
    for drive in ("speed",):
        m = MeshDifferential(DifferentialParams(carrierDrive=drive),
                             MeshParams(level="contact", flankFriction=True, kernel="python"))
        m.w_ref = m.w_start_carrier = 20.0
        m.tau_c, m.tau_L, m.tau_R = 250.0, 150.0, 100.0
        m.initialize()
        N = m._N
        pos, vel = split(N)
        J = np.asarray(m.jac(0.0, m.state_vector()), dtype=float)
        assert np.all(J[np.ix_(pos, pos)] == 0.0)              # the split's premise: x_p' = B x_v
        assert np.count_nonzero(J[np.ix_(vel, pos)]) > 0 and np.count_nonzero(J[np.ix_(vel, vel)]) > 0
        for h in (1e-7, 1e-5, 1e-3, 1e-1, 10.0):
            e = RODAS5P.gamma * h
            F = split_factor(J.tolist(), e, pos, vel)
            W = np.eye(N) / e - J          # condition numbers 1e4 to 3e11 over these steps
            for _ in range(3):
                r = rng.standard_normal(N)
                x = np.array(split_solve(F, None, r.tolist()))
                xs = np.linalg.solve(W, r)
                # backward stable (normwise backward error at rounding level) and LAPACK's answer
                back = np.abs(W @ x - r).max() / (np.abs(W).max() * np.abs(x).max() + np.abs(r).max())
                assert back < 1e-15, (drive, h, back)
                assert np.abs(x - xs).max() <= 1e-12 * np.abs(xs).max(), (drive, h)
    assert gj_inverse([[1.0, 2.0], [2.0, 4.0]]) is None
    X = gj_inverse([[0.0, 2.0], [3.0, 1.0]])                     # a row exchange
    assert np.allclose(np.array(X) @ np.array([[0.0, 2.0], [3.0, 1.0]]), np.eye(2))


def test_the_dense_output_polynomial_is_the_tableaus_dense_output():
    """dpoly (the dense output's weights as a polynomial in theta, what the stepper and the kernel
    evaluate) gives the weights B(theta) Gamma^-1 of the tableau, for both methods."""
    from spurdiff.differential.mesh.integrator import METHODS, dense_weights

    for tr in METHODS.values():
        for th in (0.0, 0.1, 0.25, 0.5, 0.9, 1.0):
            d = sum(np.array(tr.dpoly[p]) * th ** (p + 1) for p in range(4))
            assert np.allclose(d, dense_weights(th, tr), rtol=1e-13, atol=1e-13), (tr.name, th)
        # at theta = 1 the dense output is the step's solution
        assert np.allclose(sum(np.array(tr.dpoly[p]) for p in range(4)), tr.m, rtol=1e-12, atol=1e-12), tr.name
