"""Mass properties of the differential's parts from geometry, density and the parts data.

Each gear is a steel ring: outer radius the mean of its tip and root radii ``(r_a + r_f) / 2``
(the teeth as a ring of half their height), inner radius its bore, width its face width
(``m = rho pi (r^2 - r_i^2) b``, ``J = m (r^2 + r_i^2) / 2``). Data: ``spurdiff/data/parts.toml``
(sources there):

* the planets' bore is the pin's diameter ``2 r_collar`` (the pin belongs to the carrier; the
  planet turns on it), the suns' bore the half-shaft's spline;
* stepped planets: the part of a planet's face that meshes with no gear (the axial overlaps of
  :mod:`spurdiff.gears.axial`) is a hub at the root radius, not a toothed ring;
* the pins: solid steel of diameter ``2 r_collar`` across the carrier's inner width (the axial
  layout's ``wallB``), on the carrier at the planets' orbit radii (``m_pin (a^2 + r_pin^2 / 2)``
  each; the parts inside the side plates are counted with the plates);
* the carrier: two steel side plates (thickness and rim margin from the data) with the radius of
  the planets' outer reach plus the margin.

Every value can be overridden (parameters ``J_*`` and ``m_planet*``: values > 0 are used as given,
``J_carrier`` then being the carrier with its pins).
"""
from __future__ import annotations

import math

from spurdiff.datafile import parse_bundled
from spurdiff.differential.params import DifferentialParams
from spurdiff.gears.axial import axial_layout
from spurdiff.gears.geometry import DifferentialGeometry, GearGeometry
from spurdiff.attrpath import record

PARTS_FILE = "parts.toml"
PARTS = parse_bundled(PARTS_FILE)   # read once, at import
CARRIER_PLATE_THICKNESS = PARTS["carrier"]["plateThickness"]   # m, each of two side plates (assumed)
CARRIER_RIM_MARGIN = PARTS["carrier"]["rimMargin"]             # m beyond the planets' outer reach (assumed)


def ring(r_outer: float, r_inner: float, width: float, density: float) -> tuple[float, float]:
    """(mass kg, polar inertia kg m^2) of a ring (a disc with a bore: ``r_inner`` 0 for none)."""
    r_inner = min(max(r_inner, 0.0), r_outer)
    mass = density * math.pi * (r_outer * r_outer - r_inner * r_inner) * width
    return mass, 0.5 * mass * (r_outer * r_outer + r_inner * r_inner)


def disc(g: GearGeometry, density: float, bore: float = 0.0) -> tuple[float, float]:
    """(mass kg, polar inertia kg m^2) of a gear as a ring of its mean radius and face width with a
    bore of diameter ``bore`` (m; 0: a solid disc)."""
    return ring(0.5 * (g.ra + g.rf), 0.5 * bore, g.b, density)


def toothed_width(geo: DifferentialGeometry, gear: str) -> float:
    """The part of ``gear``'s face (m) that meshes with some gear: the union of its meshes' axial
    overlaps (:mod:`spurdiff.gears.axial`), within its face."""
    lay = axial_layout(geo)
    s0, e0 = lay.starts[gear], lay.end(gear)
    spans = sorted((max(me.start, s0), min(me.end, e0)) for me in lay.meshes.values()
                   if gear in (me.gear1, me.gear2) and me.width > 0.0)
    total, reach = 0.0, s0
    for s, e in spans:
        s = max(s, reach)
        if e > s:
            total += e - s
            reach = e
    return total


def planet(g: GearGeometry, geo: DifferentialGeometry, density: float, bore: float,
           stepped: bool = True) -> tuple[float, float]:
    """(mass, polar inertia) of a planet: a ring of its mean radius over the toothed part of its face
    and (stepped) a hub of its root radius over the rest, both with the bore."""
    if not stepped:
        return disc(g, density, bore)
    bt = min(toothed_width(geo, g.name), g.b)
    m1, J1 = ring(0.5 * (g.ra + g.rf), 0.5 * bore, bt, density)
    m2, J2 = ring(g.rf, 0.5 * bore, g.b - bt, density)
    return m1 + m2, J1 + J2


@record(frozen=True)
class MassProperties:
    """Inertias (kg m^2) and planet masses (kg) used by the dynamic models."""

    J_carrier: float      # carrier alone with its pins (without planets)
    J_sunA: float
    J_sunB: float
    J_planet1: float      # one planet about its own axis
    J_planet2: float
    m_planet1: float
    m_planet2: float
    r_orbit1: float       # planet 1 axis radius on the carrier = a_A1 (m)
    r_orbit2: float       # planet 2 axis radius = a_B2 (m)
    n_pairs: int
    m_pin: float = 0.0    # one pin (kg; inside the carrier's inner width), part of J_carrier

    @property
    def J_carrier_total(self) -> float:
        """Carrier with the planets' orbiting masses (rigidly carried part)."""
        n = self.n_pairs
        return (self.J_carrier + n * (self.m_planet1 * self.r_orbit1 ** 2 + self.m_planet2 * self.r_orbit2 ** 2))


def bores(p: DifferentialParams) -> dict[str, float]:
    """Bore diameters (m) of the four gears from ``parts.toml`` (planets: 0 there means ``2 r_collar``)."""
    b_planet = PARTS["planet"]["bore"] or 2.0 * max(p.r_collar, 0.0)
    b_sun = PARTS["sun"]["bore"]
    return {"sunA": b_sun, "sunB": b_sun, "planet1": b_planet, "planet2": b_planet}


def mass_properties(p: DifferentialParams, geo: DifferentialGeometry) -> MassProperties:
    rho = p.density
    g = geo.gears
    bo = bores(p)
    stepped = bool(PARTS["planet"]["stepped"])
    mA, JA = disc(g["sunA"], rho, bo["sunA"])
    mB, JB = disc(g["sunB"], rho, bo["sunB"])
    m1, J1 = planet(g["planet1"], geo, rho, bo["planet1"], stepped)
    m2, J2 = planet(g["planet2"], geo, rho, bo["planet2"], stepped)
    R = geo.meshB2.a + g["planet2"].ra + CARRIER_RIM_MARGIN
    plate_mass = rho * math.pi * R * R * CARRIER_PLATE_THICKNESS
    Jc = 2.0 * 0.5 * plate_mass * R * R
    # the pins across the carrier's inner width, on the carrier at the orbit radii
    r_pin = max(p.r_collar, 0.0)
    m_pin = rho * math.pi * r_pin * r_pin * geo.table.carrier.wallB
    n = geo.table.nPairs
    Jc += n * m_pin * (geo.meshA1.a ** 2 + geo.meshB2.a ** 2 + r_pin * r_pin)

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
        n_pairs=n,
        m_pin=m_pin,
    )


__all__ = ["MassProperties", "mass_properties", "disc", "ring", "planet", "toothed_width", "bores", "PARTS"]
