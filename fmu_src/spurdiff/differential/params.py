"""Parameters of the differential model, SI units; defaults (the paper's values) from
``spurdiff/data/differential.toml``."""
from __future__ import annotations

import math
from dataclasses import field

from spurdiff.datafile import differential_default as _d
from spurdiff.errors import Bound, check_fields
from spurdiff.errors import ParameterError
from spurdiff.gears.design import derive
from spurdiff.gears.geometry import DifferentialGeometry, GearTable
from spurdiff.gears.layout import HANDEDNESS, PIN_MODELS
from spurdiff.attrpath import record

LEADING_SUNS = ("either", "A", "B")   # as spurdiff.differential.locking.LEADING_SUNS

CARRIER_DRIVES = ("speed", "torque")
LOCKING_LAWS = ("pinFriction", "paper")


@record
class DifferentialParams:
    """Parameters shared by every fidelity level of the differential.

    Inertias set to 0 are computed from the geometry and ``density`` (see :mod:`spurdiff.differential.inertia`).
    """

    table: GearTable = field(default_factory=GearTable)
    mu_pin: float = _d("mu_pin")          # pin-bushing friction coefficient at break-away (paper: one coefficient)
    mu_pinDynamic: float = _d("mu_pinDynamic")   # sliding coefficient, 0 <= it <= mu_pin (0: equal to mu_pin)
    r_collar: float = _d("r_collar")      # thrust-collar radius r_d of the pinion shaft, m (paper)
    lockingLaw: str = _d("lockingLaw")    # "pinFriction": from the pin loads | "paper": the paper's K
    lockingPreload: float = _d("lockingPreload")   # N m, spring preload of the locking friction (0: none)
    pinSpeedLoads: bool = _d("pinSpeedLoads")      # the planets' centrifugal forces load their pins (pinFriction law)
    pinModel: str = _d("pinModel")        # how a pin carries its planet's loads along the journal (locking.py)
    pairHandedness: str = _d("pairHandedness")   # planet 2 leading or trailing planet 1 (positive rotation)
    leadingSun: str = _d("leadingSun")    # the sun ahead for the reported K: either (the smaller) | A | B
    pinContactFactor: float = _d("pinContactFactor")   # journal friction moment per mu r |F| (1: friction circle)
    density: float = _d("density")        # steel, kg/m^3 (paper: 7.85e-6 kg/mm^3)
    carrierDrive: str = _d("carrierDrive")   # "speed": carrier.w_ref imposed; "torque": carrier.tau drives it
    J_carrier: float = _d("J_carrier")    # kg m^2, carrier (with everything rigidly on it), 0 = estimate
    J_sunA: float = _d("J_sunA")          # kg m^2, 0 = from geometry
    J_sunB: float = _d("J_sunB")
    J_planet1: float = _d("J_planet1")    # kg m^2, one planet about its own axis, 0 = from geometry
    J_planet2: float = _d("J_planet2")
    m_planet1: float = 0.0        # kg, one planet, 0 = from geometry (orbit inertia on the carrier)
    m_planet2: float = 0.0

    # the fields' fixed ranges (spurdiff.errors: validate and the FMU's min/max); mu_pinDynamic <= mu_pin
    # and r_collar's friction lever are checked in validate
    BOUNDS = {
        "mu_pin": Bound(0.0, 1.0),
        "mu_pinDynamic": Bound(0.0, 1.0, allowed="between 0 and mu_pin (0: equal to mu_pin)"),
        "r_collar": Bound(0.0),
        "lockingPreload": Bound(0.0, 1e5, allowed="between 0 and 1e5 N m"),
        "pinContactFactor": Bound(1.0, 2.0, hint="1: friction circle, 4/pi: run-in bushing, pi/2: uniform pressure"),
        "density": Bound(0.0, lo_open=True),
        **{name: Bound(0.0) for name in ("J_carrier", "J_sunA", "J_sunB", "J_planet1", "J_planet2",
                                         "m_planet1", "m_planet2")},
    }

    def validate(self) -> DifferentialGeometry:
        """Check every parameter; return the derived geometry. Raises ParameterError."""
        geo = derive(self.table)
        geo.raise_on_error()
        mu = self.BOUNDS["mu_pin"].check("mu_pin", self.mu_pin)
        # mu_pinDynamic's range depends on mu_pin: its error says mu_pin's value (the declared
        # bound, 0 .. 1, is the FMU's min/max)
        if not 0.0 <= self.mu_pinDynamic <= mu:        # (NaN fails too)
            raise ParameterError("mu_pinDynamic", self.mu_pinDynamic,
                                 f"between 0 and mu_pin = {mu:g} (0: equal to mu_pin)")
        check_fields(self)
        if self.lockingLaw not in LOCKING_LAWS:
            raise ParameterError("lockingLaw", self.lockingLaw, " or ".join(LOCKING_LAWS))
        for name, allowed in (("pinModel", PIN_MODELS), ("pairHandedness", HANDEDNESS), ("leadingSun", LEADING_SUNS)):
            if getattr(self, name) not in allowed:
                raise ParameterError(name, getattr(self, name), " | ".join(allowed))
        fac = self.pinContactFactor
        rb_planet = min(geo.meshA1.rb2, geo.meshB2.rb2)
        if self.lockingLaw == "pinFriction" and mu * self.r_collar * fac >= 0.5 * rb_planet:
            raise ParameterError("r_collar", self.r_collar,
                                 f"mu_pin * r_collar * pinContactFactor < r_b / 2 = {0.5 * rb_planet:.4g} m "
                                 "(planet base radius)",
                                 "a larger friction lever than that makes the pins nearly self-locking")
        if self.carrierDrive not in CARRIER_DRIVES:
            raise ParameterError("carrierDrive", self.carrierDrive, " or ".join(CARRIER_DRIVES))
        return geo

    @property
    def mu_sliding(self) -> float:
        """The pins' coefficient while the differential slips: ``mu_pinDynamic``, or ``mu_pin``
        where that is 0 (one coefficient)."""
        return self.mu_pinDynamic if self.mu_pinDynamic > 0.0 else self.mu_pin


def degrees(rad: float) -> float:
    return math.degrees(rad)
