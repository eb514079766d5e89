"""The largest contact and root stress over a run (:class:`StressWatch`), scaled from a rating."""
from __future__ import annotations

import math

from spurdiff.errors import ParameterError
from spurdiff.gears.capacity.data import MPA, Conditions, Material, conditions, material
from spurdiff.gears.capacity.rating import capacity_report, static_contact_strength, static_root_strength
from spurdiff.gears.geometry import DifferentialGeometry


class StressWatch:
    """The largest contact and root stress over a run from the mesh forces, and whether the static
    strength was exceeded (for the FMU: plain state, saved and restored with the model's).

    The load factors depend on the load (K_Hbeta and K_Halpha fall as it grows), so a run's stress
    is scaled from the rating at the reference forces ``forces`` (N per mesh, e.g. the locked split
    at break-away of the rated carrier torque) and the pitch-line speed ``v`` (m/s, K_v): ``sigma_H = a_H sqrt(F)``, ``sigma_F = a_F F`` with
    ``a_H``, ``a_F`` of each mesh's more loaded gear there; exact at the reference forces,
    conservative above them.
    """

    def __init__(self, geo: DifferentialGeometry, forces: dict[str, float], mat: Material | None = None,
                 cond: Conditions | None = None, bores: dict[str, float] | None = None, *, v: float,
                 report=None):
        mat = mat or material()
        cond = cond or conditions()
        self.geo, self.mat, self.cond, self.bores, self.v = geo, mat, cond, bores, v
        self.sigma_HG_static = static_contact_strength(mat, cond)
        self.sigma_FG_static = static_root_strength(mat, cond)
        self.calibrate(forces, report)
        self.sigma_H_max = 0.0
        self.sigma_F_max = 0.0
        self.exceeded = False
        self._F_max = (0.0, 0.0, 0.0)    # largest |force| booked per mesh

    def calibrate(self, forces: dict[str, float], report=None) -> None:
        """Take the load factors at ``forces`` (N per mesh, each > 0); stresses scale from there.
        ``report``: the caller's :func:`capacity_report` of these forces with this watch's material,
        conditions, bores and ``v``, if it made one (the same rating is then not computed again)."""
        for k, F in forces.items():
            if not (math.isfinite(F) and F > 0.0):
                raise ParameterError(f"capacity.F_{k}", F, "> 0 N (the reference force of the stress scaling)")
        rep = report if report is not None else capacity_report(self.geo, forces, self.mat, self.cond, self.bores,
                                                                v=self.v)
        self._aH = tuple(r.sigma_H / math.sqrt(r.F_n) if r.F_n > 0 else 0.0 for r in rep.meshes)
        self._aF = tuple(r.sigma_F / r.F_n if r.F_n > 0 else 0.0 for r in rep.meshes)

    def update(self, F_A1: float, F_B2: float, F_12: float) -> str | None:
        """Book the mesh forces of one instant; a message the first time a limit is exceeded.
        (On the FMU's per-step path: three comparisons unless a mesh's largest force grows.)"""
        a1 = F_A1 if F_A1 >= 0.0 else -F_A1
        a2 = F_B2 if F_B2 >= 0.0 else -F_B2
        a3 = F_12 if F_12 >= 0.0 else -F_12
        m1, m2, m3 = self._F_max
        if a1 <= m1 and a2 <= m2 and a3 <= m3:     # NaN too: never booked
            return None
        self._F_max = (a1 if a1 > m1 else m1), (a2 if a2 > m2 else m2), (a3 if a3 > m3 else m3)
        hA, hB, h12 = self._aH
        fA, fB, f12 = self._aF
        sH = max(hA * math.sqrt(a1), hB * math.sqrt(a2), h12 * math.sqrt(a3))
        sF = max(fA * a1, fB * a2, f12 * a3)
        if sH > self.sigma_H_max:
            self.sigma_H_max = sH
        if sF > self.sigma_F_max:
            self.sigma_F_max = sF
        if not self.exceeded and (sH > self.sigma_HG_static or sF > self.sigma_FG_static):
            self.exceeded = True
            return (f"the mesh forces ({F_A1:.0f}, {F_B2:.0f}, {F_12:.0f} N on meshes A1, B2, 12) exceed the "
                    f"static strength of {self.mat.name}: contact {sH / MPA:.0f} MPa (limit "
                    f"{self.sigma_HG_static / MPA:.0f}), root {sF / MPA:.0f} MPa (limit "
                    f"{self.sigma_FG_static / MPA:.0f}); the results beyond are those of hardware that "
                    f"would fail (ISO 6336, docs/capacity.md)")
        return None

    @property
    def exceeded_indicator(self) -> float:
        """1.0 once the static strength was exceeded, else 0.0 (an FMU output)."""
        return 1.0 if self.exceeded else 0.0

    def get_state(self) -> list:
        return [self.sigma_H_max, self.sigma_F_max, self.exceeded, list(self._F_max)]

    def set_state(self, s) -> None:
        self.sigma_H_max, self.sigma_F_max, self.exceeded = float(s[0]), float(s[1]), bool(s[2])
        self._F_max = tuple(float(f) for f in s[3])


__all__ = ["StressWatch"]
