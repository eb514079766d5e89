"""The driver of the mesh model over one communication step, apart from the model and from the
method (as scipy's ``solve_ivp`` keeps its driver apart from its methods): internal steps of the
Rosenbrock method (:mod:`spurdiff.differential.mesh.integrator`: ROS34PW2 or RODAS5P) with error control of the state and of the
loss quadrature, events (:mod:`spurdiff.differential.mesh.events`), friction modes
(:mod:`spurdiff.differential.mesh.stickslip`) and the work accounting.

Per internal step: a trial step limited by the communication point and the next mesh-phase
boundary; rejected (smaller step) when the state error or the loss-quadrature error exceeds the
tolerance, or when an event lies inside it (the step is cut to land just past the event, up to
four times); accepted: work and loss booked, contact transitions counted, planets that reached
zero slip speed stuck, the friction modes decided again where needed.

The Jacobian and the factored W are reused (ROS34PW2 is a W-method: order 3, and its embedded
order 2, for any Jacobian; the W-order conditions hold to rounding; RODAS5P is not, and gets a new
Jacobian at the end of every accepted step): a new Jacobian is evaluated
at the end of a step only every JAC_AGE_MAX accepted steps, after an event was located in the
step or where a contact opened or closed in it, and at the start of a step that is retried after a
rejection; the friction modes' decision evaluates one too. The Jacobian depends on the state
only, so it serves on across communication steps with new inputs. W is factored again only when
the Jacobian or the step size changed, and a proposed growth of the step below H_KEEP keeps the
step (and so the factorization).
"""
from __future__ import annotations

from spurdiff.differential.mesh.events import (PHASE_PAST, PHASE_RTOL, STICK_RTOL, breakaway, contact_flags,
                                               friction_margins, phase_events, phase_limit, phase_mode,
                                               phase_switches, state_events)
from spurdiff.differential.mesh.forces import evaluate
from spurdiff.differential.mesh.integrator import combine, error_norm, new_step_size
from spurdiff.differential.mesh.layout import PHIC, PSI, VA, VB, W1, W2, WC, relative_angles
from spurdiff.differential.mesh.stickslip import settle_modes, slip_speed_reached_zero, stick_impulse
from spurdiff.errors import StepError

E_REF = 0.1       # J, energy scale of the loss-quadrature error control
H_MIN = 1e-13     # s, smallest internal step
JAC_AGE_MAX = 10  # accepted steps one Jacobian serves (a W-method keeps its order with any J)
H_KEEP = 1.2      # a proposed step growth up to this factor keeps the step, and so the factored W


def loss_quadrature(P0: float, Pm: float, P1: float, h: float, rtol: float) -> tuple[float, float]:
    """Loss over a step by Simpson's rule with the dense-output midpoint, and its error estimate:
    the difference to the trapezoidal rule relative to ``rtol (E_REF + loss)`` (the dissipated
    power is not smooth where forces clip, so the state error alone does not see it)."""
    dloss = h / 6.0 * (P0 + 4.0 * Pm + P1)
    return dloss, abs(dloss - 0.5 * h * (P0 + P1)) / (rtol * (E_REF + dloss))


def loss_quadrature5(P0: float, Pa: float, Pm: float, Pb: float, P1: float, h: float,
                     rtol: float) -> tuple[float, float]:
    """The same for a method of order 5 (RODAS5P), with the dense output also at the quarter points
    (Pa, Pb): Boole's rule (Simpson on two halves extrapolated, order 6) and as the error estimate
    the difference of Simpson on the two halves and on the whole step (order 5, as the method's)."""
    s1 = h / 6.0 * (P0 + 4.0 * Pm + P1)
    s2 = h / 12.0 * (P0 + 4.0 * Pa + 2.0 * Pm + 4.0 * Pb + P1)
    dloss = s2 + (s2 - s1) / 15.0
    return dloss, abs(s2 - s1) / (rtol * (E_REF + dloss))


def work_speed_drive(c, ya, yb, hi: float, ac: float, wc_a: float, wc_b: float, dphic: float) -> float:
    """Work put in over an internal step with the speed drive, exactly from the state change
    (momentum balance of the relative motion; the carrier's speed follows ``wc_a -> wc_b``)."""
    n = c.n
    JA, JB, J1, J2 = c.JA, c.JB, c.J1 * n, c.J2 * n
    psiBa, th1a, th2a = relative_angles(c, ya)
    psiBb, th1b, th2b = relative_angles(c, yb)
    dpsiA, dpsiB = yb[PSI] - ya[PSI], psiBb - psiBa
    return (c.Jtot * ac * dphic
            + JA * (yb[VA] * wc_b - ya[VA] * wc_a - ac * dpsiA)
            + JB * (yb[VB] * wc_b - ya[VB] * wc_a - ac * dpsiB)
            + J1 * (yb[W1] * wc_b - ya[W1] * wc_a - ac * (th1b - th1a))
            + J2 * (yb[W2] * wc_b - ya[W2] * wc_a - ac * (th2b - th2a))
            + c.tau_L * dpsiA + c.tau_R * dpsiB)


def work_torque_drive(c, ya, yb) -> float:
    """Work put in over an internal step with the torque drive (the carrier angle is a state)."""
    psiBa, _, _ = relative_angles(c, ya)
    psiBb, _, _ = relative_angles(c, yb)
    dpsiA, dpsiB = yb[PSI] - ya[PSI], psiBb - psiBa
    dphic = yb[PHIC] - ya[PHIC]
    return c.tau_c * dphic + c.tau_L * (dphic + dpsiA) + c.tau_R * (dphic + dpsiB)


def book_parametric_work(c, ya, yb) -> None:
    """Book the energy put into the mesh springs by single/double contact switches (rectangular
    stiffness wave) over a step: V(d, k_after) - V(d, k_before) at the end of the step."""
    psiBa, th1a, _ = relative_angles(c, ya)
    psiBb, th1b, _ = relative_angles(c, yb)
    ua = (c.rbA * ya[PSI], c.rbB * psiBa, c.rb1 * th1a)
    ub = (c.rbA * yb[PSI], c.rbB * psiBb, c.rb1 * th1b)
    for mi, m in enumerate(c.md):
        d = yb[m.d]
        Va = c.law_obj.potential(m, d, *c.phase_obj.factors(m, ua[mi]))
        Vb = c.law_obj.potential(m, d, *c.phase_obj.factors(m, ub[mi]))
        if Va != Vb:
            c.parametric_work += c.n * (Vb - Va)


def dense_output(tr, U, y, yn, tin: float, hi: float, k: int, tq: list, yq: list) -> int:
    """The states at the output times ``tq[k], ...`` (into the communication step) that lie in
    (tin, tin + hi], an accepted step from y to yn, by the method's dense output (ROS34PW2: order 3
    with the exact Jacobian, 2 as a W-method; RODAS5P 4) as the rows ``yq[k]`` (new lists); returns the next k. ``y + theta Q_0 + theta^2 Q_1 + theta^3 Q_2 +
    theta^4 Q_3`` with ``Q_p = sum_j dpoly[p][j] u_j``, formed once for a step with outputs (the
    kernel's order of operations; a three-power output's Q_3 is 0)."""
    Q = None
    while k < len(tq) and tq[k] <= tin + hi:
        th = (tq[k] - tin) / hi
        if th >= 1.0:
            yq[k] = list(yn)
        else:
            if Q is None:
                Q = [combine(tr.dpoly[p], U) for p in range(4)]
            th2 = th * th
            th3 = th2 * th
            th4 = th3 * th
            yq[k] = [v + (((q0 * th + q1 * th2) + q2 * th3) + q3 * th4)
                     for v, q0, q1, q2, q3 in zip(y, *Q)]
        k += 1
    return k


def advance(c, t: float, h: float, dense=None) -> None:
    """Advance the model ``c`` from t to t + h (inputs held); raises StepError. ``dense``: None or
    (times into the step, increasing, in (0, h]; an array with a row per time) for the states
    there by the dense output (a list, a row set per time).

    With a mesh-phase effect the phase modes (pairs in contact, tooth count) are held over each
    internal step (``c._mode``), so the right-hand side is smooth within it; a step that a loaded
    flank's phase leaves its interval in is cut to land just past the boundary (as the other
    events), and the modes switch where an accepted step ended: f, the side values and a fresh
    Jacobian (where one was due) are evaluated again there in the new modes."""
    if c._need_phase:
        c._mode = phase_mode(c, c.y)
    try:
        _advance(c, t, h, dense)
    finally:
        c._mode = None


def _advance(c, t: float, h: float, dense) -> None:
    integ = c._integ
    exponent = integ.method.err_exp
    every_step = not integ.method.w_method    # not a W-method: a Jacobian at every step's start
    dq = integ.method.dquarter                 # the five-point loss quadrature's dense weights
    y = c.y
    speed = c.speed_drive
    wc_start = c.wc
    if speed:
        c._ac = (c.w_ref - wc_start) / h
    ac = c._ac
    f0, f1 = c._f0, c._f1
    key = (c.tau_L, c.tau_R, c.tau_c, ac if speed else None, c.s[0], c.s[1])
    if key == c._f0_key:
        sv0 = c._sv0               # f0 and the side values at y are still those of the last step
    elif c._jac_age < 0:           # no Jacobian yet
        sv0 = evaluate(c, y, f0, integ.J)
        c._jac_age, integ.lu_h = 0, 0.0
        c.n_jacobians += 1
    else:                          # the Jacobian depends on the state only: it serves on
        sv0 = evaluate(c, y, f0, None)
    loss0 = c.energy_loss
    max_steps = int(c.mesh.maxInternalSteps)
    n_here = 0
    tin = 0.0          # time into the communication step
    remaining = h
    h_ctrl = c.h_next
    wc_a = wc_start
    phic = c.phic
    dloss = 0.0
    kq, tq, yq = (0, dense[0], dense[1]) if dense is not None else (0, (), None)
    while remaining > 1e-12 * h:
        hi = h_ctrl if h_ctrl < remaining else remaining
        if c._need_phase:
            lim = phase_limit(c, y)
            if lim < hi:
                hi = lim
        if remaining - hi < 1e-9 * h:
            hi = remaining
        truncated = hi < h_ctrl
        located = 0
        rejected = False
        while True:                                   # trial steps until one is accepted
            n_here += 1
            if n_here > max_steps:
                raise StepError(f"more than {max_steps} internal steps in the step at t = {t:.9g} s "
                                f"(maxInternalSteps)")
            if hi < H_MIN:
                raise StepError(f"internal step size {hi:.3g} s below {H_MIN:g} s at t = {t + tin:.9g} s")
            if rejected and c._jac_age > 0:                # retried with a Jacobian at y
                evaluate(c, y, c._fscratch, integ.J)
                c._jac_age, integ.lu_h = 0, 0.0
                c.n_jacobians += 1
            if not integ.step(y, f0, hi):
                c.n_rejected_steps += 1
                rejected = truncated = True
                hi *= 0.25
                continue
            yn = integ.y_new
            if c._pin:
                if c.s[0] == 0:
                    yn[W1] = 0.0
                if c.s[1] == 0:
                    yn[W2] = 0.0
            err = error_norm(integ.err, y, yn, c._atol, c._rtol)
            if not err <= 1.0:  # also catches nan
                c.n_rejected_steps += 1
                rejected = truncated = True
                hi = new_step_size(hi, err, True, exponent) if err == err else hi * 0.25
                continue
            fresh = every_step or located > 0 or c._jac_age + 1 >= JAC_AGE_MAX    # a new Jacobian at y_new?
            if not fresh and (c._bl or c._contact):                  # also where a contact changed
                fresh = contact_flags(c, yn) != c._contact_flags
            sv1 = evaluate(c, yn, f1, c._J1 if fresh else None)
            c.n_jacobians += fresh
            ym = integ.midpoint(y)
            if c._dissipative:
                svm = evaluate(c, ym, c._fscratch, None)
                if dq is None:
                    dloss, errE = loss_quadrature(sv0.P, svm.P, sv1.P, hi, c._rtol)
                else:
                    Pm = svm.P
                    Pa = evaluate(c, integ.dense_at(dq[0], y), c._fscratch, None).P
                    Pb = evaluate(c, integ.dense_at(dq[1], y), c._fscratch, None).P
                    dloss, errE = loss_quadrature5(sv0.P, Pa, Pm, Pb, sv1.P, hi, c._rtol)
                if not errE <= 1.0:
                    c.n_rejected_steps += 1
                    rejected = truncated = True
                    hi = new_step_size(hi, errE, True, exponent) if errE == errE else hi * 0.25
                    continue
                if errE > err:
                    err = errE
            theta = state_events(c, y, ym, yn)
            # a contact made or lost inside the step makes the stuck planets' friction margins
            # jump there, and their secant estimate then lands early again and again (Zeno):
            # locate the contact first
            if c._pin and theta >= 1.0 - 1e-6:        # (pin friction dissipates: svm is there)
                theta = breakaway(c, sv0, svm, sv1, theta)
            if c._need_phase and located < 4:
                # a loaded flank left its held phase mode inside the step: land just past the
                # boundary (its overrun carries the held mode's error, PHASE_RTOL of the step)
                thp = phase_events(c, y, ym, yn)
                if thp < theta and thp < 1.0 - PHASE_RTOL and thp * hi > H_MIN:
                    located += 1
                    c.n_rejected_steps += 1
                    hi = hi * thp * (1.0 + PHASE_PAST) + 1e-15
                    truncated = True
                    continue
            if theta < 1.0 - 1e-6 and located < 4 and theta * hi > H_MIN:
                located += 1
                c.n_rejected_steps += 1
                hi = hi * theta * (1.0 + 1e-4) + 1e-14
                truncated = True
                continue
            break
        # ---- accept
        c.n_internal_steps += 1
        h_prop = new_step_size(hi, err, rejected, exponent)
        if not fresh and hi <= h_prop <= H_KEEP * hi:
            h_prop = hi
        h_ctrl = max(h_ctrl, h_prop) if truncated and not rejected else h_prop
        if c._dissipative:
            c.energy_loss += dloss
        ya, yb = y, yn            # (read before y takes yn's values below)
        if speed:
            wc_b = wc_start + ac * (tin + hi)
            dphic = wc_a * hi + 0.5 * ac * hi * hi
            c.work_in += work_speed_drive(c, ya, yb, hi, ac, wc_a, wc_b, dphic)
            phic += dphic
            wc_a = wc_b
        else:
            c.work_in += work_torque_drive(c, ya, yb)
            wc_b = yb[WC]
        if c._var:
            book_parametric_work(c, ya, yb)
        if kq < len(tq):
            kq = dense_output(integ.method, integ.U, y, yn, tin, hi, kq, tq, yq)
        y[:] = yn
        tin += hi
        remaining = h - tin
        if c._bl or c._contact:
            fl = contact_flags(c, y)
            c.n_contact_transitions += sum(1 for a, b in zip(fl, c._contact_flags) if a != b)
            c._contact_flags = fl
        phase_switched = False
        if c._need_phase:                     # the phase modes switch where the step ended
            mode = phase_mode(c, y)
            if mode != c._mode:
                c.n_phase_switches += phase_switches(c, y, c._mode, mode)
                c._mode = mode
                phase_switched = True
        switched = False
        if c._pin:
            zeroed = []
            for i in (0, 1):
                if slip_speed_reached_zero(c, y, f1, i):
                    stick_impulse(c, y, i, wc_b)
                    zeroed.append(i)
            m1 = friction_margins(c, sv1)
            tolc = -STICK_RTOL * (sv1.cap_1 + sv1.cap_2)
            if zeroed or m1[0] < tolc or m1[1] < tolc:
                c.n_mode_switches += settle_modes(c, y, zeroed)
                switched = True
        if not switched:
            f0, f1 = f1, f0
            if fresh:
                integ.J, c._J1 = c._J1, integ.J
                c._jac_age, integ.lu_h = 0, 0.0
            else:
                c._jac_age += 1
            c._f0, c._f1 = f0, f1
            sv0 = sv1
            if phase_switched:                # f and side values (and the fresh Jacobian) in the new modes
                sv0 = evaluate(c, y, f0, integ.J if fresh else None)
                c.n_jacobians += fresh
                if c._pin:                    # the forces jumped: a stuck planet may break away
                    m0 = friction_margins(c, sv0)
                    tolc = -STICK_RTOL * (sv0.cap_1 + sv0.cap_2)
                    if m0[0] < tolc or m0[1] < tolc:
                        c.n_mode_switches += settle_modes(c, y, [])
                        f0, f1 = c._f0, c._f1
                        sv0 = c._sv
        else:
            f0, f1 = c._f0, c._f1
            sv0 = c._sv                                # (and J: settle_modes)
    c.h_next = h_ctrl
    c._f0_key = (c.tau_L, c.tau_R, c.tau_c, ac if speed else None, c.s[0], c.s[1])
    c._sv0 = sv0
    if speed:
        c.wc = float(c.w_ref)
        c.phic = phic
    else:
        c.wc = float(y[WC])
        c.phic = float(y[PHIC])
    c.t = t + h
    c.loss_last_step = c.energy_loss - loss0
    c._last_h = h
    c.n_steps += 1
