"""Layout of the mesh model: the state vector, the three meshes of a planet pair (geometry of
their paths of contact, stiffness, damping, backlash, phases) and the gears each mesh connects.

State ``y = (psi_A, d_A1, d_B2, d_12, v_A, v_B, w_1, w_2[, w_c, phi_c])`` (see
:mod:`spurdiff.differential.mesh.model`). Gears are numbered ``A, B, 1, 2`` = 0..3 (suns A and B, planets 1
and 2); their speeds relative to the carrier are the states ``v_A, v_B, w_1, w_2``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from spurdiff.gears.axial import AxialLayout
from spurdiff.gears.geometry import DifferentialGeometry
from spurdiff.differential.inertia import MassProperties
from spurdiff.gears.phasing import mesh_phases
from spurdiff.differential.mesh.laws import iso6336_stiffness
from spurdiff.differential.mesh.params import MeshParams

# state indices
PSI, DA, DB, D12, VA, VB, W1, W2, WC, PHIC = range(10)
MESHES = ("A1", "B2", "12")
GEAR_A, GEAR_B, GEAR_1, GEAR_2 = range(4)
SPEED = (VA, VB, W1, W2)          # state index of each gear's speed relative to the carrier


@dataclass(frozen=True)
class MeshData:
    """Derived constants of one mesh (per planet pair) and the gears it connects."""

    name: str
    sigma: float        # +1: F > 0 gives + torque on both gears (A1, B2); -1 for mesh 12
    rb1: float
    rb2: float
    k: float            # compliant stiffness (N/m)
    c: float            # compliant damping (N s/m)
    K: float            # contact stiffness (N/m^e)
    jn: float           # normal backlash along the line of action (m), 0 without backlash
    eps: float          # usable transverse contact ratio
    pb: float           # base pitch
    l1min: float        # distance from gear 1's base tangent point to the start of the path
    galpha: float       # length of the path of contact
    L: float            # a sin(alpha_w): distance between the two base tangent points
    xi0: float          # initial phase of the drive-side flanks (spurdiff.gears.phasing)
    xi0c: float         # initial phase of the coast-side flanks
    xip: float          # phase of the pitch point
    m_e: float          # equivalent mass (kg)
    d: int              # state index of the deflection
    g1: int             # first and second gear (GEAR_*)
    g2: int
    a1: float           # deflection rate d' = a1 W_g1 + a2 W_g2 (W: gear speeds rel. to the carrier)
    a2: float


def mesh_data(geo: DifferentialGeometry, ms: MassProperties, mp: MeshParams) -> tuple[MeshData, MeshData, MeshData]:
    """The three meshes of a planet pair, in the order A1, B2, 12."""
    n = ms.n_pairs
    t = geo.table
    gearpairs = {"A1": (t.sunA, t.planet1, ms.J_sunA / n, ms.J_planet1, GEAR_A, GEAR_1, DA),
                 "B2": (t.sunB, t.planet2, ms.J_sunB / n, ms.J_planet2, GEAR_B, GEAR_2, DB),
                 "12": (t.planet1, t.planet2, ms.J_planet1, ms.J_planet2, GEAR_1, GEAR_2, D12)}
    phases = mesh_phases(geo)
    axial = AxialLayout.of(t)
    widths = {name: axial.mesh_width(name) for name in MESHES}
    out = []
    for name, me in zip(MESHES, geo.meshes):
        g1, g2, J1, J2, i1, i2, d = gearpairs[name]
        # usable path: involute to tip on both gears (form circles from the generating rack)
        L = me.a * math.sin(me.alpha_w)
        l1min, l1max = me.usable_path
        galpha = l1max - l1min
        eps = galpha / me.pb
        ph = phases[name]
        m_e = 1.0 / (me.rb1 ** 2 / J1 + me.rb2 ** 2 / J2)
        k = getattr(mp, "stiffness" + name)
        if k <= 0.0:
            _, cg = iso6336_stiffness(g1.z, g1.x, g2.z, g2.x, eps, mp.youngsModulus, t.hf, math.degrees(t.alpha))
            # N/(mm um) per mm face width -> N/m per m; the face width the mesh has: the axial overlap of
            # its gears (spurdiff.gears.axial, issue 41: mesh B2 17 of 22 mm in the paper's set)
            k = cg * 1e9 * widths[name]
        c = 2.0 * mp.dampingRatio * math.sqrt(k * m_e)
        jn = getattr(mp, "backlash" + name) * math.cos(me.alpha_w) if mp.backlash else 0.0
        K = getattr(mp, "contactStiffness" + name)
        sigma = -1.0 if name == "12" else 1.0
        # external meshes: d_A1' = -(rb_A v_A + rb_1 w_1), d_B2' = -(rb_B v_B + rb_2 w_2),
        # d_12' = rb_1 w_1 + rb_2 w_2
        a1, a2 = (me.rb1, me.rb2) if name == "12" else (-me.rb1, -me.rb2)
        out.append(MeshData(name, sigma, me.rb1, me.rb2, k, c, K, jn, eps, me.pb, l1min, galpha, L, ph.drive,
                            ph.coast, ph.pitch, m_e, d, i1, i2, a1, a2))
    return tuple(out)


def relative_angles(c, yl) -> tuple[float, float, float]:
    """(psi_B, theta_1, theta_2) from psi_A and the deflections (``c``: the model's radii and the
    reference deflections ``_dA0, _dB0, _d120``)."""
    th1 = (c._dA0 - yl[DA] - c.rbA * yl[PSI]) / c.rb1
    th2 = (yl[D12] - c._d120 - c.rb1 * th1) / c.rb2
    psiB = (c._dB0 - yl[DB] - c.rb2 * th2) / c.rbB
    return psiB, th1, th2


def rolls(c, yl) -> tuple[float, float, float]:
    """Base-circle roll of the first gear of each mesh (m): (u_A1, u_B2, u_12)."""
    psiB, th1, _ = relative_angles(c, yl)
    return c.rbA * yl[PSI], c.rbB * psiB, c.rb1 * th1


def roll_gradients(rbA: float) -> tuple[tuple[float, float, float, float], ...]:
    """d(u_A1, u_B2, u_12)/d(psi_A, d_A1, d_B2, d_12): the rolls of :func:`rolls` are linear,
    ``u_A1 = rb_A psi_A``, ``u_12 = rb_1 theta_1 = d_A0 - d_A1 - rb_A psi_A``,
    ``u_B2 = rb_B psi_B = d_B0 - d_B2 - d_12 + d_120 + d_A0 - d_A1 - rb_A psi_A``."""
    return ((rbA, 0.0, 0.0, 0.0), (-rbA, -1.0, -1.0, -1.0), (-rbA, -1.0, 0.0, 0.0))


def split(N: int) -> tuple[tuple[int, ...], tuple[int, ...]] | None:
    """The positions and the velocities of the state with the carrier's speed imposed (N = 8; the
    integrator's ``split``): the positions' rates are the constant kinematic rows of
    :func:`constant_jacobian`, linear in the velocities alone. None with the carrier free (N = 10):
    its rigid rotation makes the Schur complement ill-conditioned at long steps (solve errors growing
    with h far beyond the LU's), so W there takes the general LU."""
    return ((PSI, DA, DB, D12), (VA, VB, W1, W2)) if N == 8 else None


def constant_jacobian(J, rbA: float, rb1: float, rbB: float, rb2: float, speed_drive: bool) -> None:
    """The rows of df/dy that do not depend on y (the kinematic rows), into ``J`` (rows, the rest zeroed)."""
    for row in J:
        row[:] = [0.0] * len(row)
    J[PSI][VA] = 1.0
    J[DA][VA] = -rbA
    J[DA][W1] = -rb1
    J[DB][VB] = -rbB
    J[DB][W2] = -rb2
    J[D12][W1] = rb1
    J[D12][W2] = rb2
    if not speed_drive:
        J[PHIC][WC] = 1.0
