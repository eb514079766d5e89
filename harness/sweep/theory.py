"""Closed-form values a sweep metric can give (``theory = "locking_coefficient"``...), from the
run's parameters of one instance."""
from __future__ import annotations

from typing import Any

from harness.scene.spec import SceneError

def _differential(params: dict[str, Any]):
    """Parameters and geometry of a SpurDifferential from its FMU start values plus ``params``."""
    from spurdiff.fmi.differential_fmu import VARIABLES, differential_params

    values = {v.name: v.start for v in VARIABLES}
    unknown = sorted(set(params) - set(values))
    if unknown:
        raise SceneError(f"closed form: unknown SpurDifferential parameter(s) {', '.join(unknown)}")
    values.update(params)
    p = differential_params(values)
    return p, p.validate()


def locking_coefficient(params: dict[str, Any]) -> float:
    """K = (mu r_d / n)(1/(r_a + r_1) + 1/(r_b + r_2)) from spurdiff.differential.statics, dimensionless."""
    from spurdiff.differential.statics import locking_coefficient as k

    p, g = _differential(params)
    return k(p.mu_pin, p.r_collar, p.table.nPairs, g.r_a, g.r_1, g.r_b, g.r_2)


def torque_bias_ratio(params: dict[str, Any]) -> float:
    """(1 + K) / (1 - K) from spurdiff.differential.statics, dimensionless."""
    from spurdiff.differential.statics import torque_bias_ratio as tbr

    return tbr(locking_coefficient(params))


# name -> (function of the instance's parameter values, FMU it applies to)
THEORIES = {
    "locking_coefficient": (locking_coefficient, "SpurDifferential"),
    "torque_bias_ratio": (torque_bias_ratio, "SpurDifferential"),
}
