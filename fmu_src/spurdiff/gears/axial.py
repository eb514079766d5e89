"""The differential along its axis: where each gear sits, the face width each mesh gets, where the
mesh forces act on the planets' pins, and the stack-up check.

Data (``spurdiff/data/differential.toml``, a gear set's file): each gear's ``axialStart`` (its face
starts there, measured from carrier wall A's inner face) and face width ``b``; the carrier's
``wallB`` (wall B's inner face) and ``axialClearance`` (the smallest running clearance between
faces that turn relative to each other). All lengths in m.

Derived (:class:`AxialLayout`):

* each mesh (``A1`` sun A - planet 1, ``12`` planet 1 - planet 2, ``B2`` sun B - planet 2) acts over
  the axial overlap of its two gears: face width ``b = min(end_1, end_2) - max(start_1, start_2)``
  and centre the middle of the overlap (a uniformly loaded face: the mesh force's line of action
  crosses the axis there);
* each planet turns on its pin over its own bore: the journal (bushing) runs from the planet's face
  start to its face end, length ``L = b``; the planet's mesh forces act at the meshes' centres,
  given as ``z / L`` from the journal's start (:attr:`AxialLayout.load_positions`), and its
  inertial (centrifugal, orbital) load at the planet's middle. These are the positions the 3-D pin
  law of :mod:`spurdiff.differential.locking` puts the forces at;
* a planet whose loads all act in one plane is *planar*: its pin carries no couple.

Stack-up findings (:meth:`AxialLayout.findings`, :class:`spurdiff.gears.geometry.Finding`, as the
design checks of :mod:`spurdiff.gears.checks`):

* ``axial-mesh`` error: a mesh whose gears do not overlap axially;
* ``mesh-width`` warning: a mesh narrower than the narrower of its gears (the face width the
  stress and stiffness see is the overlap, not ``b``);
* ``axial-stackup`` error: two parts that do not mesh, whose circles overlap radially (sun A and sun B
  always; planet 1's tip circle and sun B's, planet 2's and sun A's when they reach inside each
  other) and whose faces overlap axially; warning when the faces are apart by less than
  ``axialClearance``;
* ``carrier-wall`` error: a gear past a wall; warning: closer to a wall than ``axialClearance``.
"""
from __future__ import annotations

import math

from spurdiff.gears.geometry import MM, DifferentialGeometry, Finding, GearTable
from spurdiff.attrpath import record

MESHES = (("A1", "sunA", "planet1"), ("12", "planet1", "planet2"), ("B2", "sunB", "planet2"))
PLANETS = ("planet1", "planet2")
_LABEL = {"sunA": "sun A", "planet1": "planet 1", "sunB": "sun B", "planet2": "planet 2"}


def _mm(v: float) -> str:
    return f"{v / MM:.2f} mm"


@record(frozen=True)
class MeshAxial:
    """One mesh along the axis (m)."""

    name: str
    gear1: str
    gear2: str
    start: float
    end: float

    @property
    def width(self) -> float:
        """Face width of the mesh: the axial overlap of its gears (<= 0: they do not overlap)."""
        return self.end - self.start

    @property
    def centre(self) -> float:
        return 0.5 * (self.start + self.end)


@record(frozen=True)
class Journal:
    """A planet's bore on its pin: from ``start`` to ``end`` (m, along the axis); the positions of
    its sun mesh, its planet mesh and its mass centre as fractions of the length from ``start``."""

    planet: str
    start: float
    end: float
    sun_mesh: float      # z / L of the sun mesh's centre (planet 1: A1, planet 2: B2)
    planet_mesh: float   # z / L of mesh 12's centre
    mass: float          # z / L of the planet's centre of mass (0.5: a uniform planet)

    @property
    def length(self) -> float:
        return self.end - self.start

    @property
    def planar(self) -> bool:
        """All of the planet's loads act in one plane (its pin carries no couple)."""
        return self.sun_mesh == self.planet_mesh == self.mass


@record(frozen=True)
class AxialLayout:
    """The axial layout of a gear table (see the module docstring)."""

    starts: dict            # gear -> face start (m)
    widths: dict            # gear -> face width b (m)
    wallB: float
    clearance: float
    meshes: dict            # "A1" / "12" / "B2" -> MeshAxial
    journals: tuple         # (Journal of planet 1, Journal of planet 2)

    @classmethod
    def of(cls, t: GearTable) -> "AxialLayout":
        gears = t.gears()
        if any(g.axialStart is None for g in gears.values()):
            return cls.coplanar(t)
        starts = {n: g.axialStart for n, g in gears.items()}
        widths = {n: g.b for n, g in gears.items()}
        meshes = {}
        for name, g1, g2 in MESHES:
            s = max(starts[g1], starts[g2])
            e = min(starts[g1] + widths[g1], starts[g2] + widths[g2])
            meshes[name] = MeshAxial(name, g1, g2, s, e)
        journals = []
        for planet, sun_mesh in (("planet1", "A1"), ("planet2", "B2")):
            s, L = starts[planet], widths[planet]
            journals.append(Journal(planet, s, s + L, (meshes[sun_mesh].centre - s) / L,
                                    (meshes["12"].centre - s) / L, 0.5))
        return cls(starts, widths, t.carrier.wallB, t.carrier.axialClearance, meshes, tuple(journals))

    @classmethod
    def coplanar(cls, t: GearTable) -> "AxialLayout":
        """A table without an axial layout (an ``axialStart`` not given): every gear from 0, each mesh
        as wide as its narrower gear and centred at 0, planar journals; no stack-up check
        (:attr:`given` False, one warning in :meth:`findings`)."""
        gears = t.gears()
        meshes = {name: MeshAxial(name, g1, g2, -0.5 * min(gears[g1].b, gears[g2].b),
                                  0.5 * min(gears[g1].b, gears[g2].b)) for name, g1, g2 in MESHES}
        journals = tuple(Journal(p, -0.5 * gears[p].b, 0.5 * gears[p].b, 0.5, 0.5, 0.5) for p in PLANETS)
        out = cls({n: -0.5 * g.b for n, g in gears.items()}, {n: g.b for n, g in gears.items()},
                  t.carrier.wallB, t.carrier.axialClearance, meshes, journals)
        object.__setattr__(out, "given", False)
        return out

    given = True    # the gear table gives the layout (False: coplanar stand-in, see coplanar)

    def end(self, gear: str) -> float:
        return self.starts[gear] + self.widths[gear]

    def mesh_width(self, mesh: str) -> float:
        """Face width of mesh ``A1`` | ``12`` | ``B2`` (m): the axial overlap of its gears."""
        return self.meshes[mesh].width

    @property
    def load_positions(self) -> tuple:
        """Per planet: (sun mesh, planet mesh, mass centre) as z / L along its journal."""
        return tuple((j.sun_mesh, j.planet_mesh, j.mass) for j in self.journals)

    @property
    def planar(self) -> bool:
        """Every planet carries its loads in one plane (the planar pin law is exact)."""
        return all(j.planar for j in self.journals)

    def findings(self, geo: DifferentialGeometry):
        """The stack-up findings (a generator of :class:`Finding`; see the module docstring)."""
        if not self.given:
            missing = [n for n, g in geo.table.gears().items() if g.axialStart is None]
            yield Finding("warning", "axial-layout", f"{missing[0]}.axialStart",
                          f"no axial layout ({', '.join(m + '.axialStart' for m in missing)} not given): the meshes "
                          f"taken as coplanar, each as wide as its narrower gear (the planar pin law), no stack-up "
                          f"check")
            return
        c = self.clearance
        for me in self.meshes.values():
            b1, b2 = self.widths[me.gear1], self.widths[me.gear2]
            if me.width <= 0.0:
                yield Finding("error", "axial-mesh", f"{me.gear2}.axialStart",
                              f"mesh {me.name}: {_LABEL[me.gear1]} ({_mm(self.starts[me.gear1])} .. "
                              f"{_mm(self.end(me.gear1))}) and {_LABEL[me.gear2]} ({_mm(self.starts[me.gear2])} .. "
                              f"{_mm(self.end(me.gear2))}) do not overlap axially")
            elif me.width < min(b1, b2) * (1.0 - 1e-9):
                yield Finding("warning", "mesh-width", f"{me.gear2}.axialStart",
                              f"mesh {me.name} is {_mm(me.width)} wide (the axial overlap of {_LABEL[me.gear1]}, "
                              f"{_mm(b1)}, and {_LABEL[me.gear2]}, {_mm(b2)}); the narrower gear's face is not "
                              f"used in full: the stresses and the mesh stiffness follow {_mm(me.width)} "
                              f"(against {_mm(min(b1, b2))}: sigma_H x {math.sqrt(min(b1, b2) / me.width):.3f}, "
                              f"sigma_F x {min(b1, b2) / me.width:.3f})")
        # parts that do not mesh but reach radially inside each other must be apart axially
        ga, g1, gb, g2 = (geo.gears[n] for n in ("sunA", "planet1", "sunB", "planet2"))
        aA, aB = geo.meshA1.a, geo.meshB2.a
        pairs = [("sunA", "sunB", "coaxial suns", 0.0),
                 ("planet1", "sunB", "planet 1's tip circle reaches inside sun B's",
                  gb.ra - (aA - g1.ra)),
                 ("planet2", "sunA", "planet 2's tip circle reaches inside sun A's",
                  ga.ra - (aB - g2.ra))]
        for p, q, why, radial in pairs:
            if p != "sunA" and radial <= 0.0:
                continue
            gap = max(self.starts[p], self.starts[q]) - min(self.end(p), self.end(q))
            what = why if p == "sunA" else f"{why} by {_mm(radial)}"
            if gap < 0.0:
                yield Finding("error", "axial-stackup", f"{q}.axialStart",
                              f"{_LABEL[p]} and {_LABEL[q]} overlap axially by {_mm(-gap)} ({what}): they must "
                              f"sit in separate planes")
            elif gap < c * (1.0 - 1e-9):
                yield Finding("warning", "axial-stackup", f"{q}.axialStart",
                              f"{_LABEL[p]} and {_LABEL[q]} ({what}) are {_mm(gap)} apart axially, less than the "
                              f"running clearance carrier.axialClearance = {_mm(c)}")
        for n in self.starts:
            s, e = self.starts[n], self.end(n)
            if s < 0.0 or e > self.wallB:
                yield Finding("error", "carrier-wall", f"{n}.axialStart",
                              f"{_LABEL[n]} ({_mm(s)} .. {_mm(e)}) reaches past the carrier walls (0 .. "
                              f"{_mm(self.wallB)})")
            elif s < c * (1.0 - 1e-9) or self.wallB - e < c * (1.0 - 1e-9):
                yield Finding("warning", "carrier-wall", f"{n}.axialStart",
                              f"{_LABEL[n]} ({_mm(s)} .. {_mm(e)}) is closer to a carrier wall (0, "
                              f"{_mm(self.wallB)}) than carrier.axialClearance = {_mm(c)}")

    def summary(self) -> list[str]:
        """Lines for `spurdiff info`: gears, meshes and journals along the axis."""
        out = [f"carrier walls at 0 and {_mm(self.wallB)}; running clearance {_mm(self.clearance)}"]
        for n in self.starts:
            out.append(f"  {_LABEL[n]:9s} {_mm(self.starts[n]):>9s} .. {_mm(self.end(n)):>9s}  (b = {_mm(self.widths[n])})")
        for me in self.meshes.values():
            out.append(f"  mesh {me.name:3s} {_mm(me.start):>9s} .. {_mm(me.end):>9s}  face width {_mm(me.width)}, "
                       f"centre {_mm(me.centre)}")
        for j in self.journals:
            out.append(f"  {_LABEL[j.planet]} journal {_mm(j.start)} .. {_mm(j.end)} (L = {_mm(j.length)}): sun mesh "
                       f"at {j.sun_mesh:.4f} L, planet mesh at {j.planet_mesh:.4f} L, mass at {j.mass:.4f} L"
                       + (" (planar)" if j.planar else ""))
        return out


def axial_layout(geo_or_table) -> AxialLayout:
    """The :class:`AxialLayout` of a :class:`DifferentialGeometry` or a :class:`GearTable`."""
    t = geo_or_table.table if isinstance(geo_or_table, DifferentialGeometry) else geo_or_table
    return AxialLayout.of(t)


__all__ = ["AxialLayout", "MeshAxial", "Journal", "axial_layout", "MESHES", "PLANETS"]
