"""`spurdiff info`: derived geometry, design findings and the paper's theory table beside ours."""
from __future__ import annotations

import math

from spurdiff.differential.watches import rating_forces
from spurdiff.gears.capacity import CapacityParams, capacity_report, nominal_mesh_forces, pin_bores, pitch_line_speed
from spurdiff.gears.axial import AxialLayout
from spurdiff.gears.design import derive
from spurdiff.differential.locking_table import K_HEADER, P_HEADER, T0_RATED, k_rows, pressure_rows
from spurdiff.gears.design_sets import gear_set
from spurdiff.gears.geometry import MM, GearTable
from spurdiff.differential.inertia import mass_properties
from spurdiff.differential.params import DifferentialParams
from spurdiff.differential.locking import (breakaway, first_order_K, locking_coefficients, paper_locking_coefficient,
                              pin_friction, torque_bias_ratio)
from spurdiff.differential.bushing import BACKUP_RATIO_MIN, PIN_SETS, bushing, check
from spurdiff.differential.speed_law import breakaway_at_speed, locking_torque_at_speed
from spurdiff.differential.flank_law import locking_coefficient_flank, locking_coefficients_flank
from spurdiff.gears.layout import kinematics
from spurdiff.differential.mesh.params import MeshParams
from spurdiff.gears.phasing import mesh_phases
from spurdiff.differential.statics import mesh_forces, mesh_forces_for

from harness.run.report import render

# The paper's printed theory values (N mm, N) and its printed (rounded) pitch radii (mm)
PAPER_T0 = 2_100_000.0  # N mm
PAPER_DELTA_T = 60_201.0
PAPER_FORCES = (6898.0, 6896.0, 6899.0)
PAPER_RADII_MM = {"r_a": 52.16, "r_1": 18.84, "r_b": 55.84, "r_2": 20.16}
PAPER_TABLE = {  # mesh: (centre distance mm, r_w1, r_w2)
    "A1": (71.0, 52.16, 18.84),
    "B2": (76.0, 55.84, 20.16),
}


def _pct(ours: float, ref: float) -> str:
    return f"{100.0 * (ours - ref) / ref:+.3f} %"


def flank_rows(geo, pf, Kd: float, Kc: float, mu_flank: float) -> list[str]:
    """The locking coefficients with Coulomb flank friction (spurdiff.differential.flank_law)
    beside those of the pins alone, drive and coast."""
    fl = locking_coefficients_flank(geo, pf, mu_flank)
    rows = []
    for k, (case, K0) in enumerate((("drive", Kd), ("coast", Kc))):
        rows.append([case, f"{K0:.4f}", f"{torque_bias_ratio(K0):.4f}", f"{fl.average[k]:.4f}",
                     f"{torque_bias_ratio(fl.average[k]):.4f}", f"{100 * (fl.average[k] / K0 - 1):+.1f} %",
                     f"{fl.start[k]:.4f}", f"{fl.lo[k]:.4f} .. {fl.hi[k]:.4f}"])
    return [f"Locking with flank friction (pinFriction law; Coulomb friction on the flanks at the static "
            f"coefficient flank.muStatic = {mu_flank:g}; drive: load on the drive flanks, the carrier drives the "
            f"suns; coast: on the coast flanks, the suns drive the carrier). Off by default at every level "
            f"(docs/locking-law.md); where flankFriction is on (compliant, contact) lockingCoefficient is the "
            f"mesh-cycle average",
            render(["case", "K pins", "bias pins", "K pins + flanks (cycle mean)", "bias", "change",
                    "K at the start phases", "K over one cycle"], rows), ""]


PIN_DEFAULTS = (DifferentialParams().pinModel, DifferentialParams().pairHandedness)   # the pins of the bushing table
CORNERING_W_REL = 1.1706   # rad/s, sun A relative to the carrier in vehicle-cornering's steady turn
CORNERING_WC, CORNERING_T0 = 30.7161, 152.4    # rad/s, N m: vehicle-cornering's carrier speed and axle torque


def bushing_rows(geo, mu_flank: float) -> list[str]:
    """Both pin data sets (spurdiff/data/pin_bushing.toml): lever, K and bias with and without
    flank friction, and the design findings (rim backup ratio, bushing p and pv)."""
    kin = kinematics(geo)
    rho = (kin.planet1_per_sunA, kin.planet2_per_sunA)
    rows, finds = [], []
    for name in PIN_SETS:
        b = bushing(name)
        pf = pin_friction(geo, b.mu_effective, b.journalRadius, 0.0, "pinFriction", *PIN_DEFAULTS)
        Kd, Kc = locking_coefficients(pf)
        Ksd, Ksc = locking_coefficients(pin_friction(geo, b.mu_effective_dynamic, b.journalRadius, 0.0, "pinFriction",
                                                     *PIN_DEFAULTS))
        Kfd, Kfc = (locking_coefficient_flank(geo, pf, mu_flank, sg) for sg in (1.0, -1.0))
        ba = breakaway(pf, PAPER_T0 * 1e-3, -1.0)
        checks = check(geo, b, ba.F_pin, CORNERING_W_REL, rho, ba.R)       # p: the peak at T0 = 2100 N m
        ba_c = breakaway(pf, CORNERING_T0, -1.0)                               # pv: p and v of one point,
        at_c = check(geo, b, ba_c.F_pin, CORNERING_W_REL, rho, ba_c.R)        # vehicle-cornering's
        rows.append([name, f"{b.muStatic:g} / {b.muDynamic:g}", f"{b.mu_effective:.4f}", f"{b.journalRadius / MM:g}",
                     f"{b.lever / MM:.4f}", f"{Kd:.4f} / {Kc:.4f}", f"{Ksd:.4f} / {Ksc:.4f}",
                     f"{torque_bias_ratio(Kd):.3f} / {torque_bias_ratio(Kc):.3f}", f"{Kfd:.4f} / {Kfc:.4f}",
                     f"{torque_bias_ratio(Kfd):.3f} / {torque_bias_ratio(Kfc):.3f}",
                     " / ".join(f"{c.backup_ratio:.2f}" for c in checks),
                     " / ".join(f"{c.p / 1e6:.1f}" for c in checks),
                     " / ".join(f"{c.pv / 1e6:.3f}" for c in at_c)])
        finds += [f"  {name}: {f}" for c in checks for f in c.findings(b) if " pv = " not in f]
        finds += [f"  {name}: {f} (vehicle-cornering)" for c in at_c for f in c.findings(b) if " pv = " in f]
    return ["Pin bushings (spurdiff/data/pin_bushing.toml, sources there): lever mu' r_j, mu' = mu_s/sqrt(1+mu_s^2) "
            "with the friction-circle correction (bronze), as published (paper); K (break-away, mu_s), K sliding "
            "(mu_d: the locking while the differential slips) and bias drive / coast, pins "
            f"alone and with flank friction {mu_flank:g} (cycle mean); backup ratio s_R/h_t planet 1 / 2; p (edge of the "
            f"linear distribution from the journals' end reactions, pinModel = {PIN_DEFAULTS[0]}) at the "
            f"break-away pin loads at T0 = {PAPER_T0 * 1e-3:g} N m (drive, the peak); pv at one operating point, "
            f"vehicle-cornering's: p at the break-away pin loads of T0 = {CORNERING_T0:g} N m times v with sun A at "
            f"{CORNERING_W_REL:g} rad/s relative to the carrier",
            render(["set", "mu_s / mu_d", "mu'", "r_j mm", "lever mm", "K", "K sliding", "bias", "K + flanks", "bias + flanks",
                    "backup ratio", "p MPa", "pv MPa m/s"], rows),
            "Bushing findings" + (f" (limits: backup ratio >= {BACKUP_RATIO_MIN:g}, C93200 bronze p, pv)"),
            *(finds or ["  none"]), ""]


def capacity_rows(geo) -> list[str]:
    """ISO 6336 safety factors and capacity findings (spurdiff.gears.capacity, method B) of the
    given gear set (the paper's by default) and of the designed one (spurdiff/data/gear_set_designed.toml), each on the pins of
    both pin data sets (bore 2 (r_j + bushing wall)), at the FMU's rating torque capacity.T0."""
    T0 = CapacityParams().T0
    sets = [("paper (default)" if geo.table == GearTable.paper() else "given", geo),
            ("designed", derive(gear_set("designed")))]
    rows, reports = [], []
    for label, g in sets:
        for pins in PIN_SETS:
            b = bushing(pins)
            bores = pin_bores(b.journalRadius, b.bushingWall)   # as the FMU with capacity.bushingWall
            bore = bores["planet1"]
            F = rating_forces(g, b.mu_effective, b.journalRadius, T0)     # the locked split at break-away
            rep = capacity_report(g, F, bores=bores, v=pitch_line_speed(g, CORNERING_W_REL))
            gs = [x for r in rep.meshes for x in r.gears]
            n_err = sum(f.level == "error" for f in rep.findings)
            rows.append([label, f"{pins} ({bore / MM:g})", f"{max(x.sigma_H for x in gs) / 1e6:.0f}",
                         f"{max(x.sigma_F for x in gs) / 1e6:.0f}", f"{rep.S_H:.3f} / {rep.S_H_static:.3f}",
                         f"{rep.S_F:.3f} / {rep.S_F_static:.3f}", f"{n_err} / {len(rep.findings) - n_err}"])
            reports.append((f"{label}, {pins} pins ({bore / MM:g} mm bore)", rep))
    out = [f"Load capacity, ISO 6336 method B (spurdiff.gears.capacity, docs/capacity.md) at the rating torque "
           f"capacity.T0 = {T0:g} N m, the locked split at break-away, K_gamma of nPairs, K_v at vehicle-cornering's "
           f"pitch-line speed; the given set and the designed "
           f"one (spurdiff design, spurdiff/data/gear_set_designed.toml), each on the planet pins of both pin data "
           f"sets; safety factors S (smallest over meshes and gears) long life / static; findings: errors (static "
           f"< 1) / warnings (thin rim; the limited life over the duty cycle: `spurdiff design --torque`)",
           render(["gear set", "pins (bore mm)", "sigma_H max MPa", "sigma_F max MPa", "S_H", "S_F",
                   "findings"], rows)]
    for label, rep in reports:
        out.append(f"Capacity of {label}:")
        out += [f"  {line}" for line in rep.lines()]
    return out + [""]


def axial_locking_rows(geo, p) -> list[str]:
    """The axial layout and the pin law in 3-D (issue 41; spurdiff.differential.locking_table): K for
    each pin model, handedness of the pair and leading sun; pressures at break-away."""
    return ["Axial layout (spurdiff.gears.axial; stack-up findings under Design checks)",
            *[f"  {line}" for line in AxialLayout.of(geo.table).summary()], "",
            f"Locking with the pins' axial load positions (mu = {p.mu_pin:g}, r_d = {p.r_collar / MM:g} mm; in use: "
            f"pinModel = {p.pinModel}, pairHandedness = {p.pairHandedness}, leadingSun = {p.leadingSun}; pair leading: "
            f"planet 2 ahead of planet 1 in the positive sense of rotation; K: the smaller of the two leading suns)",
            render(K_HEADER, k_rows(geo, p.mu_pin, p.r_collar)),
            f"  bushing loads and pressures at break-away, T0 = {T0_RATED:g} N m, sun A behind, pair leading, journal "
            f"radius r_d, length the planet's face width; p edge: the larger end of the linear pressure distribution",
            render(P_HEADER, pressure_rows(geo, p.mu_pin, p.r_collar, p.r_collar)), ""]


WHEEL_RADIUS = 0.3266      # m, the Chrono sedan's tyre (shared/docs/model-references.md): carrier = wheel speed


def speed_rows(p, geo, pf) -> list[str]:
    """Locking torque against carrier speed (spurdiff.differential.speed_law) at zero and low
    torque, beside the first-order theory n c (|rho_1| m_1 a_1 + |rho_2| m_2 a_2) w_c^2."""
    mp = mass_properties(p, geo)
    ms = (mp.m_planet1, mp.m_planet2)
    first = pf.n * pf.c * (abs(pf.rho[0]) * ms[0] * geo.meshA1.a + abs(pf.rho[1]) * ms[1] * geo.meshB2.a)
    rows = []
    for label, wc in (("standstill", 0.0), ("vehicle-cornering", 30.7161), ("100 km/h", 100 / 3.6 / WHEEL_RADIUS),
                      ("200 km/h", 200 / 3.6 / WHEEL_RADIUS)):
        T = [locking_torque_at_speed(pf, geo, ms, wc, T0) for T0 in (0.0, 100.0, -100.0)]
        rows.append([label, f"{wc:.1f}", f"{T[0]:.3f}", f"{first * wc * wc:.3f}", f"{T[1]:.2f}", f"{T[1] / 100:.4f}",
                     f"{T[2]:.2f}", f"{T[2] / 100:.4f}"])
    return [f"Locking torque against carrier speed (centrifugal pin loads of the planets, {ms[0]:.3f} / {ms[1]:.3f} kg "
            f"at {geo.meshA1.a / MM:.1f} / {geo.meshB2.a / MM:.1f} mm; quasi-static break-away, smaller direction; every "
            f"level carries these loads with pinSpeedLoads (default on); carrier speed = wheel speed, r_w = "
            f"{WHEEL_RADIUS} m)",
            render(["carrier", "w_c rad/s", "T0 = 0: N m", "first order N m", "T0 = 100 drive: N m", "K",
                    "T0 = 100 coast: N m", "K"], rows),
            f"  vehicle-cornering's operating point (carrier {CORNERING_WC} rad/s, T0 = {CORNERING_T0} N m drive, "
            f"inner sun A behind the carrier): K = "
            f"{breakaway_at_speed(pf, geo, ms, CORNERING_WC, CORNERING_T0, -1.0).K:.4f} (standstill "
            f"{breakaway(pf, CORNERING_T0, -1.0).K:.4f})", ""]


def info_text(table: GearTable | None = None, params: DifferentialParams | None = None,
              mu_flank: float | None = None) -> str:
    if mu_flank is None:
        mu_flank = MeshParams().muStatic
    p = params or DifferentialParams(table=table or GearTable())
    geo = derive(p.table)
    t = geo.table
    out = [f"spurdiff: spur-gear planetary differential, m = {t.m / MM:g} mm, alpha = {math.degrees(t.alpha):g} deg, "
           f"nPairs = {t.nPairs}", ""]
    rows = []
    for name, g in geo.gears.items():
        rows.append([name, str(g.z), f"{g.x:+.4f}", f"{g.b / MM:.1f}", f"{2 * g.r / MM:.3f}", f"{2 * g.rb / MM:.3f}",
                     f"{2 * g.rF / MM:.3f}" + (" (undercut)" if g.undercut else ""),
                     f"{2 * g.ra / MM:.3f}", f"{2 * g.rf / MM:.3f}", f"{g.sa / MM:.3f}"])
    out += [f"Gears (form diameter d_F: start of the involute, generating rack h_aP0 = {t.haP0:g} m, "
            f"rho_aP0 = {t.rhoaP0:g} m)",
            render(["gear", "z", "x", "b mm", "d mm", "d_b mm", "d_F mm", "d_a mm", "d_f mm", "s_a mm"], rows), ""]
    rows = []
    phases = mesh_phases(geo) if not geo.errors else {}
    for me in geo.meshes:
        paper = PAPER_TABLE.get(me.name)
        sap1, sap2 = me.start_of_active_profile(me.gear1), me.start_of_active_profile(me.gear2)
        ph = phases.get(me.name)
        rows.append([me.name, f"{math.degrees(me.alpha_w):.4f}", f"{me.a / MM:.4f}", f"{me.rw1 / MM:.4f}",
                     f"{me.rw2 / MM:.4f}", f"{me.epsilon_alpha:.3f}", f"{me.epsilon_usable:.3f}",
                     f"{2 * sap1 / MM:.3f} / {2 * sap2 / MM:.3f}",
                     f"{ph.drive:.3f} / {ph.coast:.3f}" if ph else "-",
                     f"{paper[0]:g} / {paper[1]:g} / {paper[2]:g}" if paper else "-"])
    out += ["Meshes (operating values; eps usable: involute from form circle to tip on both gears, fed to the "
            "ISO stiffness and the stiffness wave; SAP: start of active profile with the tips as given; phase: "
            "drive / coast flanks along the usable path, an A1 drive pair at its pitch point)",
            render(["mesh", "alpha_w deg", "a mm", "r_w1 mm", "r_w2 mm", "eps_alpha", "eps usable",
                    "d_SAP 1 / 2 mm", "phase", "paper a / r_w1 / r_w2 mm"], rows), ""]
    out.append(f"Kinematics: r_a/r_1 = {geo.r_a / geo.r_1:.5f}, r_b/r_2 = {geo.r_b / geo.r_2:.5f}, "
               f"r_a/r_b = {geo.r_a / geo.r_b:.4f}, r_1/r_2 = {geo.r_1 / geo.r_2:.4f} "
               f"(the paper prints r_a/r_b = r_2/r_1, a typo); w_A + w_B = 2 w_c")
    out.append("")
    out.append("Design checks")
    out += [f"  {f}" for f in geo.findings] or ["  no findings"]
    out.append("")

    # Statics at the paper's T0
    # Locking: both laws
    pf = pin_friction(geo, p.mu_pin, p.r_collar, 0.0, "pinFriction", p.pinModel, p.pairHandedness,
                      p.pinContactFactor)
    Kd, Kc = locking_coefficients(pf, p.leadingSun)
    Kp = paper_locking_coefficient(p.mu_pin, p.r_collar, t.nPairs, geo.r_a, geo.r_1, geo.r_b, geo.r_2)
    ppf = pin_friction(geo, p.mu_pin, p.r_collar, 0.0, "paper")
    Kpc_mesh = locking_coefficients(ppf)[1]
    u_d, u_c = pf.layout.unit_pin_loads(1.0), pf.layout.unit_pin_loads(-1.0)
    bd = breakaway(pf, PAPER_T0 * 1e-3, -1.0)
    bc = breakaway(pf, -PAPER_T0 * 1e-3, -1.0)
    rows = [
        [f"pinFriction ({p.pinModel})", "drive", f"{Kd:.4f}", f"{first_order_K(pf, 1.0):.4f}", f"{torque_bias_ratio(Kd):.4f}",
         f"{u_d[0]:.3f} / {u_d[1]:.3f}", f"{Kd * PAPER_T0 * 1e-3:.1f}"],
        [f"pinFriction ({p.pinModel})", "coast", f"{Kc:.4f}", f"{first_order_K(pf, -1.0):.4f}", f"{torque_bias_ratio(Kc):.4f}",
         f"{u_c[0]:.3f} / {u_c[1]:.3f}", f"{Kc * PAPER_T0 * 1e-3:.1f}"],
        ["paper", "drive", f"{Kp:.4f}", "-", f"{torque_bias_ratio(Kp):.4f}", "-", f"{Kp * PAPER_T0 * 1e-3:.1f}"],
        ["paper", "coast", f"{Kp:.4f}", "-", f"{torque_bias_ratio(Kp):.4f}", "-", f"{Kp * PAPER_T0 * 1e-3:.1f}"],
    ]
    out += [f"Locking (mu = {p.mu_pin:g}, r_d = {p.r_collar / MM:g} mm, n = {t.nPairs}): K = |T_A - T_B| / |T_A + T_B| "
            f"at break-away; pin loads per unit mesh force with equal mesh forces; K_1 their linearisation "
            f"c (|rho_1| p_1 + |rho_2| p_2) / (r_bA + r_bB); drive: the load on the drive flanks (the carrier "
            f"drives the suns, T_A + T_B > 0, FMU output loadedFlanks = 1), coast: on the coast flanks (the suns "
            f"drive the carrier, reversing under power included, loadedFlanks = -1)",
            render(["law", "case", "K", "K_1", "bias ratio", "pin loads p_1 / p_2", "K |T0| at 2100 N m, N m"], rows),
            f"  pinFriction at break-away, T0 = {PAPER_T0 * 1e-3:g} N m drive: T_A / T_B = {bd.T_A:.1f} / {bd.T_B:.1f} N m, "
            f"F_A1 / F_B2 / F_12 = {bd.F_A1:,.0f} / {bd.F_B2:,.0f} / {bd.F_12:,.0f} N, pin loads "
            f"{bd.F_pin[0]:,.0f} / {bd.F_pin[1]:,.0f} N; coast: pin loads {bc.F_pin[0]:,.0f} / {bc.F_pin[1]:,.0f} N",
            f"  the paper's law at the compliant/contact levels (pin lever scaled to its K in drive) holds "
            f"K = {Kpc_mesh:.4f} in coast ({Kpc_mesh / Kp:.3f} x)", ""]
    out += axial_locking_rows(geo, p)
    out += flank_rows(geo, pf, Kd, Kc, mu_flank)
    out += bushing_rows(geo, mu_flank)
    out += speed_rows(p, geo, pf)
    out += capacity_rows(geo)

    T0 = PAPER_T0 * 1e-3  # N m
    K = Kp
    f_exact = mesh_forces_for(geo, T0 / 2, T0 / 2)
    pr = {k: v * MM for k, v in PAPER_RADII_MM.items()}
    f_rounded = mesh_forces(T0 / 2, T0 / 2, t.nPairs, pr["r_a"], geo.meshA1.alpha_w, pr["r_1"],
                            pr["r_b"], geo.meshB2.alpha_w, geo.mesh12.rw1, geo.mesh12.alpha_w)
    K_paper = PAPER_DELTA_T / PAPER_T0
    rows = [
        ["locking coefficient K (paper's law)", "1", f"{K:.6f}", f"{K_paper:.6f}", _pct(K, K_paper)],
        ["delta T = K T0", "N mm", f"{K * PAPER_T0:,.0f}", f"{PAPER_DELTA_T:,.0f}", _pct(K * PAPER_T0, PAPER_DELTA_T)],
        ["torque bias ratio (1+K)/(1-K)", "1", f"{(1 + K) / (1 - K):.4f}", "-", "-"],
    ]
    for label, ours, rounded, paper in zip(("F_A1 sun A / planet 1", "F_B2 sun B / planet 2", "F_12 planet 1 / planet 2"),
                                           (f_exact.F_A1, f_exact.F_B2, f_exact.F_12),
                                           (f_rounded.F_A1, f_rounded.F_B2, f_rounded.F_12), PAPER_FORCES):
        rows.append([label + " (exact radii)", "N", f"{ours:,.1f}", f"{paper:,.0f}", _pct(ours, paper)])
        rows.append([label + " (paper's rounded radii)", "N", f"{rounded:,.1f}", f"{paper:,.0f}", _pct(rounded, paper)])
    out += [f"Statics at T0 = {PAPER_T0:,.0f} N mm, mu = {p.mu_pin:g}, r_d = {p.r_collar / MM:g} mm, "
            f"n = {t.nPairs} pairs (the paper writes 6; its numbers follow from 3)",
            render(["quantity", "unit", "ours", "paper", "ours vs paper"], rows), ""]
    mp = mass_properties(p, geo)
    out.append(f"Mass properties (steel {p.density:g} kg/m^3): J_sunA = {mp.J_sunA:.4e}, J_sunB = {mp.J_sunB:.4e}, "
               f"J_planet1 = {mp.J_planet1:.3e}, J_planet2 = {mp.J_planet2:.3e}, J_carrier (estimate) = "
               f"{mp.J_carrier:.4e} kg m^2; planet masses {mp.m_planet1:.3f} / {mp.m_planet2:.3f} kg")
    return "\n".join(out)


def breakaway_table(resolution: float = 1e-3) -> str:
    """Break-away of the rigid and contact levels with the pin-load law, drive and coast: the sun
    load difference is ramped (1 ms steps of ``resolution`` x K T0, from 0.97 K T0, the model
    starting statically loaded) until the differential moves (rigid: relative speed; contact: both
    planets slipping). T0 = 2100 N m, carrier at 1.389 rad/s, sun A the more loaded one."""
    from spurdiff.differential.mesh import MeshDifferential, MeshParams
    from spurdiff.differential.rigid import RigidDifferential

    def make(level: str, loads: tuple[float, float]):
        p = DifferentialParams()
        m = RigidDifferential(p) if level == "rigid" else MeshDifferential(p, MeshParams(level=level))
        m.w_ref, m.w_start_carrier = 1.389, 1.389
        m.tau_L, m.tau_R = loads
        m.initialize()
        return m

    def loads(sign: float, D: float) -> tuple[float, float]:
        return -1050.0 * sign - D / 2, -1050.0 * sign + D / 2

    ref = make("rigid", loads(1.0, 0.0))
    rows = []
    for case, sign, K in (("drive", 1.0, ref.K), ("coast", -1.0, ref.K_coast)):
        KT0 = K * 2100.0
        found = {}
        for level in ("rigid", "contact"):
            D0 = 0.97 * KT0
            m = make(level, loads(sign, D0))
            for k in range(400):
                D = D0 + resolution * KT0 * k
                m.tau_L, m.tau_R = loads(sign, D)
                m.do_step(k * 1e-3, 1e-3)
                if (m.wd != 0.0) if level == "rigid" else (0 not in m.planet_modes):
                    found[level] = D
                    break
        rows.append([case, f"{K:.4f}", f"{KT0:.2f}", f"{found['rigid']:.2f}", f"{found['contact']:.2f}",
                     f"{100 * (found['contact'] / found['rigid'] - 1):+.2f} %"])
    return render(["case", "K", "K T0 N m", "rigid breaks at N m", "contact breaks at N m", "contact vs rigid"],
                  rows)
