"""Limited life from a duty cycle: the gear set rated at each state of a cornering load spectrum
(``spurdiff/data/duty_cycle.toml``), the load cycles each gear's teeth see there, and Miner's sum
on the ISO 6336 life lines.

Life lines (ISO 6336-2:2006 table 2, ISO 6336-3:2006 table 3, case-hardened steel, no pitting
permitted; the same knees are used for the through-hardened material, whose root line ISO puts at
1e4 static, a conservative simplification): the permissible stress falls log-log-linearly from the
static value at ``N_static`` cycles to the endurance value at ``N_endurance`` and stays there::

    contact: sigma_HG(N) from sigma_Hlim Z_NT,static (Z_L Z_v Z_R = 1) at 1e5 to sigma_Hlim Z_L Z_v Z_R Z_W Z_X at 5e7
    root:    sigma_FG(N) from sigma_Flim Y_ST Y_NT,static at 1e3 to sigma_Flim Y_ST (x Y_M for the planets) at 3e6

A stress ``sigma`` above the endurance value allows ``N(sigma)`` cycles on that line (none above the
static value); below it, none are counted (Miner's original rule). Damage ``D = sum n_i / N_i``
per gear, mesh and mode (each flank of a planet meets one mesh; its root is counted per mesh with
the fully reversed endurance value). The limited-life safety ``S`` is the factor on every stress of
the spectrum at which ``D = 1`` (or the static value is reached): ``S < 1`` is a finding.

Cycles per state: sun A turns at ``w_rel`` relative to the carrier, sun B at ``-w_rel``, planet i at
``w_rel z_sun / z_i``; each sun tooth meets ``n`` planets per relative turn, each planet tooth its
two mates once per turn: ``N_sun = n w_rel t / (2 pi)``, ``N_planet = (z_sun / z_i) w_rel t / (2 pi)``.
Each state is rated at its carrier torque with the forces per N m given (the locked split at
break-away: a differential that turns in a corner slips at its locking torque) and with K_v at its
pitch-line speed.
"""
from __future__ import annotations

import math

from spurdiff.datafile import bundled_text, parse_bundled
from spurdiff.errors import ParameterError, require_finite
from spurdiff.gears.capacity.data import MPA, Conditions, Material, conditions, material
from spurdiff.gears.capacity.loads import face_widths, pitch_line_speed
from spurdiff.gears.capacity.rating import (IDLERS, rate_mesh, static_contact_strength, static_root_strength)
from spurdiff.gears.geometry import DifferentialGeometry, Finding
from spurdiff.attrpath import record

DUTY_FILE = "duty_cycle.toml"
_DUTY_TEXT = bundled_text(DUTY_FILE)   # read once, at import
N_H_STATIC, N_H_ENDURANCE = 1e5, 5e7     # ISO 6336-2 table 2, Eh (no pitting permitted)
N_F_STATIC, N_F_ENDURANCE = 1e3, 3e6     # ISO 6336-3 table 3, Eh


@record(frozen=True)
class DutyBin:
    name: str
    T0: float        # carrier torque, N m
    w_rel: float     # sun A relative to the carrier, rad/s
    hours: float


def duty_cycle(data: dict | None = None) -> tuple[DutyBin, ...]:
    """The bins of ``data`` (default: the bundled ``duty_cycle.toml``), checked."""
    data = parse_bundled(DUTY_FILE, _DUTY_TEXT) if data is None else data
    out = []
    for k, b in enumerate(data.get("bin", [])):
        try:
            bin_ = DutyBin(str(b["name"]), float(b["T0"]), float(b["w_rel"]), float(b["hours"]))
        except (KeyError, TypeError, ValueError) as e:
            raise ParameterError(f"duty_cycle.bin[{k}]", b, "a table with name, T0 (N m), w_rel (rad/s), hours", str(e)) from None
        for what in ("T0", "w_rel", "hours"):
            v = require_finite(f"duty_cycle.bin[{k}].{what}", getattr(bin_, what))
            if v < 0.0:
                raise ParameterError(f"duty_cycle.bin[{k}].{what}", v, ">= 0")
        out.append(bin_)
    if not out:
        raise ParameterError("duty_cycle.bin", None, "at least one bin")
    return tuple(out)


def allowed_cycles(sigma: float, G_static: float, G_end: float, N_static: float, N_end: float) -> float:
    """Cycles allowed at stress ``sigma`` on the log-log life line from ``(N_static, G_static)`` to
    ``(N_end, G_end)``: inf at or below ``G_end``, 0 above ``G_static``."""
    if sigma <= G_end:
        return math.inf
    if sigma > G_static:
        return 0.0
    k = math.log(N_end / N_static) / math.log(G_static / G_end)     # the line's slope exponent
    return N_static * (G_static / sigma) ** k


@record(frozen=True)
class LifeEntry:
    """One gear in one mesh, one mode (contact | root): cycles, damage and the limited-life safety."""

    mesh: str
    gear: str
    mode: str
    cycles: float         # load cycles over the spectrum
    damage: float         # Miner's sum
    S: float              # factor on the spectrum's stresses at which the damage reaches 1
    sigma_max: float      # the spectrum's largest stress, Pa


def _damage(stresses, cycles, line, k: float) -> float:
    D = 0.0
    for s, n in zip(stresses, cycles):
        if n <= 0.0:
            continue
        N = allowed_cycles(k * s, *line)
        if N == 0.0:
            return math.inf
        D += n / N
    return D


def _safety(stresses, cycles, line) -> float:
    """The factor k on the stresses at which the damage reaches 1 (or the static value)."""
    smax = max((s for s, n in zip(stresses, cycles) if n > 0.0), default=0.0)
    if smax <= 0.0:
        return math.inf
    k_static = line[0] / smax
    if _damage(stresses, cycles, line, k_static) < 1.0:
        return k_static
    lo, hi = line[1] / smax, k_static        # D(lo) = 0 < 1 <= D(hi)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if _damage(stresses, cycles, line, mid) < 1.0:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-12 * hi:
            break
    return 0.5 * (lo + hi)


@record(frozen=True)
class LifeReport:
    entries: tuple[LifeEntry, ...]
    findings: tuple[Finding, ...]
    K_gamma: float

    @property
    def S(self) -> float:
        return min(e.S for e in self.entries)

    def lines(self) -> list[str]:
        out = [f"limited life over the duty cycle (Miner, ISO 6336 life lines, K_gamma {self.K_gamma:g}):"]
        for e in self.entries:
            out.append(f"  mesh {e.mesh:2s} {e.gear:8s} {e.mode:7s} cycles {e.cycles:9.3g}  largest stress "
                       f"{e.sigma_max / MPA:6.0f} MPa  damage {e.damage:9.3g}  safety {e.S:.3f}")
        out += [str(f) for f in self.findings]
        return out


def life_report(geo: DifferentialGeometry, unit_forces: dict[str, float], bins: tuple[DutyBin, ...] | None = None,
                mat: Material | None = None, cond: Conditions | None = None,
                bores: dict[str, float] | None = None, S_min: float = 1.0) -> LifeReport:
    """Miner's sum over ``bins`` (default: the bundled duty cycle) with the mesh forces
    ``unit_forces`` per N m of carrier torque (keys A1, B2, 12); a limited-life safety below
    ``S_min`` is a warning finding."""
    bins = duty_cycle() if bins is None else bins
    mat = mat or material()
    cond = cond or conditions()
    cond.validate()
    t = geo.table
    Kg = cond.load_sharing(t.nPairs)
    widths = face_widths(geo)
    GH = (static_contact_strength(mat, cond), mat.sigma_Hlim * cond.Z_LvR * cond.Z_W * cond.Z_X)
    GF = static_root_strength(mat, cond)
    GF_end = mat.sigma_Flim * cond.Y_ST * cond.Y_deltarelT * cond.Y_RrelT * cond.Y_X
    entries, found = [], []
    for me in geo.meshes:
        rows = []
        for b in bins:
            F = abs(unit_forces[me.name]) * b.T0
            r = rate_mesh(me, geo.gears, t, F, mat, cond, v=pitch_line_speed(geo, b.w_rel), bores=bores,
                          b=widths[me.name], K_gamma=Kg)
            rows.append((b, r))
        for k, gname in enumerate((me.gear1, me.gear2)):
            g = geo.gears[gname]
            per_turn = t.nPairs if gname in ("sunA", "sunB") else t.sunA.z / g.z
            cycles = [per_turn * b.w_rel * b.hours * 3600.0 / (2.0 * math.pi) for b, _ in rows]
            Fend = GF_end * (cond.Y_M_reversed if gname in IDLERS else 1.0)
            for mode, stresses, line in (
                    ("contact", [r.gears[k].sigma_H for _, r in rows], (GH[0], GH[1], N_H_STATIC, N_H_ENDURANCE)),
                    ("root", [r.gears[k].sigma_F for _, r in rows], (GF, Fend, N_F_STATIC, N_F_ENDURANCE))):
                D = _damage(stresses, cycles, line, 1.0)
                S = _safety(stresses, cycles, line)
                e = LifeEntry(me.name, gname, mode, sum(cycles), D, S, max(stresses))
                entries.append(e)
                if S < S_min:
                    found.append(Finding("warning", f"life-{mode}", f"{gname}.b",
                                         f"mesh {me.name}: {gname} {mode} over the duty cycle: damage {D:.3g} "
                                         f"(Miner), limited-life safety {S:.3f} < {S_min:g} ({sum(cycles):.3g} cycles, "
                                         f"largest stress {max(stresses) / MPA:.0f} MPa, {mat.name})"))
    return LifeReport(tuple(entries), tuple(found), Kg)


__all__ = ["DutyBin", "duty_cycle", "allowed_cycles", "LifeEntry", "LifeReport", "life_report",
           "N_H_STATIC", "N_H_ENDURANCE", "N_F_STATIC", "N_F_ENDURANCE", "DUTY_FILE"]
