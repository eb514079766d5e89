"""Error metrics shared by the accuracy grid (:mod:`harness.measure.accuracy`) and the solver benchmark
(:mod:`harness.measure.bench.mesh`): statistics of a quantity ("mean(q)", "max(q)", "min(q)") compared
with a reference, each relative to its quantity's scale."""
from __future__ import annotations

import math


def metric_scales(ref: dict[str, float]) -> dict[str, float]:
    """Each quantity's scale: the largest magnitude of its statistics ("mean(q)", "max(q)", "min(q)")
    in the reference."""
    scales: dict[str, float] = {}
    for k, v in ref.items():
        q = k.split("(", 1)[1]
        scales[q] = max(scales.get(q, 0.0), abs(v))
    return scales


def relative_errors(values: dict, ref: dict, scale: dict) -> dict:
    """|value - reference| over the quantity's scale (:func:`metric_scales`), so a statistic that is
    near zero in the reference (the minimum of a force that starts at zero) does not blow up the
    error; a missing or non-finite value is an infinite error."""
    out = {}
    for k, r in ref.items():
        v = values.get(k, math.nan)
        s = scale.get(k.split("(", 1)[1], 0.0) if "(" in k else abs(r)
        out[k] = abs(v - r) / max(s, 1e-300) if math.isfinite(v) else math.inf
    return out


def metric_error(values: dict[str, float], ref: dict[str, float]) -> float:
    """Largest error of the metrics, each relative to its quantity's scale, as ``spurdiff accuracy``
    measures the scenes."""
    return max(relative_errors(values, ref, metric_scales(ref)).values())
