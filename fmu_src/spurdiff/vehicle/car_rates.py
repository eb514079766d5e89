"""The equations of the vehicle (:mod:`spurdiff.vehicle.car`: frames, signs, states, integration), as
the rate function its integrator steps. Equations::

    m (dv_x/dt - v_y r) = F_xf cos(delta) - F_yf sin(delta) + Fx_L + Fx_R + F_aero + F_grade
    m (dv_y/dt + v_x r) = F_xf sin(delta) + F_yf cos(delta) + F_yr
    Iz dr/dt            = l_f (F_xf sin(delta) + F_yf cos(delta)) - l_r F_yr + (t_r/2)(Fx_R - Fx_L)
    F_aero = -1/2 rho CdA v_x |v_x|,   F_grade = -m g sin(grade)

Lateral tyres (single-track, one Magic Formula per axle, tyre.py): ``F_yf = mu Fz_f f(alpha_f)``,
``F_yr = D_r f(alpha_r)`` with the rear friction circle ``D_r = sqrt((mu Fz_r)^2 - (Fx_L + Fx_R)^2)``
(0 if negative). Slip angles by relaxation length ``sigma`` (no division by the speed, defined at
standstill, as the longitudinal slip in tyre.py)::

    sigma dalpha/dt + |v_wx| alpha = -v_wy

with ``(v_wx, v_wy)`` the axle-centre velocity in the wheel frame: front ``v_wx = v_x cos delta +
(v_y + l_f r) sin delta``, ``v_wy = -v_x sin delta + (v_y + l_f r) cos delta``; rear ``v_wx = v_x``,
``v_wy = v_y - l_r r``. In steady state this is the single-track slip angle
``alpha_f = delta - (v_y + l_f r)/v_x``, ``alpha_r = -(v_y - l_r r)/v_x``. ``|alpha| <= alpha_max``.
Front rolling resistance ``F_xf = -f_rr Fz_f tanh(v_wx / v_rr)``.

Loads (never negative; a lifted wheel carries 0)::

    Fz_f = m g cos(grade) l_r / L - m a_xs_f h / L,   Fz_r = m g cos(grade) l_f / L + m a_xs_f h / L
    Fz_RL,RR = Fz_r / 2 -+ s_r m a_y_f h / t_r      (clamped to [0, Fz_r])

``a_xs = a_x + g sin(grade)`` is the longitudinal specific force (ground and aero forces over m,
what shifts load); ``s_r`` is the rear share of the roll stiffness. ``a_xs_f``, ``a_y_f`` follow
``a_xs``, ``a_y`` with a first-order lag ``tau_load`` (the body's pitch/roll response); the lag also
breaks the algebraic loop load -> force -> acceleration -> load.

Steering (``steering.mode = 0``): ``delta = atan(L / R) + K_r e + I_r``, ``dI_r/dt = K_ri e``,
``e = (v_x / R - r) tanh(v_x / 1 m/s)`` (the factor keeps the feedback sign right when reversing
and fades it at standstill), limited to ``+-delta_max`` with conditional-integration anti-windup;
``R = 0`` or ``inf`` means straight. ``mode = 1``: ``delta`` = the steering-angle input (limited).
Speed control: ``driveTorque = Kp (speedTarget - v_x) + I_v``, ``dI_v/dt = Ki (speedTarget - v_x)``,
limited to ``[driveTorqueMin, driveTorqueMax]`` with conditional-integration anti-windup. It is the
axle torque (at the differential carrier) the powertrain should deliver; this model only
computes it.
"""
from __future__ import annotations

import math
from typing import Callable

from spurdiff.vehicle.car_params import G, STEER_ANGLE


def make_rates(self) -> Callable:
    """The model's equations (module docstring) as a rate function for the inputs the vehicle
    ``self`` (:class:`spurdiff.vehicle.car.Vehicle`) cached by its ``_load_inputs``, every parameter
    and input-only term bound once (per step).

    ``rates(vx, vy, r, psi, alpha_f, alpha_r, axs_f, ay_f, I_v, I_r, tau)`` (the state without the
    position, which no rate depends on; ``tau`` the time since the start of the step, default 0)
    returns the 12 time derivatives in state order; with ``full=True`` it returns ``(derivatives,
    (delta, Fz_f, Fz_r, a_x, a_y, a_xs, Fx_rear, Fy_f, Fy_r, u))``, what the outputs and the
    initialization need (u: the speed controller's unlimited torque). The command inputs ramp over
    the step at their rates (``pathRadiusRate``, ``speedTargetRate``; 0: held):
    ``R(tau) = R + dR tau`` (not from a straight path, R = 0 or inf), ``v_ref(tau) = v_ref + dv tau``."""
    p = self.params
    b, lt, st, sc = p.vehicle, p.lateralTyre, p.steering, p.speedControl
    m, L, lf = b.m, b.L, b.l_f
    lr = L - lf
    mu = self._mu
    Wn = m * G * self._cos_g
    Wn_lr_L = Wn * lr / L
    h_cg = b.h_cg
    B, C, E = lt.B, lt.C, lt.E
    nfrr, v_rr = -b.f_rr, b.v_rr
    FxL, FxR = self._FxL, self._FxR
    Fxr = FxL + FxR
    Fxr2 = Fxr * Fxr
    k_aero = -0.5 * b.rho_air * b.CdA
    F_grade = -m * G * self._sin_g
    Mz_x = 0.5 * b.trackRear * (FxR - FxL)
    G_sin = G * self._sin_g
    Iz = b.Iz
    vref, Kp, Ki = self._vref, sc.Kp, sc.Ki
    umax, umin = sc.driveTorqueMax, sc.driveTorqueMin
    inv_sig = 1.0 / lt.sigma
    inv_tau = 1.0 / b.tau_load
    dmax = st.delta_max
    angle_mode = st.mode == STEER_ANGLE
    dcmd = self._dcmd
    delta_cmd = dmax if dcmd > dmax else (-dmax if dcmd < -dmax else dcmd)
    kappa, delta_ff, K_r, K_ri = self._kappa, self._delta_ff, st.K_r, st.K_ri
    sin, cos, tanh, atan, sqrt = math.sin, math.cos, math.tanh, math.atan, math.sqrt
    dvref = self._dvref
    dR = self._dR if kappa != 0.0 else 0.0     # a straight path (R = 0 or inf) does not ramp
    R0 = self._R
    ramp = dvref != 0.0 or dR != 0.0
    inf = math.inf

    def rates(vx, vy, r, psi, af, ar, axf, ayf, Iv, Ir, tau=0.0, full=False):
        if ramp:   # the command inputs at tau into the step (first-order hold)
            vr = vref + dvref * tau
            if dR != 0.0:
                R = R0 + dR * tau
                kap = 0.0 if (R == 0.0 or R == inf or R == -inf) else 1.0 / R
                dff = atan(L * kap)
            else:
                kap, dff = kappa, delta_ff
        else:
            vr, kap, dff = vref, kappa, delta_ff
        if angle_mode:
            dIr = 0.0
            delta = delta_cmd
        else:
            e = (vx * kap - r) * tanh(vx)
            raw = dff + K_r * e + Ir
            if (raw >= dmax and e > 0.0) or (raw <= -dmax and e < 0.0):
                dIr = 0.0
            else:
                dIr = K_ri * e
            delta = dmax if raw > dmax else (-dmax if raw < -dmax else raw)
        Fz_f = Wn_lr_L - m * axf * h_cg / L
        Fz_f = 0.0 if Fz_f < 0.0 else (Wn if Fz_f > Wn else Fz_f)
        Fz_r = Wn - Fz_f
        cd, sd = cos(delta), sin(delta)
        vfy = vy + lf * r
        vwx_f = vx * cd + vfy * sd
        vwy_f = -vx * sd + vfy * cd
        x = B * af
        Fyf = mu * Fz_f * sin(C * atan(x - E * (x - atan(x))))
        Fxf = nfrr * Fz_f * tanh(vwx_f / v_rr)
        D2 = (mu * Fz_r) ** 2 - Fxr2
        x = B * ar
        Fyr = (sqrt(D2) if D2 > 0.0 else 0.0) * sin(C * atan(x - E * (x - atan(x))))
        Fyf_b = Fxf * sd + Fyf * cd
        FX = Fxf * cd - Fyf * sd + Fxr + k_aero * vx * abs(vx) + F_grade
        ax = FX / m
        ay = (Fyf_b + Fyr) / m
        eu = vr - vx
        u = Kp * eu + Iv
        cpsi, spsi = cos(psi), sin(psi)
        d = (
            ax + vy * r,
            ay - vx * r,
            (lf * Fyf_b - lr * Fyr + Mz_x) / Iz,
            r,
            vx * cpsi - vy * spsi,
            vx * spsi + vy * cpsi,
            (-vwy_f - abs(vwx_f) * af) * inv_sig,
            (-(vy - lr * r) - abs(vx) * ar) * inv_sig,
            (ax + G_sin - axf) * inv_tau,
            (ay - ayf) * inv_tau,
            0.0 if ((u >= umax and eu > 0.0) or (u <= umin and eu < 0.0)) else Ki * eu,
            dIr,
        )
        if full:
            return d, (delta, Fz_f, Fz_r, ax, ay, ax + G_sin, Fxr, Fyf, Fyr, u)
        return d
    return rates


__all__ = ["make_rates"]
