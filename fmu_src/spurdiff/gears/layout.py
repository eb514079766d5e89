"""Where the gears of one planet pair sit and how fast they turn relative to the carrier.

:class:`PinLayout`: the pin positions from the three centre distances and the directions of the
mesh forces on the two planets (the pin loads of the locking law, :mod:`spurdiff.differential.locking`,
and the mesh phasing, :mod:`spurdiff.gears.phasing`, read it). :func:`kinematics`: the speed
ratios of the planets and of sun B relative to sun A, from the tooth counts (external meshes:
``w_1 = -(z_a/z_1) (w_A - w_c)``, ``w_2 = -(z_1/z_2) w_1``, ``w_B - w_c = -(z_a/z_b) (w_A - w_c)``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from spurdiff.gears.geometry import DifferentialGeometry


@dataclass(frozen=True)
class PinLayout:
    """Directions of the mesh forces on the two planets of a pair (unit vectors, in the carrier).

    Sun axis at the origin, planet 1 at angle 0 (radius a_A1), planet 2 at +theta (radius a_B2,
    a_12 from planet 1), theta from the triangle of centre distances. The force of a mesh with
    normal force F (> 0: positive moment on both gears, the drive flank) on its first gear is
    ``F cos(a_w) e - |F| sin(a_w) d`` (d from gear 1 to gear 2, e = z x d): the tangential part
    carries the moment, the radial part separates the gears. ``vectors[4 i: 4 i + 4]`` are, for
    planet i, the tangential and radial unit parts of its sun mesh force and of the planet-planet
    mesh force (per unit F_12).
    """

    theta: float
    vectors: tuple

    @classmethod
    def of(cls, geo: DifferentialGeometry) -> "PinLayout":
        mA, mB, m12 = geo.meshA1, geo.meshB2, geo.mesh12
        aA, aB, a12 = mA.a, mB.a, m12.a
        th = math.acos(max(-1.0, min(1.0, (aA ** 2 + aB ** 2 - a12 ** 2) / (2.0 * aA * aB))))
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
        vectors = (
            (-cA * eA[0], -cA * eA[1]), (sA * dA[0], sA * dA[1]),            # on planet 1 from sun A
            (-c12 * e12[0], -c12 * e12[1]), (-s12 * d12[0], -s12 * d12[1]),  # on planet 1 from planet 2
            (-cB * eB[0], -cB * eB[1]), (sB * dB[0], sB * dB[1]),            # on planet 2 from sun B
            (c12 * e12[0], c12 * e12[1]), (s12 * d12[0], s12 * d12[1]),      # on planet 2 from planet 1
        )
        return cls(th, vectors)

    def __post_init__(self):
        flat = tuple(c for v in self.vectors for c in v)
        object.__setattr__(self, "_flat", (flat[:8], flat[8:]))

    def pin_force(self, i: int, Fs: float, F12: float) -> tuple[float, float, float]:
        """|bearing force| of planet i (0: planet 1 with Fs = F_A1; 1: planet 2 with Fs = F_B2)
        and its derivatives with respect to Fs and F12."""
        tx, ty, rx, ry, ux, uy, qx, qy = self._flat[i]
        aS = abs(Fs)
        a12 = abs(F12)
        fx = Fs * tx + aS * rx + F12 * ux + a12 * qx
        fy = Fs * ty + aS * ry + F12 * uy + a12 * qy
        mag = math.sqrt(fx * fx + fy * fy)
        if mag == 0.0:
            return 0.0, 0.0, 0.0
        sgS = 1.0 if Fs >= 0.0 else -1.0
        sg12 = 1.0 if F12 >= 0.0 else -1.0
        dS = (fx * (tx + sgS * rx) + fy * (ty + sgS * ry)) / mag
        d12 = (fx * (ux + sg12 * qx) + fy * (uy + sg12 * qy)) / mag
        return mag, dS, d12

    def unit_pin_loads(self, sign: float = 1.0) -> tuple[float, float]:
        """|F_pin,1|, |F_pin,2| per unit mesh force with all three mesh forces equal to ``sign``
        (+1 drive, -1 coast)."""
        return self.pin_force(0, sign, sign)[0], self.pin_force(1, sign, sign)[0]


@dataclass(frozen=True)
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
