"""The rating's data: materials and rating conditions (``spurdiff/data/materials.toml``, sources
there), the FMU's rating parameters, and the load-sharing factor K_gamma of a planetary set."""
from __future__ import annotations

import copy
import math
from dataclasses import replace
from functools import lru_cache

from spurdiff.errors import Bound
from spurdiff.datafile import bundled_text, parse_bundled
from spurdiff.errors import ParameterError, require_finite
from spurdiff.attrpath import record

MATERIALS_FILE = "materials.toml"
# read once at import, from this package's own data folder (see spurdiff.datafile)
_MATERIALS_TEXT = bundled_text(MATERIALS_FILE)


@lru_cache(maxsize=None)
def _materials_parsed() -> dict:
    """``materials.toml`` parsed once per process (never changed: :func:`materials_data` hands out copies)."""
    return parse_bundled(MATERIALS_FILE, _MATERIALS_TEXT)


MM = 1e-3
MPA = 1e6
# ISO 6336-1 method C dynamic factor: K_1 for spur gears by ISO 1328 accuracy grade, K_2 (spur)
K1_SPUR = {3: 2.1, 4: 3.9, 5: 7.5, 6: 14.9, 7: 26.8, 8: 39.1, 9: 52.8, 10: 76.6, 11: 102.6, 12: 146.3}
K2_SPUR = 0.0193


@record(frozen=True)
class Material:
    """A gear material: elastic constants (Pa, 1), endurance limits (Pa), static life factors."""

    name: str
    description: str
    E: float
    nu: float
    sigma_Hlim: float
    sigma_Flim: float
    Z_NT_static: float
    Y_NT_static: float


def K_gamma_default(n_planets: int) -> float:
    """The load-sharing factor K_gamma of ``n_planets`` planets (here: planet pairs) per sun,
    AGMA 6123-B06 (ISO 6336-1 leaves it to the application): 1.0 for one or two, 1.10 three,
    1.25 four, 1.35 five, 1.44 six, 1.47 seven, 1.50 eight and more (``materials.toml``
    ``[loadSharing]``)."""
    table = _materials_parsed()["loadSharing"]
    n = int(n_planets)
    if n < 1:
        raise ParameterError("nPairs", n, ">= 1")
    keys = sorted(int(k) for k in table["K_gamma"])
    return float(table["K_gamma"][str(min(max(n, keys[0]), keys[-1]))])


@record(frozen=True)
class Conditions:
    """Rating conditions (ISO 6336 factors not computed from the geometry). ``K_gamma`` 0: the
    default of the set's number of planet pairs (:func:`K_gamma_default`)."""

    K_A: float = 1.0
    grade: int = 6
    f_pb_um: float = 8.0
    F_betay_um: float = 10.0
    Z_LvR: float = 0.92          # endurance only; static stress takes Z_L Z_v Z_R = 1 (ISO 6336-2)
    Z_W: float = 1.0
    Z_X: float = 1.0
    Y_ST: float = 2.0
    Y_deltarelT: float = 1.0
    Y_RrelT: float = 1.0
    Y_X: float = 1.0
    Y_M_reversed: float = 0.7   # idlers (teeth bent both ways): sigma_Flim times this, long life
    K_gamma: float = 0.0

    def validate(self) -> None:
        if not (math.isfinite(self.K_A) and self.K_A >= 1.0):
            raise ParameterError("capacity.K_A", self.K_A, ">= 1 (ISO 6336-1 application factor)")
        if self.grade not in K1_SPUR:
            raise ParameterError("capacity.grade", self.grade, f"an ISO 1328 accuracy grade {min(K1_SPUR)} .. {max(K1_SPUR)}")
        for name in ("f_pb_um", "F_betay_um"):
            v = require_finite(f"capacity.{name}", getattr(self, name))
            if v < 0.0:
                raise ParameterError(f"capacity.{name}", v, ">= 0")
        k = self.K_gamma
        if not (math.isfinite(k) and (k == 0.0 or 1.0 <= k <= 2.0)):
            raise ParameterError("capacity.K_gamma", k, "0 (the default for the number of planet pairs) or 1 .. 2")

    def load_sharing(self, n_pairs: int) -> float:
        """K_gamma for ``n_pairs`` planet pairs: the given value, or the default."""
        return self.K_gamma if self.K_gamma > 0.0 else K_gamma_default(n_pairs)


@record(frozen=True)
class CapacityParams:
    """What an FMU rates its gear set with: the carrier torque ``T0`` (N m) of the safety factors
    and of the stress scaling, the material's name, the planets' bushing wall, and the load-sharing
    factor (0: the default for nPairs) (defaults: ``materials.toml``)."""

    T0: float = _materials_parsed()["rating"]["T0"]
    material: str = _materials_parsed()["default"]
    bushingWall: float = 0.0     # m, wall of the planets' pin bushings: the bore is 2 (r_j + bushingWall)
    K_gamma: float = 0.0         # load-sharing factor; 0: K_gamma_default(nPairs)

    # the fields' ranges (spurdiff.errors: checked where the FMU's capacity watch is built, and its min/max)
    BOUNDS = {"T0": Bound(0.0, lo_open=True), "bushingWall": Bound(0.0, 0.1, hi_open=True, allowed=">= 0 m and < 0.1 m"),
              # the outer range; Conditions.validate refuses the values between 0 and 1
              "K_gamma": Bound(0.0, 2.0, allowed="0 (the default for the number of planet pairs) or 1 .. 2")}


def pin_bores(journal_radius: float, bushing_wall: float) -> dict[str, float] | None:
    """Bore diameters (m) of the planets, which turn on pins of ``journal_radius`` in bushings of
    ``bushing_wall`` (the rims under their roots set the rim factor Y_B); None without pins."""
    if not journal_radius > 0.0:
        return None
    bore = 2.0 * (journal_radius + bushing_wall)
    return {"planet1": bore, "planet2": bore}


def materials_data() -> dict:
    """The bundled ``materials.toml`` as a dict (the caller's own copy; parsed once per process)."""
    return copy.deepcopy(_materials_parsed())


def material(name: str | None = None) -> Material:
    """The material ``name`` of ``materials.toml`` (None: its ``default``)."""
    data = materials_data()
    name = name or data["default"]
    table = data["material"]
    if name not in table:
        raise ParameterError("capacity.material", name, "one of " + ", ".join(sorted(table)))
    return Material(name=name, **table[name])


def conditions(**changes) -> Conditions:
    """The rating conditions of ``materials.toml`` with ``changes``."""
    c = replace(Conditions(**materials_data()["conditions"]), **changes)
    c.validate()
    return c


__all__ = ["Material", "Conditions", "CapacityParams", "K_gamma_default", "pin_bores", "materials_data", "material",
           "conditions", "K1_SPUR", "K2_SPUR", "MM", "MPA", "MATERIALS_FILE"]
