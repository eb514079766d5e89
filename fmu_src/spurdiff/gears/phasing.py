"""Mesh phasing of one planet pair from the tooth positions (Parker and Lin's planetary phasing).

A mesh phase says where the tooth pairs of a mesh are along its path of contact: with the pairs
one base pitch ``p_b`` apart, the phase ``xi`` in [0, 1) is the position of a pair measured from
the start of the usable path (gear 1's side), in base pitches. The stiffness wave and the flank
friction of :mod:`spurdiff.differential.mesh` read it.

Geometry (all angles in the carrier, gear centres from :class:`spurdiff.gears.layout.PinLayout`):

* tooth ``i`` of a gear with ``z`` teeth has its centre line at ``phi + 2 pi i / z``; its flanks
  leave the base circle at ``phi + 2 pi i / z -+ psi_b`` with the half tooth angle at the base
  circle ``psi_b = (pi / 2 + 2 x tan(alpha)) / z + inv(alpha)`` (ISO 21771; tooth thickness from
  the profile shift, zero-backlash tooth thicknesses);
* a mesh between gear 1 (centre C1) and gear 2, centre line at angle ``theta_d``, has two lines
  of action, tangent to gear 1's base circle at ``tau_1 = theta_d -+ alpha_w``. The line tangent
  at ``theta_d + alpha_w`` meets gear 1's "-" flanks (``phi - psi_b`` side) at the distance
  ``s = r_b1 (tau_1 - beta)`` from the tangent point, for every flank start angle ``beta``;
  the line at ``theta_d - alpha_w`` meets the "+" flanks at ``s = r_b1 (beta - tau_1)``.
  Contact on the "-" flanks gives both gears a positive moment (the drive side of meshes A1 and
  B2, whose normal force is positive then), on the "+" flanks a negative one (the drive side of
  mesh 12, whose positive force turns both planets backwards). Gear 2's flanks are placed in the
  same way with ``s_2 = L - s_1``, ``L = a sin(alpha_w)``;
* the reference: an A1 drive pair at the pitch point (the mesh model's start). That fixes
  planet 1's tooth angle; meshing without backlash fixes planet 2's (through mesh 12) and with
  it the phase of mesh B2.

Planetary phasing (Parker and Lin 2004, "Mesh phasing relationships in planetary and epicyclic
gears", J. Mech. Des. 126(2) 365-370): the sun mesh of the pair at carrier angle
``2 pi j / n`` lags pair 0 by ``frac(z_sun j / n)`` mesh periods. With ``z_sun / n`` an integer
for both suns all pairs mesh in phase and the lumped model (one representative pair, its forces
n times) is exact; otherwise they do not, and :func:`phase_findings` warns.
"""
from __future__ import annotations

import math

from spurdiff.gears.geometry import DifferentialGeometry, Finding, MeshGeometry, inv
from spurdiff.gears.layout import PinLayout
from spurdiff.attrpath import record


def _frac(v: float) -> float:
    f = v % 1.0
    return 0.0 if f >= 1.0 - 1e-12 else f


@record(frozen=True)
class MeshPhase:
    """Phases of one mesh at the reference configuration (pitches, in [0, 1))."""

    drive: float      # a pair of the drive-side flanks, from the start of the usable path
    coast: float      # the coast-side flanks
    pitch: float      # the pitch point


def _positions(rb: float, phi: float, psi_b: float, z: int, tau: float, flank: int) -> float:
    """Contact position (m, modulo one base pitch) of a gear's flanks on a line of action tangent
    at ``tau``: flank -1 ("-" flanks, s = rb (tau - beta)) or +1 (s = rb (beta - tau))."""
    beta = phi - psi_b if flank < 0 else phi + psi_b
    s = rb * (tau - beta) if flank < 0 else rb * (beta - tau)
    pb = 2.0 * math.pi * rb / z
    return s % pb


def _psi_b(z: int, x: float, alpha: float) -> float:
    return (math.pi / 2.0 + 2.0 * x * math.tan(alpha)) / z + inv(alpha)


def mesh_phases(geo: DifferentialGeometry) -> dict[str, MeshPhase]:
    """Phases of meshes A1, B2 and 12 of one planet pair, from the tooth positions; the
    reference is an A1 drive pair at its pitch point."""
    t = geo.table
    lay = PinLayout.of(geo)
    mA, mB, m12 = geo.meshA1, geo.meshB2, geo.mesh12
    th = lay.theta
    C1 = (mA.a, 0.0)
    C2 = (mB.a * math.cos(th), mB.a * math.sin(th))
    ang = math.atan2

    def centre_angle(frm, to):
        return ang(to[1] - frm[1], to[0] - frm[0])

    # lines of action, tangent points on each gear: (theta_d from gear 1 to gear 2)
    dA = centre_angle((0.0, 0.0), C1)         # mesh A1: gear 1 sun A at the origin, gear 2 planet 1
    dB = centre_angle((0.0, 0.0), C2)         # mesh B2: gear 1 sun B, gear 2 planet 2
    d12 = centre_angle(C1, C2)                # mesh 12: gear 1 planet 1, gear 2 planet 2
    a_ = t.alpha
    psi1 = _psi_b(t.planet1.z, t.planet1.x, a_)
    psi2 = _psi_b(t.planet2.z, t.planet2.x, a_)
    rb1, rb2 = mA.rb2, mB.rb2
    z1, z2 = t.planet1.z, t.planet2.z

    def drive_flank(me_name: str) -> int:
        # "-" flanks of gear 1 carry positive forces of A1/B2 (sigma = +1); "+" flanks those of 12
        return -1 if me_name in ("A1", "B2") else +1

    def on_gear2(me: MeshGeometry, theta_d: float, flank: int, rb: float, phi: float, psi: float, z: int) -> float:
        """Position from gear 1's tangent point of gear 2's flank contacts on the line with
        gear-1 flank side ``flank`` (gear 2 uses the same side by point symmetry about P)."""
        L = me.a * math.sin(me.alpha_w)
        tau1 = theta_d + me.alpha_w if flank < 0 else theta_d - me.alpha_w
        tau2 = tau1 + math.pi
        s2 = _positions(rb, phi, psi, z, tau2, flank)
        return (L - s2) % me.pb

    def on_gear1(me: MeshGeometry, theta_d: float, flank: int, rb: float, phi: float, psi: float, z: int) -> float:
        tau1 = theta_d + me.alpha_w if flank < 0 else theta_d - me.alpha_w
        return _positions(rb, phi, psi, z, tau1, flank)

    def phase(me: MeshGeometry, s: float) -> float:
        l0, _ = me.usable_path
        return _frac((s - l0) / me.pb)

    def pitch_phase(me: MeshGeometry) -> float:
        return phase(me, me.rb1 * math.tan(me.alpha_w))

    # 1. planet 1 (gear 2 of A1): an A1 drive pair at the pitch point
    fA = drive_flank("A1")
    s_pitch = mA.rb1 * math.tan(mA.alpha_w)
    # find phi1 with on_gear2(A1, drive) == s_pitch: linear in phi1 with slope -+ rb1
    base = on_gear2(mA, dA, fA, rb1, 0.0, psi1, z1)
    # on gear 2 the drive line is the one with tau2 = tau1 + pi; s2 grows with phi for "-" flanks
    # read from gear 1 (L - s2): decreases; solve by shifting phi1
    slope = -rb1 if fA < 0 else rb1              # d(s2)/d(phi) on gear 2's flank side
    # position from gear 1 = L - s2: d/dphi = -slope
    phi1 = ((base - s_pitch) / slope) % (2.0 * math.pi / z1)
    assert abs(((on_gear2(mA, dA, fA, rb1, phi1, psi1, z1) - s_pitch + mA.pb / 2) % mA.pb) - mA.pb / 2) < 1e-9
    # 2. mesh 12 from planet 1 (its gear 1)
    f12 = drive_flank("12")
    s12_drive = on_gear1(m12, d12, f12, rb1, phi1, psi1, z1)
    s12_coast = on_gear1(m12, d12, -f12, rb1, phi1, psi1, z1)
    sA_coast = on_gear2(mA, dA, -fA, rb1, phi1, psi1, z1)
    # 3. planet 2 placed so that its drive flanks of mesh 12 meet planet 1's (no backlash)
    base2 = on_gear2(m12, d12, f12, rb2, 0.0, psi2, z2)
    slope2 = -rb2 if f12 < 0 else rb2
    phi2 = ((base2 - s12_drive) / slope2) % (2.0 * math.pi / z2)
    # 4. mesh B2 from planet 2 (its gear 2)
    fB = drive_flank("B2")
    sB_drive = on_gear2(mB, dB, fB, rb2, phi2, psi2, z2)
    sB_coast = on_gear2(mB, dB, -fB, rb2, phi2, psi2, z2)
    return {
        "A1": MeshPhase(phase(mA, s_pitch), phase(mA, sA_coast), pitch_phase(mA)),
        "B2": MeshPhase(phase(mB, sB_drive), phase(mB, sB_coast), pitch_phase(mB)),
        "12": MeshPhase(phase(m12, s12_drive), phase(m12, s12_coast), pitch_phase(m12)),
        "_planets": (phi1, phi2),
    }


def pair_phases(z_sun: int, n: int) -> list[float]:
    """Parker and Lin's sun-mesh phases of the n equally spaced pairs relative to pair 0 (mesh
    periods, in [0, 1)): ``frac(z_sun j / n)``."""
    return [_frac(z_sun * j / n) for j in range(n)]


def phase_findings(geo: DifferentialGeometry) -> list[Finding]:
    """A warning when a sun's tooth count is not a multiple of nPairs (pairs out of phase)."""
    t = geo.table
    n = t.nPairs
    out = []
    for sun in ("sunA", "sunB"):
        z = getattr(t, sun).z
        if z % n:
            ph = ", ".join(f"{p:.3f}" for p in pair_phases(z, n))
            out.append(Finding("warning", "mesh-phasing", "nPairs",
                               f"{sun}.z / nPairs = {z} / {n} is not an integer: the pairs mesh out of phase "
                               f"(sun mesh phases {ph} mesh periods, Parker and Lin 2004), so the one simulated pair "
                               f"no longer stands for all"))
    return out
