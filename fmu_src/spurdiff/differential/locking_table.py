"""The locking law's tables for `spurdiff info` and docs/locking-law.md: K, torque bias ratio and the
planets' bushing pressures at break-away for each pin model (planar, end reactions, linear
pressure), each handedness of the planet pair and each leading sun (issue 41). Numbers only; the
harness renders them."""
from __future__ import annotations

from spurdiff.differential.bushing import edge_pressure
from spurdiff.differential.locking import breakaway, locking_coefficients, pin_friction, torque_bias_ratio
from spurdiff.gears.geometry import DifferentialGeometry
from spurdiff.gears.layout import HANDEDNESS, PIN_MODELS

T0_RATED = 2100.0   # N m, the paper's carrier torque


def k_rows(geo: DifferentialGeometry, mu: float, r_d: float) -> list[list[str]]:
    """Rows: pin model, handedness, case, K with sun A ahead, K with sun B ahead, K (the smaller),
    bias ratio (of the smaller)."""
    rows = []
    for model in PIN_MODELS:
        for hand in HANDEDNESS:
            pf = pin_friction(geo, mu, r_d, 0.0, "pinFriction", model, hand)
            KA, KB, K = (locking_coefficients(pf, lead) for lead in ("A", "B", "either"))
            for k, case in enumerate(("drive", "coast")):
                rows.append([model, hand, case, f"{KA[k]:.4f}", f"{KB[k]:.4f}", f"{K[k]:.4f}",
                             f"{torque_bias_ratio(K[k]):.4f}"])
    return rows


def pressure_rows(geo: DifferentialGeometry, mu: float, r_d: float, r_j: float,
                  T0: float = T0_RATED) -> list[list[str]]:
    """Rows: pin model, case, the friction loads of planets 1 / 2 (N), their end reactions |R_0| /
    |R_L| (N), mean and edge pressure (MPa) on journals of radius ``r_j`` and the planets' face
    widths, at break-away under ``T0`` (sun A behind the carrier, leading pair)."""
    rows = []
    d = 2.0 * r_j
    for model in PIN_MODELS:
        pf = pin_friction(geo, mu, r_d, 0.0, "pinFriction", model)
        for case, sign in (("drive", 1.0), ("coast", -1.0)):
            b = breakaway(pf, sign * T0, -1.0)
            cells = [model, case, f"{b.F_pin[0]:,.0f} / {b.F_pin[1]:,.0f}"]
            ends, pm, pe = [], [], []
            for i, planet in enumerate(("planet1", "planet2")):
                R0x, R0y, RLx, RLy = b.R[i]
                if model == "planar" or pf.layout.ends[i][3] == 0.0:
                    ends.append("-")
                else:
                    ends.append(f"{(R0x * R0x + R0y * R0y) ** 0.5:,.0f} + {(RLx * RLx + RLy * RLy) ** 0.5:,.0f}")
                mean, edge = edge_pressure(R0x, R0y, RLx, RLy, d, geo.gears[planet].b)
                pm.append(mean)
                pe.append(edge if model != "planar" else mean)
            cells += [" / ".join(ends), f"{pm[0] / 1e6:.1f} / {pm[1] / 1e6:.1f}", f"{pe[0] / 1e6:.1f} / {pe[1] / 1e6:.1f}"]
            rows.append(cells)
    return rows


LAYOUTS = (   # (label, planet 2's axialStart, its b, sun B's axialStart), m
    ("all in one plane, planet 2 22 mm (the planar limit)", 0.001, 0.022, 0.001),
    ("planet 2 40 mm at 1 mm, sun B at 24 mm (the paper set as assumed)", 0.001, 0.040, 0.024),
    ("planet 2 40 mm at 3 mm", 0.003, 0.040, 0.024),
    ("planet 2 40 mm at 5 mm (flush with sun B's far face)", 0.005, 0.040, 0.024),
    ("planet 2 45 mm at 1 mm", 0.001, 0.045, 0.024),
    ("planet 2 45 mm at 1 mm, sun B at 26 mm", 0.001, 0.045, 0.026),
)
S_HEADER = ["layout", "mesh 12 / B2 width mm", "mesh centres apart mm", "K drive / coast end reactions",
            "K drive / coast linear pressure"]


def sensitivity_rows(geo: DifferentialGeometry, mu: float, r_d: float) -> list[list[str]]:
    """K against the axial layout (planet 2's position and width, sun B's plane) for the gear set
    of ``geo`` (the carrier's wall B moved to fit)."""
    from dataclasses import replace

    from spurdiff.gears.axial import AxialLayout
    from spurdiff.gears.design import derive

    rows = []
    for label, z2, b2, zB in LAYOUTS:
        t = geo.table.with_gear("planet2", axialStart=z2, b=b2).with_gear("sunB", axialStart=zB)
        t = replace(t, carrier=replace(t.carrier, wallB=max(zB + t.sunB.b, z2 + b2) + 0.001))
        g = derive(t)
        lay = AxialLayout.of(t)
        Ks = [locking_coefficients(pin_friction(g, mu, r_d, 0.0, "pinFriction", m)) for m in ("endReactions",
                                                                                            "linearPressure")]
        rows.append([label, f"{lay.mesh_width('12') * 1e3:.0f} / {lay.mesh_width('B2') * 1e3:.0f}",
                     f"{abs(lay.meshes['B2'].centre - lay.meshes['12'].centre) * 1e3:.1f}",
                     f"{Ks[0][0]:.4f} / {Ks[0][1]:.4f}", f"{Ks[1][0]:.4f} / {Ks[1][1]:.4f}"])
    return rows


K_HEADER = ["pin model", "pair", "case", "K sun A ahead", "K sun B ahead", "K", "bias ratio"]
P_HEADER = ["pin model", "case", "friction load p1 / p2 N", "|R_0| + |R_L| p1 / p2 N", "p mean MPa",
            "p edge MPa"]

__all__ = ["k_rows", "pressure_rows", "sensitivity_rows", "K_HEADER", "P_HEADER", "S_HEADER", "T0_RATED"]


def main(argv: list[str] | None = None) -> int:
    """``python -m spurdiff.differential.locking_table [paper|designed]``: the K, bias and pressure
    rows and the axial stack-up findings of a named gear set, with the default pins (mu 0.26, r 12 mm),
    as docs/locking-law.md quotes them."""
    import sys

    from spurdiff.gears.axial import AxialLayout
    from spurdiff.gears.design import derive
    from spurdiff.gears.design_sets import gear_set

    args = sys.argv[1:] if argv is None else argv
    geo = derive(gear_set(args[0] if args else "paper"))
    for header, rows in ((K_HEADER, k_rows(geo, 0.26, 0.012)), (P_HEADER, pressure_rows(geo, 0.26, 0.012, 0.012)),
                         (S_HEADER, sensitivity_rows(geo, 0.26, 0.012))):
        print(" | ".join(header))
        for r in rows:
            print(" | ".join(r))
    print("\n".join(AxialLayout.of(geo.table).summary()))
    for f in AxialLayout.of(geo.table).findings(geo):
        print(f)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
