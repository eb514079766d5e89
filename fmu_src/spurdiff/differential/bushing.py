"""The planets' pin bushings: the data sets of ``spurdiff/data/pin_bushing.toml`` (each value with
its source there), the friction lever they give the locking law, and the design findings they
raise (rim backup ratio of the planets, bushing pressure p and pv against the material's limits).

The lever of the pin-load law (:mod:`spurdiff.differential.locking`) is ``mu' r_j``: ``r_j`` the
journal radius, ``mu' = mu_s / sqrt(1 + mu_s^2)`` the friction-circle coefficient of a journal
bearing where the data set says so (the paper's set uses its ``mu`` as published). The static
coefficient gives the break-away lever (``mu_pin`` of the model: the stuck differential and its
break-away, the locking coefficient K), the dynamic one the sliding lever (``mu_pinDynamic``: the
friction while the differential slips, the sliding K), each with the friction-circle correction
where the data set has it.

Bushing length: the planet's face width (planet 1: 22 mm, planet 2: 40 mm in the paper's set). With
the journals' end reactions the pressure checked is the edge pressure of the linear distribution.
Backup ratio ``m_B = s_R / h_t`` with the rim ``s_R = (d_f - d_bore) / 2`` under the tooth root
and the tooth height ``h_t = (d_a - d_f) / 2``; ``d_bore = 2 (r_j + wall)``.
"""
from __future__ import annotations

import math

from spurdiff.datafile import parse_bundled
from spurdiff.gears.geometry import DifferentialGeometry
from spurdiff.attrpath import record

PIN_DATA = "pin_bushing.toml"
# read once at import, from this package's own data folder (see spurdiff.datafile)
_SETS = parse_bundled(PIN_DATA)
PIN_SETS = tuple(_SETS)
BACKUP_RATIO_MIN = 1.2      # AGMA 2001-D04 / ISO 6336-3: rim as solid at and above (pin_bushing.toml)


@record(frozen=True)
class Bushing:
    name: str
    description: str
    material: str
    lubrication: str
    muStatic: float
    muDynamic: float
    frictionCircle: bool
    journalRadius: float
    bushingWall: float
    pMax: float
    vMax: float
    pvMax: float

    @property
    def mu_effective(self) -> float:
        """The coefficient the locking law uses with ``journalRadius``: mu_s / sqrt(1 + mu_s^2)
        with the friction-circle correction, else mu_s."""
        mu = self.muStatic
        return mu / math.sqrt(1.0 + mu * mu) if self.frictionCircle else mu

    @property
    def lever(self) -> float:
        return self.mu_effective * self.journalRadius

    @property
    def mu_effective_dynamic(self) -> float:
        """The sliding coefficient the dynamics use while slipping (the model's ``mu_pinDynamic``):
        mu_d / sqrt(1 + mu_d^2) with the friction-circle correction, else mu_d."""
        mu = self.muDynamic
        return mu / math.sqrt(1.0 + mu * mu) if self.frictionCircle else mu

    @property
    def lever_dynamic(self) -> float:
        return self.mu_effective_dynamic * self.journalRadius


def bushing(name: str) -> Bushing:
    """The pin data set ``name`` (``paper`` or ``bronze``)."""
    if name not in _SETS:
        raise ValueError(f"pin data set {name!r}: the sets are {', '.join(PIN_SETS)}")
    d = _SETS[name]
    return Bushing(name, d["description"], d["material"], d["lubrication"], float(d["muStatic"]),
                   float(d["muDynamic"]), bool(d["frictionCircle"]), float(d["journalRadius"]),
                   float(d["bushingWall"]), float(d["pMax"]), float(d["vMax"]), float(d["pvMax"]))


@record(frozen=True)
class BushingCheck:
    planet: str
    backup_ratio: float
    p: float          # Pa, the largest pressure: the edge of the linear distribution (planar: the mean)
    v: float          # m/s, sliding speed on the journal
    pv: float         # Pa m/s, with p
    p_mean: float = 0.0   # Pa, net pin force / (journal diameter x length)

    def findings(self, b: Bushing) -> list[str]:
        out = []
        if self.backup_ratio < BACKUP_RATIO_MIN:
            out.append(f"{self.planet}: rim backup ratio s_R/h_t = {self.backup_ratio:.2f} < {BACKUP_RATIO_MIN:g} "
                       f"(thin rim under the bore: root stress raised, ISO 6336-3 Y_B > 1)")
        if self.p > b.pMax:
            out.append(f"{self.planet}: bushing pressure p = {self.p / 1e6:.1f} MPa > {b.pMax / 1e6:.1f} MPa")
        if self.pv > b.pvMax:
            out.append(f"{self.planet}: bushing pv = {self.pv / 1e6:.2f} MPa m/s > {b.pvMax / 1e6:.2f} MPa m/s")
        return out


def backup_ratio(geo: DifferentialGeometry, planet: str, b: Bushing) -> float:
    g = geo.gears[planet]
    rf, ra = g.rf, g.ra
    s_R = rf - (b.journalRadius + b.bushingWall)
    return s_R / (ra - rf)


def edge_pressure(R0x: float, R0y: float, RLx: float, RLy: float, d: float, L: float) -> tuple[float, float]:
    """(mean, edge) pressure of a journal of diameter d and length L (Pa) with end reactions R_0,
    R_L (N): mean ``|R_0 + R_L| / (d L)``; edge, the larger end of the linear distribution,
    ``max(|4 R_0 - 2 R_L|, |4 R_L - 2 R_0|) / (d L)`` (docs/locking-law.md)."""
    mean = math.hypot(R0x + RLx, R0y + RLy) / (d * L)
    edge = max(math.hypot(4 * R0x - 2 * RLx, 4 * R0y - 2 * RLy), math.hypot(4 * RLx - 2 * R0x, 4 * RLy - 2 * R0y))
    return mean, max(mean, edge / (d * L))


def check(geo: DifferentialGeometry, b: Bushing, pin_loads: tuple[float, float], w_rel: float,
          rho: tuple[float, float], reactions: tuple | None = None) -> tuple[BushingCheck, BushingCheck]:
    """Backup ratio, p, v and pv of the two planets' bushings for the pin loads (N, per planet)
    and the differential speed ``w_rel`` (sun A relative to the carrier, rad/s; the planets
    turn at ``rho_i w_rel`` on their pins). With the journals' end reactions (per planet
    R_0x, R_0y, R_Lx, R_Ly; :meth:`spurdiff.gears.layout.PinLayout.end_reactions`) p is the edge
    pressure of the linear distribution (a planet carrying a couple loads its bushing's ends),
    else the pin load over the projected area. Bushing length: the planet's face width."""
    out = []
    for k, planet in enumerate(("planet1", "planet2")):
        L = geo.gears[planet].b
        d = 2.0 * b.journalRadius
        if reactions is None:
            p = p_mean = pin_loads[k] / (d * L)
        else:
            p_mean, p = edge_pressure(*reactions[k], d, L)
        v = abs(rho[k] * w_rel) * b.journalRadius
        out.append(BushingCheck(planet, backup_ratio(geo, planet, b), p, v, p * v, p_mean))
    return tuple(out)
