"""Where the gears of one planet pair sit and how fast they turn relative to the carrier.

:class:`PinLayout`: the pin positions from the three centre distances and the directions of the
mesh forces on the two planets (the pin loads of the locking law, :mod:`spurdiff.differential.locking`,
and the mesh phasing, :mod:`spurdiff.gears.phasing`, read it). :func:`kinematics`: the speed
ratios of the planets and of sun B relative to sun A, from the tooth counts (external meshes:
``w_1 = -(z_a/z_1) (w_A - w_c)``, ``w_2 = -(z_1/z_2) w_1``, ``w_B - w_c = -(z_a/z_b) (w_A - w_c)``).
"""
from __future__ import annotations

import math

from spurdiff.gears.geometry import DifferentialGeometry
from spurdiff.attrpath import record


PIN_MODELS = ("endReactions", "linearPressure", "planar")
HANDEDNESS = ("leading", "trailing")
_ZERO8 = (0.0,) * 8


@record(frozen=True)
class PinLayout:
    """Directions of the mesh forces on the two planets of a pair (unit vectors, in the carrier),
    and where along each planet's journal they act.

    Sun axis at the origin, planet 1 at angle 0 (radius a_A1), planet 2 at +theta (``handedness``
    leading: planet 2 leads planet 1 in the positive sense of rotation; trailing: at -theta, the
    mirrored assembly), a_12 from planet 1, theta from the triangle of centre distances. The force of
    a mesh with normal force F (> 0: positive moment on both gears, the drive flank) on its first
    gear is ``F cos(a_w) e - |F| sin(a_w) d`` (d from gear 1 to gear 2, e = z x d): the tangential
    part carries the moment, the radial part separates the gears. ``vectors[4 i: 4 i + 4]`` are,
    for planet i, the tangential and radial unit parts of its sun mesh force and of the
    planet-planet mesh force (per unit F_12).

    The pin (docs/locking-law.md): a rigid planet on a journal of length L, its sun mesh force at
    ``zeta_s L``, its planet mesh force at ``zeta_12 L`` and its inertial load at ``zeta_m L`` from
    the journal's start (:class:`spurdiff.gears.axial.AxialLayout`). The journal's end reactions are
    ``R_0 = sum (1 - zeta_k) F_k`` and ``R_L = sum zeta_k F_k`` (vectors); the friction moment of
    ``pinModel``

    * ``endReactions``: ``mu r (|R_0| + |R_L|)`` (the load carried at the bushing's two ends);
    * ``linearPressure``: ``mu r int_0^L |q(z)| dz`` with the pressure linear along the journal,
      ``q(0) L = 4 R_0 - 2 R_L``, ``q(L) L = 4 R_L - 2 R_0``;
    * ``planar``: every load in one plane, ``mu r |R_0 + R_L|`` (the law before issue 41).

    A planet whose loads all lie in one plane gets the planar arithmetic whatever the model (all
    three are equal there): ``ends[i]`` is then (flat coefficients, 1, zeros, 0), so the end
    reaction sum reproduces the planar law's result bit for bit. ``ends[i] = (c0, w0, cL, wL)``:
    the 8 coefficients of each end (the sun mesh's parts scaled by ``1 - zeta_s`` / ``zeta_s``,
    the planet mesh's by ``1 - zeta_12`` / ``zeta_12``) and the share of the inertial load.
    """

    theta: float
    vectors: tuple
    zeta: tuple = ((0.5, 0.5, 0.5), (0.5, 0.5, 0.5))   # per planet: sun mesh, planet mesh, mass (z / L)
    model: str = "planar"

    @classmethod
    def of(cls, geo: DifferentialGeometry, model: str = "planar", handedness: str = "leading",
           zeta: tuple | None = None) -> "PinLayout":
        """The layout of ``geo``; ``zeta`` (per planet: sun mesh, planet mesh, mass as z / L along
        its journal) from the axial layout of the gear table unless given."""
        if model not in PIN_MODELS:
            raise ValueError(f"pinModel {model!r}: one of {', '.join(PIN_MODELS)}")
        if handedness not in HANDEDNESS:
            raise ValueError(f"pairHandedness {handedness!r}: one of {', '.join(HANDEDNESS)}")
        mA, mB, m12 = geo.meshA1, geo.meshB2, geo.mesh12
        aA, aB, a12 = mA.a, mB.a, m12.a
        th = math.acos(max(-1.0, min(1.0, (aA ** 2 + aB ** 2 - a12 ** 2) / (2.0 * aA * aB))))
        if handedness == "trailing":
            th = -th
        dA = (1.0, 0.0)
        dB = (math.cos(th), math.sin(th))
        P1 = (aA, 0.0)
        P2 = (aB * dB[0], aB * dB[1])
        d12 = ((P2[0] - P1[0]) / a12, (P2[1] - P1[1]) / a12)

        def perp(d):
            return (-d[1], d[0])

        eA, eB, e12 = perp(dA), perp(dB), perp(d12)
        cA, sA = math.cos(mA.alpha_w), math.sin(mA.alpha_w)
        cB, sB = math.cos(mB.alpha_w), math.sin(mB.alpha_w)
        c12, s12 = math.cos(m12.alpha_w), math.sin(m12.alpha_w)
        # trailing: the same formulas with planet 2 at -theta (they hold for any placement; the sign
        # conventions of the forces are those of the moment balances, not of the picture)
        vectors = (
            (-cA * eA[0], -cA * eA[1]), (sA * dA[0], sA * dA[1]),                        # on planet 1 from sun A
            (-c12 * e12[0], -c12 * e12[1]), (-s12 * d12[0], -s12 * d12[1]),      # on planet 1 from planet 2
            (-cB * eB[0], -cB * eB[1]), (sB * dB[0], sB * dB[1]),                        # on planet 2 from sun B
            (c12 * e12[0], c12 * e12[1]), (s12 * d12[0], s12 * d12[1]),          # on planet 2 from planet 1
        )
        if zeta is None:
            from spurdiff.gears.axial import AxialLayout
            zeta = AxialLayout.of(geo.table).load_positions
        return cls(th, vectors, tuple(tuple(float(v) for v in z) for z in zeta), model)

    def __post_init__(self):
        flat = tuple(c for v in self.vectors for c in v)
        flat = (flat[:8], flat[8:])
        object.__setattr__(self, "_flat", flat)
        ends = []
        for i in (0, 1):
            zs, z12, zm = self.zeta[i]
            f = flat[i]
            if self.model == "planar" or zs == z12 == zm:
                ends.append((f, 1.0, _ZERO8, 0.0))
                continue
            ws0, w120 = 1.0 - zs, 1.0 - z12
            c0 = (f[0] * ws0, f[1] * ws0, f[2] * ws0, f[3] * ws0, f[4] * w120, f[5] * w120, f[6] * w120, f[7] * w120)
            cL = (f[0] * zs, f[1] * zs, f[2] * zs, f[3] * zs, f[4] * z12, f[5] * z12, f[6] * z12, f[7] * z12)
            ends.append((c0, 1.0 - zm, cL, zm))
        object.__setattr__(self, "ends", tuple(ends))

    @property
    def planar(self) -> bool:
        """Both planets carry their loads in one plane (the planar arithmetic)."""
        return all(e[3] == 0.0 and e[2] == _ZERO8 for e in self.ends)

    def end_reactions(self, i: int, Fs: float, F12: float, g=(0.0, 0.0)) -> tuple:
        """The end reactions (R_0x, R_0y, R_Lx, R_Ly) of planet i's journal (N) for the mesh forces
        and the inertial load ``g``, at the loads' axial positions ``zeta`` (whatever the model)."""
        tx, ty, rx, ry, ux, uy, qx, qy = self._flat[i]
        zs, z12, zm = self.zeta[i]
        aS, a12 = abs(Fs), abs(F12)
        sx, sy = Fs * tx + aS * rx, Fs * ty + aS * ry          # the sun mesh's force on the planet
        px, py = F12 * ux + a12 * qx, F12 * uy + a12 * qy      # the planet mesh's
        RLx = zs * sx + z12 * px + zm * g[0]
        RLy = zs * sy + z12 * py + zm * g[1]
        return (sx + px + g[0] - RLx, sy + py + g[1] - RLy, RLx, RLy)

    def pin_force(self, i: int, Fs: float, F12: float, g=(0.0, 0.0)) -> tuple[float, float, float]:
        """The pin's friction load of planet i (N; the friction moment is the lever times it: the
        bearing force |R_0 + R_L| planar, |R_0| + |R_L| with the end reactions, the integral of the
        pressure with the linear distribution) with Fs = F_A1 (planet 1) or F_B2 (planet 2), and
        its derivatives with respect to Fs and F12; ``g`` the planet's inertial load (N)."""
        if self.model == "linearPressure" and self.ends[i][3] != 0.0:
            return self._linear_pressure_force(i, Fs, F12, g)
        sgS = 1.0 if Fs >= 0.0 else -1.0
        sg12 = 1.0 if F12 >= 0.0 else -1.0
        aS, a12 = abs(Fs), abs(F12)
        tot = dS = d12 = 0.0
        for c, w in ((self.ends[i][0], self.ends[i][1]), (self.ends[i][2], self.ends[i][3])):
            tx, ty, rx, ry, ux, uy, qx, qy = c
            fx = Fs * tx + aS * rx + F12 * ux + a12 * qx + w * g[0]
            fy = Fs * ty + aS * ry + F12 * uy + a12 * qy + w * g[1]
            mag = math.sqrt(fx * fx + fy * fy)
            if mag == 0.0:
                continue
            tot = tot + mag
            dS = dS + (fx * (tx + sgS * rx) + fy * (ty + sgS * ry)) / mag
            d12 = d12 + (fx * (ux + sg12 * qx) + fy * (uy + sg12 * qy)) / mag
        return tot, dS, d12

    def _linear_pressure_force(self, i, Fs, F12, g):
        """linearPressure's load and its derivatives (central differences: the quasi-static law only)."""
        val = linear_pressure_load(*self.end_reactions(i, Fs, F12, g))
        hS = 1e-7 * (abs(Fs) + abs(F12)) + 1e-9
        dS = (linear_pressure_load(*self.end_reactions(i, Fs + hS, F12, g))
              - linear_pressure_load(*self.end_reactions(i, Fs - hS, F12, g))) / (2 * hS)
        d12 = (linear_pressure_load(*self.end_reactions(i, Fs, F12 + hS, g))
               - linear_pressure_load(*self.end_reactions(i, Fs, F12 - hS, g))) / (2 * hS)
        return val, dS, d12

    def unit_pin_loads(self, sign: float = 1.0) -> tuple[float, float]:
        """|F_pin,1|, |F_pin,2| per unit mesh force with all three mesh forces equal to ``sign``
        (+1 drive, -1 coast): the pins' friction loads of :meth:`pin_force`."""
        return self.pin_force(0, sign, sign)[0], self.pin_force(1, sign, sign)[0]


def linear_pressure_load(R0x: float, R0y: float, RLx: float, RLy: float) -> float:
    """``int_0^L |q(z)| dz`` (N) for the pressure q linear along a journal of length L whose end
    reactions are R_0 and R_L (vectors): ``q(0) L = A = 4 R_0 - 2 R_L``, ``q(L) L = B = 4 R_L - 2 R_0``,
    so the integral is ``int_0^1 |A + D t| dt`` with ``D = B - A``, in closed form
    (``|A + D t| = |D| sqrt((t + p)^2 + h^2)``, ``p = A.D / |D|^2``, ``h = |A x D| / |D|^2``):
    ``|D| / 2 [u s + h^2 asinh(u / h)]`` from ``u = p`` to ``1 + p``, ``s = sqrt(u^2 + h^2)``.
    Equals ``|R_0 + R_L|`` when both ends push the same way with 1/2 <= |R_0|/|R_L| <= 2; 3 |R| for
    a pure couple (R_0 = -R_L = R), against 2 |R| with the end reactions (docs/locking-law.md)."""
    Ax, Ay = 4.0 * R0x - 2.0 * RLx, 4.0 * R0y - 2.0 * RLy
    Dx, Dy = 6.0 * (RLx - R0x), 6.0 * (RLy - R0y)
    d2 = Dx * Dx + Dy * Dy
    if d2 == 0.0:
        return math.hypot(Ax, Ay)
    dn = math.sqrt(d2)
    p = (Ax * Dx + Ay * Dy) / d2
    h = abs(Ax * Dy - Ay * Dx) / d2

    def prim(u):
        s = math.hypot(u, h)
        return u * s + (h * h * math.asinh(u / h) if h > 0.0 else 0.0)

    if h == 0.0:            # A parallel to D: |u| integrated
        u0, u1 = p, 1.0 + p
        return dn * 0.5 * (u1 * abs(u1) - u0 * abs(u0))
    return dn * 0.5 * (prim(1.0 + p) - prim(p))


@record(frozen=True)
class Kinematics:
    """Speed ratios of the differential relative to the carrier (dimensionless)."""

    planet1_per_sunA: float   # w_1 / (w_A - w_c)
    planet2_per_sunA: float   # w_2 / (w_A - w_c)
    sunB_per_sunA: float      # (w_B - w_c) / (w_A - w_c)


def kinematics(geo: DifferentialGeometry) -> Kinematics:
    t = geo.table
    p1 = -t.sunA.z / t.planet1.z
    p2 = -t.planet1.z / t.planet2.z * p1
    b = -t.planet2.z / t.sunB.z * p2
    return Kinematics(p1, p2, b)
