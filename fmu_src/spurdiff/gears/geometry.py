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
  solved with :func:`spurdiff.numerics.find_root` (Brent's method)
* centre distance ``a = m (z1 + z2) / 2 * cos(alpha) / cos(alpha_w)``
* operating pitch radii ``r_w1 = a z1 / (z1 + z2)``, ``r_w2 = a z2 / (z1 + z2)``
* base radii ``r_b = m z cos(alpha) / 2``
* untrimmed tip diameter ``d_a = m (z + 2 h_a + 2 x)``
* transverse contact ratio
  ``eps = (sqrt(r_a1^2 - r_b1^2) + sqrt(r_a2^2 - r_b2^2) - a sin(alpha_w)) / (pi m cos(alpha))``

Design checks (each a :class:`Finding` with the numbers and the parameter to change): undercut,
pointed tip, tip interference, contact ratio, form circle, tip clearance, symmetry, assembly, in
:mod:`spurdiff.gears.checks` (the list and its criteria in its docstring); mesh phasing in
:mod:`spurdiff.gears.phasing`.
"""
from __future__ import annotations

import math
from dataclasses import field, replace

from spurdiff.datafile import differential_default as _d
from spurdiff.errors import Bound, check_fields
from spurdiff.errors import ParameterError
from spurdiff.gears.generating import form_radius
from spurdiff.numerics import find_root
from spurdiff.attrpath import record

MM = 1e-3  # metres per millimetre


def inv(alpha: float) -> float:
    """Involute function ``tan(alpha) - alpha``."""
    return math.tan(alpha) - alpha


def inv_inverse(value: float, name: str = "alpha_w") -> float:
    """Angle whose involute is ``value`` (radians), via :func:`spurdiff.numerics.find_root`."""
    hi = math.radians(60.0)
    if not 0.0 < value < inv(hi):
        raise ParameterError(name, value, f"an involute value in (0, {inv(hi):.4f})",
                             "the profile-shift sum gives no operating pressure angle between 0 and 60 deg")
    return find_root(lambda a: inv(a) - value, 1e-9, hi, xtol=1e-15, rtol=1e-15)


@record(frozen=True)
class Gear:
    """One spur gear: tooth count, profile shift, optional trimmed tip diameter, face width, and
    where its face starts along the axis (from carrier wall A's inner face; the axial layout,
    :mod:`spurdiff.gears.axial`).

    ``da = 0`` means the untrimmed tip diameter ``m (z + 2 h_a + 2 x)``.
    """

    z: int
    x: float
    b: float
    da: float = 0.0
    axialStart: float | None = None     # None: not given (no axial layout: coplanar meshes, no stack-up check)

    # the fields' ranges (spurdiff.errors: GearTable.validate and the FMUs' min/max)
    BOUNDS = {"z": Bound(6, 400, integer=True), "x": Bound(-3.0, 3.0), "b": Bound(0.0, lo_open=True),
              "da": Bound(0.0, allowed=">= 0 (0 = untrimmed tip)"),
              "axialStart": Bound(0.0, 1.0, allowed="between 0 and 1 m (from carrier wall A's inner face)")}


@record(frozen=True)
class Carrier:
    """The carrier's walls along the axis (m): wall A's inner face at 0, wall B's at ``wallB``;
    ``axialClearance`` the smallest running clearance between faces that turn relative to each
    other (gear to gear in different planes, gear to wall); :mod:`spurdiff.gears.axial`."""

    wallB: float
    axialClearance: float

    BOUNDS = {"wallB": Bound(0.0, lo_open=True), "axialClearance": Bound(0.0, 0.01)}


@record(frozen=True)
class GearTable:
    """The differential's gear table (inputs). Lengths in m, angles in rad. Defaults: the paper's
    gear table, from ``spurdiff/data/differential.toml`` (sections ``[gearing]``, ``[sunA]``...)."""

    m: float = _d("gearing.m")
    alpha: float = _d("gearing.alpha")
    ha: float = _d("gearing.ha")          # addendum coefficient of the basic rack
    hf: float = _d("gearing.hf")          # dedendum coefficient of the basic rack
    haP0: float = _d("gearing.haP0")      # addendum coefficient of the generating tool (ISO 53 A)
    rhoaP0: float = _d("gearing.rhoaP0")  # tip radius coefficient of the generating tool (ISO 53 A)
    sunA: Gear = Gear(**_d("sunA"))
    planet1: Gear = Gear(**_d("planet1"))
    sunB: Gear = Gear(**_d("sunB"))
    planet2: Gear = Gear(**_d("planet2"))
    nPairs: int = _d("nPairs")
    carrier: Carrier = Carrier(**_d("carrier"))

    @classmethod
    def paper(cls) -> "GearTable":
        """The paper's gear table (tip diameters as printed)."""
        return cls()

    def gears(self) -> dict[str, Gear]:
        return {"sunA": self.sunA, "planet1": self.planet1, "sunB": self.sunB, "planet2": self.planet2}

    def with_gear(self, name: str, **changes) -> "GearTable":
        """A copy with one gear's fields changed, e.g. ``with_gear('sunA', x=-0.5)``."""
        return replace(self, **{name: replace(getattr(self, name), **changes)})

    # the fields' fixed ranges (spurdiff.errors: validate and the FMUs' min/max); rhoaP0's upper bound
    # and hf's lower one depend on other fields and are checked in validate
    BOUNDS = {
        "m": Bound(0.0, lo_open=True),
        "alpha": Bound(math.radians(10.0), math.radians(35.0), allowed="between 10 and 35 deg (0.1745 .. 0.6109 rad)"),
        "ha": Bound(0.0, lo_open=True),
        "hf": Bound(0.0, lo_open=True),
        "haP0": Bound(0.5, 2.0, allowed="between 0.5 and 2 (ISO 53: 1.25)"),
        "rhoaP0": Bound(0.0, 2.0),   # and <= what fits the tool tip (validate)
        "nPairs": Bound(1, 12, integer=True),
    }

    def validate(self) -> None:
        """Raise ParameterError for values no gear set can have (before any geometry)."""
        for name, b in self.BOUNDS.items():
            b.check("nPairs" if name == "nPairs" else f"gearing.{name}", getattr(self, name))
        a, h0, rho = self.alpha, self.haP0, self.rhoaP0
        if self.hf <= self.ha:
            raise ParameterError("gearing.hf", self.hf, f"> gearing.ha = {self.ha:g} (root clearance)")
        ta, ca = math.tan(a), math.cos(a)
        rho_max = max(0.0, (math.pi / 4.0 - h0 * ta) / (1.0 / ca - ta))   # the rounding fits the tool tip
        rho_max = min(rho_max, h0)
        if not 0.0 <= rho <= rho_max:
            raise ParameterError("gearing.rhoaP0", self.rhoaP0,
                                 f"between 0 and {rho_max:.4f} (the tip rounding must fit the tool tooth; ISO 53: 0.38)")
        for name, g in self.gears().items():
            check_fields(g, f"{name}.")
        check_fields(self.carrier, "carrier.")


@record(frozen=True)
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
    rF: float   # radius where the generated involute starts (form radius, undercut included)
    sa: float   # tip thickness (arc, on the tip circle)
    undercut: bool = False  # the generating tool's tip cuts into the involute


@record(frozen=True)
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
    path_length: float    # length of the path of contact g_alpha (tips as given, involutes to the base)
    rF1: float = 0.0      # form radius of gear 1 (start of its involute)
    rF2: float = 0.0      # form radius of gear 2

    def tip_limit(self, gear: str) -> float:
        """Largest tip radius of ``gear`` free of interference: its tip may reach the mating gear's
        form circle (where its involute starts; the base circle unless undercut), not below it:
        ``sqrt(rb^2 + (a sin(alpha_w) - sqrt(r_F,mate^2 - r_b,mate^2))^2)``."""
        L = self.a * math.sin(self.alpha_w)
        if gear == self.gear1:
            rb, rbm, rFm = self.rb1, self.rb2, self.rF2
        else:
            rb, rbm, rFm = self.rb2, self.rb1, self.rF1
        return math.hypot(rb, L - math.sqrt(max(max(rFm, rbm) ** 2 - rbm ** 2, 0.0)))

    @property
    def usable_path(self) -> tuple[float, float]:
        """Start and end of the usable path of contact, as distances from gear 1's base tangent
        point along the line of action (m): contact runs on involute flanks only, from the form
        circle (start of the involute, :mod:`spurdiff.gears.generating`) to the tip of each gear:
        ``l_start = max(L - sqrt(r_a2^2 - r_b2^2), sqrt(r_F1^2 - r_b1^2))``,
        ``l_end = min(sqrt(r_a1^2 - r_b1^2), L - sqrt(r_F2^2 - r_b2^2))``, ``L = a sin(alpha_w)``.
        A tip reaching past the mating form circle is assumed relieved there (its excess does
        not carry)."""
        L = self.a * math.sin(self.alpha_w)
        lF1 = math.sqrt(max(max(self.rF1, self.rb1) ** 2 - self.rb1 ** 2, 0.0))
        lF2 = math.sqrt(max(max(self.rF2, self.rb2) ** 2 - self.rb2 ** 2, 0.0))
        la1 = math.sqrt(max(self.ra1 ** 2 - self.rb1 ** 2, 0.0))
        la2 = math.sqrt(max(self.ra2 ** 2 - self.rb2 ** 2, 0.0))
        return max(L - la2, lF1), min(la1, L - lF2)

    @property
    def epsilon_usable(self) -> float:
        """Usable transverse contact ratio: the usable path (involute to tip on both gears) over
        the base pitch."""
        l0, l1 = self.usable_path
        return (l1 - l0) / self.pb

    def sap_distance(self, gear: str) -> float:
        """Where contact with the mating tip starts on ``gear`` (start of active profile, tips as
        given), as the distance from ``gear``'s base tangent point along the line of action (m);
        negative: the mating tip reaches past that point (involute interference)."""
        L = self.a * math.sin(self.alpha_w)
        if gear == self.gear1:
            return L - math.sqrt(max(self.ra2 ** 2 - self.rb2 ** 2, 0.0))
        return L - math.sqrt(max(self.ra1 ** 2 - self.rb1 ** 2, 0.0))

    def start_of_active_profile(self, gear: str) -> float:
        """Radius of the start of active profile on ``gear`` (m; on the involute's mirror branch
        if the mating tip reaches past the base tangent point)."""
        rb = self.rb1 if gear == self.gear1 else self.rb2
        return math.hypot(rb, self.sap_distance(gear))

    @property
    def ratio(self) -> float:
        """Speed ratio z2/z1 = rw2/rw1."""
        return self.rw2 / self.rw1


@record(frozen=True)
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
    # start of the generated involute: the end of the tool's straight flank, or where the
    # trochoid of its tip rounding crosses the involute (undercut), see spurdiff.gears.generating
    if ra > rb:
        rF, undercut = form_radius(g.z, g.x, m, alpha, t.haP0, t.rhoaP0, ra)
    else:
        rF, undercut = rb, False
    if ra <= rb:
        sa = float("-inf")
    else:
        alpha_a = math.acos(rb / ra)
        sa = 2.0 * ra * ((math.pi / 2.0 + 2.0 * g.x * math.tan(alpha)) / g.z + inv(alpha) - inv(alpha_a))
    return GearGeometry(name, g.z, g.x, g.b, r, rb, ra, rf, rF, sa, undercut)


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
                        g_alpha / pb, pb, min(g1.b, g2.b), g_alpha, g1.rF, g2.rF)


@record(frozen=True)
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
