"""`spurdiff info`'s bushing pv is p times v at one operating point (issue 41 item 4): vehicle-
cornering's, the break-away pin loads of its 152.4 N m with sun A at 1.1706 rad/s to the carrier;
the p column stays the peak at 2100 N m."""
from harness.measure.info import CORNERING_T0, CORNERING_W_REL, PAPER_T0, PIN_DEFAULTS, bushing_rows
from spurdiff.differential.bushing import PIN_SETS, bushing, check
from spurdiff.differential.locking import breakaway, pin_friction
from spurdiff.gears.design import derive
from spurdiff.gears.geometry import GearTable
from spurdiff.gears.layout import kinematics


def test_pv_is_of_one_operating_point():
    geo = derive(GearTable.paper())
    kin = kinematics(geo)
    rho = (kin.planet1_per_sunA, kin.planet2_per_sunA)
    text = "\n".join(bushing_rows(geo, 0.05))
    for name in PIN_SETS:
        b = bushing(name)
        pf = pin_friction(geo, b.mu_effective, b.journalRadius, 0.0, "pinFriction", *PIN_DEFAULTS)
        peak = breakaway(pf, PAPER_T0 * 1e-3, -1.0)
        corner = breakaway(pf, CORNERING_T0, -1.0)
        p_peak = check(geo, b, peak.F_pin, CORNERING_W_REL, rho, peak.R)
        at = check(geo, b, corner.F_pin, CORNERING_W_REL, rho, corner.R)
        row = next(line for line in text.splitlines() if line.startswith(name)).split()
        assert " / ".join(f"{c.pv / 1e6:.3f}" for c in at) == " ".join(row[-3:])
        # the old mixed number (p at 2100 N m times the cornering v) is more than ten times larger
        assert p_peak[0].pv > 10 * at[0].pv
