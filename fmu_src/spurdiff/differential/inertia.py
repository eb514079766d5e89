"""Mass properties of the differential's parts from geometry and density.

Gears are solid steel discs of their mean radius ``(r_tip + r_root) / 2`` and face width
(``J = m r^2 / 2``, ``m = rho pi r^2 b``). The paper gives no carrier drawing; the carrier
estimate is two steel side plates 8 mm thick with the radius of the planets' outer reach plus
5 mm. Every value can be overridden (parameters ``J_*`` and ``m_planet*``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from spurdiff.gears.geometry import DifferentialGeometry, GearGeometry
from spurdiff.differential.params import DifferentialParams

CARRIER_PLATE_THICKNESS = 0.008  # m, each of two side plates (estimate, see module docstring)
CARRIER_RIM_MARGIN = 0.005       # m beyond the planets' outer reach (estimate)


def disc(g: GearGeometry, density: float) -> tuple[float, float]:
    """(mass kg, polar inertia kg m^2) of a gear as a solid disc of its mean radius."""
    r = 0.5 * (g.ra + g.rf)
    mass = density * math.pi * r * r * g.b
    return mass, 0.5 * mass * r * r


@dataclass(frozen=True)
class MassProperties:
    """Inertias (kg m^2) and planet masses (kg) used by the dynamic models."""

    J_carrier: float      # carrier alone (without planets)
    J_sunA: float
    J_sunB: float
    J_planet1: float      # one planet about its own axis
    J_planet2: float
    m_planet1: float
    m_planet2: float
    r_orbit1: float       # planet 1 axis radius on the carrier = a_A1 (m)
    r_orbit2: float       # planet 2 axis radius = a_B2 (m)
    n_pairs: int

    @property
    def J_carrier_total(self) -> float:
        """Carrier with the planets' orbiting masses and spin inertias (rigidly carried part)."""
        n = self.n_pairs
        return (self.J_carrier + n * (self.m_planet1 * self.r_orbit1 ** 2 + self.m_planet2 * self.r_orbit2 ** 2))


def mass_properties(p: DifferentialParams, geo: DifferentialGeometry) -> MassProperties:
    rho = p.density
    g = geo.gears
    mA, JA = disc(g["sunA"], rho)
    mB, JB = disc(g["sunB"], rho)
    m1, J1 = disc(g["planet1"], rho)
    m2, J2 = disc(g["planet2"], rho)
    R = geo.meshB2.a + g["planet2"].ra + CARRIER_RIM_MARGIN
    plate_mass = rho * math.pi * R * R * CARRIER_PLATE_THICKNESS
    Jc = 2.0 * 0.5 * plate_mass * R * R

    def pick(override: float, computed: float) -> float:
        return override if override > 0.0 else computed

    return MassProperties(
        J_carrier=pick(p.J_carrier, Jc),
        J_sunA=pick(p.J_sunA, JA),
        J_sunB=pick(p.J_sunB, JB),
        J_planet1=pick(p.J_planet1, J1),
        J_planet2=pick(p.J_planet2, J2),
        m_planet1=pick(p.m_planet1, m1),
        m_planet2=pick(p.m_planet2, m2),
        r_orbit1=geo.meshA1.a,
        r_orbit2=geo.meshB2.a,
        n_pairs=geo.table.nPairs,
    )
