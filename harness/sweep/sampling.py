"""A sweep's runs: the grid, the list, or random / Latin-hypercube samples of the parameters."""
from __future__ import annotations

import itertools
import math
from typing import Any

from harness.sweep.jobs import Task
from harness.sweep.spec import Param, Sweep

def _axis(p: Param) -> list:
    import numpy as np

    if p.values is not None:
        return list(p.values)
    lo, hi = p.range
    pts = np.geomspace(lo, hi, p.n) if p.scale == "log" else np.linspace(lo, hi, p.n)
    return [_cast(p, x) for x in pts]


def _cast(p: Param, x) -> Any:
    return int(round(float(x))) if p.integer else float(x)


def unit_samples(method: str, n: int, d: int, seed: int):
    """(n, d) points in [0, 1): independent uniform ("random") or Latin hypercube ("lhs")."""
    import numpy as np

    if method == "random":
        return np.random.default_rng(seed).random((n, d))
    from scipy.stats import qmc
    try:
        engine = qmc.LatinHypercube(d, rng=seed)
    except TypeError:  # scipy < 1.15
        engine = qmc.LatinHypercube(d, seed=seed)
    return engine.random(n)


def expand(sweep: Sweep) -> list[Task]:
    """The sweep's runs, numbered from 0, each with its parameter values."""
    names = [p.name for p in sweep.params]
    if sweep.method == "grid":
        rows = list(itertools.product(*(_axis(p) for p in sweep.params)))
    elif sweep.method == "list":
        rows = list(zip(*(p.values for p in sweep.params)))
    else:
        u = unit_samples(sweep.method, sweep.n, len(sweep.params), sweep.seed)
        rows = []
        for k in range(sweep.n):
            row = []
            for j, p in enumerate(sweep.params):
                lo, hi = p.range
                if p.scale == "log":
                    x = math.exp(math.log(lo) + u[k, j] * (math.log(hi) - math.log(lo)))
                else:
                    x = lo + u[k, j] * (hi - lo)
                row.append(_cast(p, x))
            rows.append(row)
    return [Task(i, dict(zip(names, r))) for i, r in enumerate(rows)]
