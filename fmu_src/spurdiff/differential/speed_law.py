"""Carrier speed in the pin loads: the centrifugal and carrier-acceleration forces of the planets
add to the bearing force of each pin, so the locking torque depends on the carrier speed
(quasi-static theory; the dynamic levels carry both with ``pinSpeedLoads``, the speed of the step's
start and the acceleration held over the step, see docs/locking-law.md).

In the carrier's frame a planet of mass ``m_i`` whose centre is at radius ``a_i`` from the carrier
axis (``a_A1`` for planet 1, ``a_B2`` for planet 2; :class:`spurdiff.gears.layout.PinLayout`
places them) needs, besides its mesh forces, the centripetal force ``m_i a_i w_c^2`` towards the
axis and ``m_i a_i alpha_c`` along its orbit. The pin supplies them, so its bearing force is

    F_pin,i = | sum of the mesh forces on planet i + m_i a_i w_c^2 e_r,i - m_i a_i alpha_c e_t,i |

(``e_r``: from the carrier axis to the planet centre, ``e_t = z x e_r``; the planet centre does
not move in the carrier, so there is no Coriolis force). With the pin friction
``M_i,max = c |F_pin,i|`` the planets' moment balances of :func:`spurdiff.differential.locking.breakaway`
give the sun torques at break-away. At zero input torque the locking torque is
``|T_A - T_B| = n c sum_i |rho_i| |F_pin,i|`` with the mesh forces it causes itself; without
mesh load it is ``n c (|rho_1| m_1 a_1 + |rho_2| m_2 a_2) w_c^2`` (first order), so it grows with
the square of the speed and with the number of pairs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from spurdiff.differential.locking import PinFriction
from spurdiff.numerics import solve_system


@dataclass(frozen=True)
class SpeedBreakaway:
    T_A: float
    T_B: float
    F_12: float
    F_pin: tuple

    @property
    def locking_torque(self) -> float:
        return abs(self.T_A - self.T_B)

    @property
    def K(self) -> float:
        T0 = self.T_A + self.T_B
        return abs(self.T_A - self.T_B) / abs(T0) if T0 != 0.0 else math.inf


def inertial_forces(pf: PinFriction, geo, masses: tuple[float, float], w_c: float,
                    alpha_c: float = 0.0) -> tuple[tuple[float, float], tuple[float, float]]:
    """The vectors ``m_i a_i (w_c^2 e_r - alpha_c e_t)`` of the two planets (N), in the layout's
    frame (planet 1 on the x axis, planet 2 at the angle theta)."""
    th = pf.layout.theta
    out = []
    for m, a, ang in ((masses[0], geo.meshA1.a, 0.0), (masses[1], geo.meshB2.a, th)):
        er = (math.cos(ang), math.sin(ang))
        et = (-er[1], er[0])
        out.append((m * a * (w_c * w_c * er[0] - alpha_c * et[0]), m * a * (w_c * w_c * er[1] - alpha_c * et[1])))
    return tuple(out)


def _pin_force(pf: PinFriction, i: int, Fs: float, F12: float, g) -> float:
    """The pin's friction load with the inertial load ``g`` at the planet's mass centre
    (:meth:`spurdiff.gears.layout.PinLayout.pin_force`: planar |F_pin|, or the journal's end reactions)."""
    return pf.layout.pin_force(i, Fs, F12, g)[0]


def breakaway_at_speed(pf: PinFriction, geo, masses: tuple[float, float], w_c: float, T0: float, s: float,
                       alpha_c: float = 0.0) -> SpeedBreakaway:
    """Sun torques at break-away (planet spin inertia 0) under the total sun torque ``T0`` (N m,
    may be 0) at carrier speed ``w_c``, sun A ahead (``s = +1``) or behind."""
    rbA, rb1, rbB, rb2 = pf.rb
    n, c = pf.n, pf.c
    g1, g2 = inertial_forces(pf, geo, masses, w_c, alpha_c)
    sg1 = math.copysign(1.0, pf.rho[0]) * s
    sg2 = math.copysign(1.0, pf.rho[1]) * s
    # scale: the larger of the torque's mesh force and the inertial forces
    scale = max(abs(T0) / (n * (rbA + rbB)), math.hypot(*g1), math.hypot(*g2), 1e-9)

    def res(x):
        D, F12 = x[0] * scale * n * (rbA + rbB), x[1] * scale
        FA, FB = (T0 + D) / (2 * n * rbA), (T0 - D) / (2 * n * rbB)
        M1 = -sg1 * (c * _pin_force(pf, 0, FA, F12, g1) + pf.M0[0])
        M2 = -sg2 * (c * _pin_force(pf, 1, FB, F12, g2) + pf.M0[1])
        return [(rb1 * (FA - F12) + M1) / (rb1 * scale), (rb2 * (FB - F12) + M2) / (rb2 * scale)]

    # start: the first-order locking torque of the inertial and mesh loads
    D0 = -s * n * c * (abs(pf.rho[0]) * (math.hypot(*g1) + abs(T0) / (n * rbA))
                       + abs(pf.rho[1]) * (math.hypot(*g2) + abs(T0) / (n * rbB)))
    sol = solve_system(res, [D0 / (scale * n * (rbA + rbB)), T0 / (n * (rbA + rbB) * scale)], xtol=1e-14)
    if not sol.success:
        raise ArithmeticError(f"break-away at carrier speed {w_c:g} rad/s did not converge: {sol.message}")
    D, F12 = float(sol.x[0]) * scale * n * (rbA + rbB), float(sol.x[1]) * scale
    FA, FB = (T0 + D) / (2 * n * rbA), (T0 - D) / (2 * n * rbB)
    return SpeedBreakaway(n * rbA * FA, n * rbB * FB, F12,
                          (_pin_force(pf, 0, FA, F12, g1), _pin_force(pf, 1, FB, F12, g2)))


def locking_torque_at_speed(pf: PinFriction, geo, masses: tuple[float, float], w_c: float, T0: float) -> float:
    """The smaller break-away torque difference of the two directions (N m)."""
    return min(breakaway_at_speed(pf, geo, masses, w_c, T0, s).locking_torque for s in (1.0, -1.0))
