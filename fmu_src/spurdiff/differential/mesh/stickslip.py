"""Pin-friction modes of the two planets (exact stick, event based): the mode decision at a
state, the inelastic impulse that zeroes a planet's slip speed, and the consistent start (initial
state of the model: the rigid model's motion, the meshes statically preloaded or unloaded)."""
from __future__ import annotations

import math

from spurdiff.numerics import solve_system
from spurdiff.differential.rigid import RigidDifferential
from spurdiff.differential.mesh.events import STICK_RTOL, contact_flags
from spurdiff.differential.mesh.forces import evaluate
from spurdiff.differential.mesh.layout import D12, DA, DB, VA, VB, W1, W2, WC


def settle_modes(c, y, zeroed) -> int:
    """Decide the friction modes at a state (after zeroing the planets in ``zeroed``): stuck
    planets whose required friction exceeds the capacity break away in the direction of the
    excess. Returns the number of mode changes; leaves f0, J and the side values evaluated at y
    (``c._f0``, ``c._integ.J``, ``c._sv``)."""
    before = list(c.s)
    for i in zeroed:
        c.s[i] = 0
    for _ in range(4):
        sv = c._sv = evaluate(c, y, c._f0, c._integ.J)
        c._jac_age, c._integ.lu_h = 0, 0.0
        c.n_jacobians += 1
        changed = False
        for i in (0, 1):
            if c.s[i] == 0:
                Mreq, cap = (sv.M_2, sv.cap_2) if i else (sv.M_1, sv.cap_1)
                if abs(Mreq) > cap * (1.0 + STICK_RTOL):
                    c.s[i] = -1 if Mreq > 0.0 else 1
                    changed = True
        if not changed:
            break
    return sum(1 for a, b in zip(before, c.s) if a != b)


def slip_speed_reached_zero(c, y, f1, i: int) -> bool:
    """A slipping planet's speed reached zero, or decays towards it below the resolution of the
    integrator (overdamped approach to the capacity limit): try to stick."""
    s = c.s[i]
    idx = W1 if i == 0 else W2
    w = float(y[idx])
    return s != 0 and (s * w <= 0.0 or (abs(w) <= c._w_stick and s * f1[idx] < 0.0))


def stick_impulse(c, y, i: int, wc: float) -> None:
    """Set planet i's slip speed to exactly zero (it re-sticks). The friction impulse that does it
    is inelastic: the kinetic energy it removes is booked as loss, the drive's impulsive work
    (speed drive) as work in."""
    idx = W1 if i == 0 else W2
    w = float(y[idx])
    if w == 0.0:
        return
    nJ = c.n * (c.J1 if i == 0 else c.J2)
    if c.speed_drive:
        c.work_in += -nJ * wc * w
        c.energy_loss += 0.5 * nJ * w * w
        y[idx] = 0.0
        return
    # torque drive: impulse p on w_i with the carrier free: dv = M^-1 e_i p, w_i -> 0,
    # loss 1/2 w^2 / (M^-1)_ii
    k = 3 + i
    col = [row[k] for row in c._Minv]
    q = w / col[k]
    v = [yv - cv * q for yv, cv in zip((y[WC], y[VA], y[VB], y[W1], y[W2]), col)]
    c.energy_loss += 0.5 * w * w / col[k]
    y[WC], y[VA], y[VB], y[W1], y[W2] = v
    y[idx] = 0.0


def initial_forces(c, ac: float, ad: float, slip_dir: float, wd0: float):
    """Mesh forces consistent with the rigid motion at t0 (deflection rates and their
    accelerations zero): stuck planets share the friction in proportion to their capacity (equal
    utilisation); otherwise the slipping (or frictionless) motion is solved for. Sets the modes
    ``c.s`` of a slipping start; returns (F_A1, F_B2, F_12, carrier acceleration)."""
    n, JA, JB, J1, J2 = c.n, c.JA, c.JB, c.J1, c.J2
    rbA, rbB, rb1, rb2 = c.rbA, c.rbB, c.rb1, c.rb2
    tL, tR = c.tau_L, c.tau_R
    pin_force = c._pin_force
    if c._pin and slip_dir == 0.0 and wd0 == 0.0:
        FA = (JA * ac - tL) / (n * rbA)
        FB = (JB * ac - tR) / (n * rbB)
        F12 = 0.5 * (FA + FB)
        a1, a2 = J1 * ac - rb1 * FA, J2 * ac - rb2 * FB
        for _ in range(6):
            cap1 = c.c_pin * pin_force(0, FA, F12)[0] + c._M01
            cap2 = c.c_pin * pin_force(1, FB, F12)[0] + c._M02
            if cap1 + cap2 <= 0.0:
                cap1 = cap2 = 1.0
            F12 = -(cap2 * a1 + cap1 * a2) / (cap2 * rb1 + cap1 * rb2)
        M1, M2 = a1 + rb1 * F12, a2 + rb2 * F12
        cap1 = c.c_pin * pin_force(0, FA, F12)[0] + c._M01
        cap2 = c.c_pin * pin_force(1, FB, F12)[0] + c._M02
        if abs(M1) <= cap1 * (1 + 1e-9) and abs(M2) <= cap2 * (1 + 1e-9):
            return FA, FB, F12, ac
        slip_dir = -math.copysign(1.0, c.rho1 * M1 + c.rho2 * M2)
    sd = slip_dir if slip_dir != 0.0 else (math.copysign(1.0, wd0) if wd0 != 0.0 else 1.0)
    s1 = math.copysign(1.0, c.rho1) * sd if c._pin else 0.0
    s2 = math.copysign(1.0, c.rho2) * sd if c._pin else 0.0
    cp = c.c_pin_slide if c._pin else 0.0      # slipping: the sliding lever (mu_pinDynamic)
    speed = c.speed_drive

    def res(x):
        F12, add = x[0], x[1]
        acc = ac if speed else x[2]
        FA = (JA * (acc + add) - tL) / (n * rbA)
        FB = (JB * (acc + c.lam * add) - tR) / (n * rbB)
        M1 = -s1 * (cp * pin_force(0, FA, F12)[0] + (c._M01 if c._pin else 0.0))
        M2 = -s2 * (cp * pin_force(1, FB, F12)[0] + (c._M02 if c._pin else 0.0))
        Q1, Q2 = J1 * (acc + c.rho1 * add), J2 * (acc + c.rho2 * add)
        r = [Q1 - (rb1 * (FA - F12) + M1), Q2 - (rb2 * (FB - F12) + M2)]
        if not speed:
            r.append(c.Jc * acc - (c.tau_c - (n * rbA * FA + n * rbB * FB + n * Q1 + n * Q2)))
        return r

    F0 = -(tL + tR) / (n * (rbA + rbB))
    x0 = [F0, ad] + ([] if speed else [ac])
    sol = solve_system(res, x0, xtol=1e-13).x
    if not all(math.isfinite(v) for v in sol):
        sol = x0  # no consistent start found: start from the rigid estimate (a short transient)
    F12, add = float(sol[0]), float(sol[1])
    acc = ac if speed else float(sol[2])
    FA = (JA * (acc + add) - tL) / (n * rbA)
    FB = (JB * (acc + c.lam * add) - tR) / (n * rbB)
    c.s = [int(s1), int(s2)]
    return FA, FB, F12, acc


def initial_state(c, t0: float) -> None:
    """Everything at the rigid model's start speeds, the meshes statically preloaded with the
    forces consistent with the motion at t0 (or unloaded, centred in the backlash, with
    ``preload = False``); bookkeeping zeroed, friction modes decided, outputs computed."""
    rig = RigidDifferential(c.params)
    rig.w_ref, rig.tau_c, rig.tau_L, rig.tau_R = c.w_ref, c.tau_c, c.tau_L, c.tau_R
    rig.w_start_carrier, rig.w_start_left = c.w_start_carrier, c.w_start_left
    rig.initialize(t0)
    wc0, wd0 = rig.wc, rig.wd
    c.t = float(t0)
    c.wc = float(wc0)
    c.phic = 0.0
    c._ac = 0.0
    y = c.y
    y[:] = [0.0] * len(y)
    y[VA], y[VB], y[W1], y[W2] = wd0, c.lam * wd0, c.rho1 * wd0, c.rho2 * wd0
    if not c.speed_drive:
        y[WC] = wc0
    ac = 0.0 if c.speed_drive else rig.ac
    c._set_speed_loads(float(wc0), 0.0)     # the planets' centrifugal pin loads at the start speed
    c.s = [0, 0]
    FA, FB, F12, ac = initial_forces(c, ac, rig.ad, rig.slip_dir, wd0)
    preload = c.mesh.preload
    if not preload:
        FA = FB = F12 = 0.0
    for F, m in zip((FA, FB, F12), c.md):
        y[m.d] = static_deflection(c, m, F) if preload else -0.5 * m.jn
    c._dA0, c._dB0, c._d120 = float(y[DA]), float(y[DB]), float(y[D12])
    c.work_in = c.energy_loss = c.loss_last_step = c.parametric_work = 0.0
    c.n_mode_switches = c.n_contact_transitions = 0
    c.n_internal_steps = c.n_rejected_steps = c.n_steps = 0
    c.h_next = 1e-5
    c._jac_age, c._integ.lu_h = -1, 0.0       # no Jacobian yet (spurdiff.differential.mesh.stepper)
    c.n_jacobians = c._integ.n_factorizations = 0
    c._jac_dirty = True                       # (for the compiled kernel: set here)
    c._last_h = 0.0
    c._contact_flags = contact_flags(c, y)
    c._f0_key = None
    c._kernel_dirty = True
    if c._pin:
        settle_modes(c, y, ())
        c.n_mode_switches = 0
    c._refresh_outputs()


def static_deflection(c, m, F: float) -> float:
    """Deflection of mesh m under the normal force F per pair (its flank's stiffness factor at the
    start phase)."""
    kf = c.phase_obj.factor(m, m.xi0 if F >= 0.0 else m.xi0c)
    if F == 0.0:
        return 0.0 if m.jn == 0.0 else -0.5 * m.jn
    pen = c.law_obj.penetration(m, F, kf)
    return pen if F > 0.0 else -(m.jn + pen)
