"""Involute spur-gear geometry of the differential and the design checks a gear engineer expects.

The differential has three external spur meshes per planet pair:

* mesh ``A1``: sun A (left half-shaft) with planet 1,
* mesh ``B2``: sun B (right half-shaft) with planet 2,
* mesh ``12``: planet 1 with planet 2.

All gears share one module ``m`` and one standard-rack pressure angle ``alpha``; each gear has its
own tooth count ``z``, profile-shift coefficient ``x``, optional (trimmed) tip diameter ``da`` and
face width ``b``. Lengths are in metres, angles in radians.

Equations (ISO 21771 / any gear textbook, e.g. Niemann-Winter vol. II):

* involute function ``inv(a) = tan(a) - a``
* operating pressure angle: ``inv(alpha_w) = 2 tan(alpha) (x1 + x2) / (z1 + z2) + inv(alpha)``,
  solved with :func:`scipy.optimize.brentq`
* centre distance ``a = m (z1 + z2) / 2 * cos(alpha) / cos(alpha_w)``
* operating pitch radii ``r_w1 = a z1 / (z1 + z2)``, ``r_w2 = a z2 / (z1 + z2)``
* base radii ``r_b = m z cos(alpha) / 2``
* untrimmed tip diameter ``d_a = m (z + 2 h_a + 2 x)``
* transverse contact ratio
  ``eps = (sqrt(r_a1^2 - r_b1^2) + sqrt(r_a2^2 - r_b2^2) - a sin(alpha_w)) / (pi m cos(alpha))``

Design checks (each a :class:`Finding` with the numbers and the parameter to change):

* undercut: ``x >= h_a - z sin^2(alpha) / 2`` (rack-generated gear, no undercut)
* pointed tip: normal tip thickness ``s_a = d_a ((pi/2 + 2 x tan(alpha)) / z + inv(alpha) -
  inv(alpha_a))``; error if ``s_a <= 0``, warning below ``0.25 m``
* tip interference: a tip that reaches past the mating gear's base tangent point (involute
  interference) is a warning that names the interference-free tip diameter (the set works only
  with tip relief to that diameter); contact below the generated involute (trochoid) is a warning
* contact ratio: the usable ratio (tips limited to the interference-free diameter) below 1.0 is an
  error (no continuous action), below 1.1 a warning
* symmetry: the kinematics ``w_A + w_B = 2 w_c`` need equal sun tooth counts and the paper's
  condition ``r_a / r_1 = r_b / r_2`` (the paper prints it as ``r_a/r_b = r_2/r_1``, a typo)
* assembly: the three centre distances must close a triangle; planet 2 (which spans both mesh
  planes) must clear sun A's tip circle; neighbouring planet pairs must not touch
  (this is what limits ``nPairs``: the paper's gear set fits 3 pairs, not 6).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from scipy.optimize import brentq

from .errors import ParameterError, require_finite, require_positive

MM = 1e-3  # metres per millimetre


def inv(alpha: float) -> float:
    """Involute function ``tan(alpha) - alpha``."""
    return math.tan(alpha) - alpha


def inv_inverse(value: float, name: str = "alpha_w") -> float:
    """Angle whose involute is ``value`` (radians), via :func:`scipy.optimize.brentq`."""
    hi = math.radians(60.0)
    if not 0.0 < value < inv(hi):
        raise ParameterError(name, value, f"an involute value in (0, {inv(hi):.4f})",
                             "the profile-shift sum gives no operating pressure angle between 0 and 60 deg")
    return brentq(lambda a: inv(a) - value, 1e-9, hi, xtol=1e-15, rtol=1e-15)


@dataclass(frozen=True)
class Gear:
    """One spur gear: tooth count, profile shift, optional trimmed tip diameter, face width.

    ``da = 0`` means the untrimmed tip diameter ``m (z + 2 h_a + 2 x)``.
    """

    z: int
    x: float
    b: float
    da: float = 0.0


@dataclass(frozen=True)
class GearTable:
    """The differential's gear table (inputs). Lengths in m, angles in rad."""

    m: float = 3.0 * MM
    alpha: float = math.radians(20.0)
    ha: float = 1.0      # addendum coefficient of the basic rack
    hf: float = 1.25     # dedendum coefficient of the basic rack
    sunA: Gear = Gear(z=36, x=-1.0099, b=22 * MM, da=107.20 * MM)
    planet1: Gear = Gear(z=13, x=0.3, b=22 * MM, da=46.059 * MM)
    sunB: Gear = Gear(z=36, x=1.2296, b=22 * MM, da=120.80 * MM)
    planet2: Gear = Gear(z=13, x=-0.3, b=40 * MM, da=42.662 * MM)
    nPairs: int = 3

    @classmethod
    def paper(cls) -> "GearTable":
        """The paper's gear table (tip diameters as printed)."""
        return cls()

    def gears(self) -> dict[str, Gear]:
        return {"sunA": self.sunA, "planet1": self.planet1, "sunB": self.sunB, "planet2": self.planet2}

    def with_gear(self, name: str, **changes) -> "GearTable":
        """A copy with one gear's fields changed, e.g. ``with_gear('sunA', x=-0.5)``."""
        return replace(self, **{name: replace(getattr(self, name), **changes)})

    def validate(self) -> None:
        """Raise ParameterError for values no gear set can have (before any geometry)."""
        require_positive("gearing.m", self.m)
        a = require_finite("gearing.alpha", self.alpha)
        if not math.radians(10.0) <= a <= math.radians(35.0):
            raise ParameterError("gearing.alpha", self.alpha, "between 10 and 35 deg (0.1745 .. 0.6109 rad)")
        require_positive("gearing.ha", self.ha)
        require_positive("gearing.hf", self.hf)
        if self.hf <= self.ha:
            raise ParameterError("gearing.hf", self.hf, f"> gearing.ha = {self.ha:g} (root clearance)")
        n = self.nPairs
        if int(n) != n or not 1 <= n <= 12:
            raise ParameterError("nPairs", n, "an integer from 1 to 12")
        for name, g in self.gears().items():
            z = g.z
            if int(z) != z or not 6 <= z <= 400:
                raise ParameterError(f"{name}.z", z, "an integer from 6 to 400")
            x = require_finite(f"{name}.x", g.x)
            if not -3.0 <= x <= 3.0:
                raise ParameterError(f"{name}.x", x, "between -3 and 3")
            require_positive(f"{name}.b", g.b)
            da = require_finite(f"{name}.da", g.da)
            if da < 0.0:
                raise ParameterError(f"{name}.da", da, ">= 0 (0 = untrimmed tip)")


@dataclass(frozen=True)
class GearGeometry:
    """Derived geometry of one gear (m)."""

    name: str
    z: int
    x: float
    b: float
    r: float    # reference radius m z / 2
    rb: float   # base radius
    ra: float   # tip radius (trimmed if given)
    rf: float   # root radius
    rF: float   # radius where the generated involute starts (form radius)
    sa: float   # tip thickness (arc, on the tip circle)


@dataclass(frozen=True)
class MeshGeometry:
    """Derived geometry of one external mesh. Radii in m, angles in rad."""

    name: str
    gear1: str
    gear2: str
    alpha_w: float        # operating pressure angle
    a: float              # centre distance
    rw1: float            # operating pitch radius of gear 1
    rw2: float            # operating pitch radius of gear 2
    rb1: float
    rb2: float
    ra1: float
    ra2: float
    epsilon_alpha: float  # transverse contact ratio
    pb: float             # base pitch pi m cos(alpha)
    b: float              # common face width min(b1, b2)
    path_length: float    # length of the path of contact g_alpha

    def tip_limit(self, gear: str) -> float:
        """Largest tip radius of ``gear`` free of involute interference: its tip may reach the
        base tangent point of the mating gear, not past it: ``sqrt(rb^2 + (a sin(alpha_w))^2)``."""
        rb = self.rb1 if gear == self.gear1 else self.rb2
        return math.hypot(rb, self.a * math.sin(self.alpha_w))

    @property
    def epsilon_usable(self) -> float:
        """Contact ratio with each tip limited to its interference-free radius."""
        ra1 = min(self.ra1, self.tip_limit(self.gear1))
        ra2 = min(self.ra2, self.tip_limit(self.gear2))
        g = (math.sqrt(max(ra1 ** 2 - self.rb1 ** 2, 0.0)) + math.sqrt(max(ra2 ** 2 - self.rb2 ** 2, 0.0))
             - self.a * math.sin(self.alpha_w))
        return g / self.pb

    @property
    def ratio(self) -> float:
        """Speed ratio z2/z1 = rw2/rw1."""
        return self.rw2 / self.rw1


@dataclass(frozen=True)
class Finding:
    """One result of a design check."""

    level: str       # "error" or "warning"
    check: str       # short check id, e.g. "undercut"
    parameter: str   # the parameter to change, e.g. "planet2.x"
    message: str

    def __str__(self) -> str:
        return f"{self.level.upper():7s} {self.check}: {self.message} (change {self.parameter})"


def gear_geometry(name: str, g: Gear, t: GearTable) -> GearGeometry:
    m, alpha = t.m, t.alpha
    r = m * g.z / 2.0
    rb = r * math.cos(alpha)
    ra = g.da / 2.0 if g.da > 0.0 else r + m * (t.ha + g.x)
    rf = r - m * (t.hf - g.x)
    # start of the generated involute (rack tip line meets the line of action)
    u = r * math.sin(alpha) - m * (t.ha - g.x) / math.sin(alpha)
    rF = math.hypot(rb, u) if u > 0.0 else rb
    if ra <= rb:
        sa = float("-inf")
    else:
        alpha_a = math.acos(rb / ra)
        sa = 2.0 * ra * ((math.pi / 2.0 + 2.0 * g.x * math.tan(alpha)) / g.z + inv(alpha) - inv(alpha_a))
    return GearGeometry(name, g.z, g.x, g.b, r, rb, ra, rf, rF, sa)


def mesh_geometry(name: str, g1: GearGeometry, g2: GearGeometry, t: GearTable) -> MeshGeometry:
    m, alpha = t.m, t.alpha
    z1, z2 = g1.z, g2.z
    inv_w = 2.0 * math.tan(alpha) * (g1.x + g2.x) / (z1 + z2) + inv(alpha)
    alpha_w = inv_inverse(inv_w, f"{g1.name}.x + {g2.name}.x")
    a = m * (z1 + z2) / 2.0 * math.cos(alpha) / math.cos(alpha_w)
    rw1 = a * z1 / (z1 + z2)
    rw2 = a * z2 / (z1 + z2)
    pb = math.pi * m * math.cos(alpha)
    l1 = math.sqrt(max(g1.ra ** 2 - g1.rb ** 2, 0.0))
    l2 = math.sqrt(max(g2.ra ** 2 - g2.rb ** 2, 0.0))
    g_alpha = l1 + l2 - a * math.sin(alpha_w)
    return MeshGeometry(name, g1.name, g2.name, alpha_w, a, rw1, rw2, g1.rb, g2.rb, g1.ra, g2.ra,
                        g_alpha / pb, pb, min(g1.b, g2.b), g_alpha)


@dataclass(frozen=True)
class DifferentialGeometry:
    """Everything derived from a :class:`GearTable`, with the design findings."""

    table: GearTable
    gears: dict[str, GearGeometry]
    meshA1: MeshGeometry
    meshB2: MeshGeometry
    mesh12: MeshGeometry
    findings: tuple[Finding, ...] = field(default_factory=tuple)

    # Short names used by the paper: r_a, r_1 (mesh A1), r_b, r_2 (mesh B2), r_0 (mesh 12)
    @property
    def r_a(self) -> float:
        return self.meshA1.rw1

    @property
    def r_1(self) -> float:
        return self.meshA1.rw2

    @property
    def r_b(self) -> float:
        return self.meshB2.rw1

    @property
    def r_2(self) -> float:
        return self.meshB2.rw2

    @property
    def meshes(self) -> tuple[MeshGeometry, MeshGeometry, MeshGeometry]:
        return (self.meshA1, self.meshB2, self.mesh12)

    @property
    def errors(self) -> list[Finding]:
        return [f for f in self.findings if f.level == "error"]

    @property
    def warnings(self) -> list[Finding]:
        return [f for f in self.findings if f.level == "warning"]

    def raise_on_error(self) -> None:
        """Raise ParameterError for the first error finding (impossible gear set)."""
        for f in self.errors:
            raise ParameterError(f.parameter, _value_of(self.table, f.parameter), "a feasible gear set", f.message)


def _value_of(t: GearTable, parameter: str):
    obj = t
    for part in parameter.split("."):
        obj = getattr(obj, part, None)
        if obj is None:
            return None
    return obj


def derive(table: GearTable | None = None) -> DifferentialGeometry:
    """Derive the geometry of all three meshes and run every design check.

    Raises ParameterError only for inputs for which no geometry exists at all (non-positive
    module, no operating pressure angle, ...). Infeasible but computable gear sets come back with
    error findings; call :meth:`DifferentialGeometry.raise_on_error` to reject them.
    """
    t = table or GearTable()
    t.validate()
    gg = {name: gear_geometry(name, g, t) for name, g in t.gears().items()}
    mA1 = mesh_geometry("A1", gg["sunA"], gg["planet1"], t)
    mB2 = mesh_geometry("B2", gg["sunB"], gg["planet2"], t)
    m12 = mesh_geometry("12", gg["planet1"], gg["planet2"], t)
    findings = tuple(_check(t, gg, (mA1, mB2, m12)))
    return DifferentialGeometry(t, gg, mA1, mB2, m12, findings)


def _mm(v: float) -> str:
    return f"{v / MM:.3f} mm"


def _check(t: GearTable, gg: dict[str, GearGeometry], meshes: tuple[MeshGeometry, ...]):
    m, alpha = t.m, t.alpha
    for name, g in gg.items():
        x_min = t.ha - g.z * math.sin(alpha) ** 2 / 2.0
        if g.x < x_min - 1e-9:
            yield Finding("warning", "undercut", f"{name}.x",
                          f"{name} (z = {g.z}) is undercut: x = {g.x:+.4f} < x_min = {x_min:+.4f}")
        if g.ra <= g.rb or g.sa <= 0.0:
            yield Finding("error", "pointed-tip", f"{name}.x",
                          f"{name} has no tooth left at its tip (tip thickness {g.sa / MM:.3f} mm)")
        elif g.sa < 0.25 * m:
            yield Finding("warning", "pointed-tip", f"{name}.x",
                          f"{name} tip thickness {g.sa / MM:.3f} mm < 0.25 m = {0.25 * m / MM:.3f} mm")
        if g.ra <= g.rf:
            yield Finding("error", "tip-below-root", f"{name}.da",
                          f"{name} tip radius {_mm(g.ra)} is not above its root radius {_mm(g.rf)}")
    for me in meshes:
        g1, g2 = gg[me.gear1], gg[me.gear2]
        clear_root_1 = me.a - g2.ra - g1.rf
        clear_root_2 = me.a - g1.ra - g2.rf
        for gear, other, clr in ((g1, g2, clear_root_1), (g2, g1, clear_root_2)):
            if clr < 0.0:
                yield Finding("error", "tip-root-clash", f"{other.name}.da",
                              f"mesh {me.name}: {other.name}'s tip cuts into {gear.name}'s root by {_mm(-clr)}")
        for gear, other in ((g1, g2), (g2, g1)):
            r_limit = me.tip_limit(other.name)
            if other.ra > r_limit + 1e-9:
                yield Finding("warning", "tip-interference", f"{other.name}.da",
                              f"mesh {me.name}: {other.name}'s tip (d_a = {2 * other.ra / MM:.3f} mm) reaches past the "
                              f"base tangent point of {gear.name} (involute interference); interference-free "
                              f"d_a <= {2 * r_limit / MM:.3f} mm, i.e. tip relief assumed; usable contact ratio "
                              f"{me.epsilon_usable:.3f}")
            else:
                reach = me.a * math.sin(me.alpha_w) - math.sqrt(other.ra ** 2 - other.rb ** 2)
                r_start = math.hypot(gear.rb, reach)
                if r_start < gear.rF - 1e-9:
                    yield Finding("warning", "trochoid-interference", f"{other.name}.da",
                                  f"mesh {me.name}: contact starts on {gear.name} at r = {_mm(r_start)}, below its "
                                  f"generated involute (form radius {_mm(gear.rF)})")
        if me.epsilon_usable < 1.0:
            yield Finding("error", "contact-ratio", f"{me.gear1}.da",
                          f"mesh {me.name}: usable contact ratio {me.epsilon_usable:.3f} < 1.0 once the tips are "
                          f"limited to the interference-free diameter (no continuous action)")
        elif me.epsilon_usable < 1.1:
            yield Finding("warning", "contact-ratio", f"{me.gear1}.da",
                          f"mesh {me.name}: usable transverse contact ratio {me.epsilon_usable:.3f} < 1.1")
    mA1, mB2, m12 = meshes
    if t.sunA.z != t.sunB.z:
        yield Finding("error", "symmetry", "sunB.z",
                      f"sun tooth counts differ ({t.sunA.z} vs {t.sunB.z}): w_A + w_B = 2 w_c does not hold")
    ratio_a = mA1.rw1 / mA1.rw2
    ratio_b = mB2.rw1 / mB2.rw2
    if abs(ratio_a / ratio_b - 1.0) > 1e-6:
        yield Finding("error", "symmetry", "planet2.z",
                      f"r_a/r_1 = {ratio_a:.5f} differs from r_b/r_2 = {ratio_b:.5f}: "
                      f"the planets of a pair must have equal tooth counts")
    # Planet pair triangle: planet 1 at radius a_A, planet 2 at a_B, a_12 apart.
    aA, aB, a12 = mA1.a, mB2.a, m12.a
    if not abs(aA - aB) < a12 < aA + aB:
        yield Finding("error", "assembly", "planet2.x",
                      f"centre distances a_A1 = {_mm(aA)}, a_B2 = {_mm(aB)}, a_12 = {_mm(a12)} do not form a triangle")
        return
    ga, g1, gb, g2 = gg["sunA"], gg["planet1"], gg["sunB"], gg["planet2"]
    # Planet 2 spans both mesh planes, so it must clear sun A's tip circle (the paper's trick).
    clr = aB - g2.ra - ga.ra
    if clr <= 0.0:
        yield Finding("error", "planet2-sunA-clearance", "sunA.x",
                      f"planet 2 tip circle overlaps sun A tip circle by {_mm(-clr)}")
    elif clr < 0.1 * m:
        yield Finding("warning", "planet2-sunA-clearance", "sunA.x",
                      f"planet 2 clears sun A's tip circle by only {_mm(clr)} (< 0.1 m)")
    # Planet 1 lies in sun A's plane only; if the faces overlap axially it must clear sun B's tip too.
    # (Not modelled: axial layout; the paper's layout keeps planet 1 out of sun B's plane.)
    n = t.nPairs
    theta = math.acos((aA ** 2 + aB ** 2 - a12 ** 2) / (2.0 * aA * aB))  # angle planet1 -> planet2
    pitch = 2.0 * math.pi / n
    pairs = [
        ("planet 2 of one pair and planet 1 of the next", aA, aB, pitch - theta, g1.ra + g2.ra),
        ("planet 1 of neighbouring pairs", aA, aA, pitch, 2.0 * g1.ra),
        ("planet 2 of neighbouring pairs", aB, aB, pitch, 2.0 * g2.ra),
    ]
    if n > 1:
        for what, r1, r2, ang, need in pairs:
            d = math.sqrt(r1 ** 2 + r2 ** 2 - 2.0 * r1 * r2 * math.cos(ang))
            if d <= need:
                yield Finding("error", "neighbour-clearance", "nPairs",
                              f"nPairs = {n}: {what} overlap (centres {_mm(d)} apart, tips need {_mm(need)})")
    if t.sunA.z % n or t.sunB.z % n:
        yield Finding("warning", "equal-spacing", "nPairs",
                      f"sun tooth counts {t.sunA.z}, {t.sunB.z} are not multiples of nPairs = {n}: "
                      f"equally spaced pairs may not assemble")
