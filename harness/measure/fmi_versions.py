"""A scene run with the FMI 2.0 FMUs and with the FMI 3.0 ones (``NAME-fmi3.fmu``), compared.

Both runs go through the same master (:mod:`harness.run.master`; an FMI 3.0 instance answers the same
calls, :mod:`harness.fmi.instance3`) with Event Mode, early return and output derivatives off, so
the model computes the same steps from the same inputs: the recorded results must agree to the
last bits. :func:`compare` gives the largest difference over every recorded variable, absolute and
relative to the variable's largest magnitude. ``python -m harness.cli.tools.fmi_versions`` prints it
per scene.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Comparison:
    scene: str
    samples: int
    variables: int
    max_abs: float          # the largest |x3 - x2| over every recorded variable and sample
    max_rel: float          # the largest |x3 - x2| / max(|x2|) per variable, over the variables
    worst: str              # the variable of max_rel
    wall2: float            # s, the runs' stepping time
    wall3: float
    failure2: str | None = None
    failure3: str | None = None

    @property
    def same_failure(self) -> bool:
        return (self.failure2 is None) == (self.failure3 is None)


def run_both(name: str, duration: float | None = None, step: float | None = None):
    """The scene ``name`` (``duration``/``step``: as ``spurdiff run --duration/--step``) run with the
    FMI 2.0 FMUs and with the FMI 3.0 ones: (result 2.0, result 3.0)."""
    from harness.run.master import run_scene
    from harness.run.runner import fmu_files_for, prepare_scene, typed_parameters

    results = []
    for version in (2, 3):
        scene = prepare_scene(name, duration=duration, step=step)
        files = fmu_files_for(scene, build_missing=True, fmi_version=version)
        typed_parameters(scene, files)
        results.append(run_scene(scene, files))
    return tuple(results)


def compare(name: str, duration: float | None = None, step: float | None = None) -> Comparison:
    r2, r3 = run_both(name, duration, step)
    if r2.data.shape != r3.data.shape or r2.names != r3.names:
        raise AssertionError(f"{name}: FMI 2.0 recorded {r2.data.shape} {r2.names[:3]}..., FMI 3.0 "
                             f"{r3.data.shape} {r3.names[:3]}...")
    max_abs, max_rel, worst = 0.0, 0.0, ""
    for j, var in enumerate(["time"] + list(r2.names)):
        a, b = r2.data[:, j], r3.data[:, j]
        both_nan = np.isnan(a) & np.isnan(b)
        d = np.where(both_nan, 0.0, np.abs(b - a))
        d = np.where(np.isnan(d), np.inf, d)
        dmax = float(d.max()) if len(d) else 0.0
        scale = float(np.nanmax(np.abs(a))) if len(a) and not np.all(np.isnan(a)) else 0.0
        rel = dmax / scale if scale > 0 else dmax
        max_abs = max(max_abs, dmax)
        if rel >= max_rel:
            max_rel, worst = rel, var
    return Comparison(name, r2.data.shape[0], len(r2.names), max_abs, max_rel, worst, r2.wall_time, r3.wall_time,
                      None if r2.failure is None else str(r2.failure), None if r3.failure is None else str(r3.failure))


def scene_names() -> list[str]:
    """Every scene shipped with the harness."""
    from harness.scene.spec import available
    return list(available())
