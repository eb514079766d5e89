"""Where in a communication step the differential switches between stick and slip, for FMI 3.0's
early return (``fmi3DoStep`` with ``earlyReturnAllowed``: the step ends at the switch, the host sees
the outputs there).

Every level counts its switches (``n_mode_switches``: the rigid level's ``w_d`` reaching 0 and its
break-away, a mesh level's pin stiction). A switch happens at the same time whatever step carries
the model across it (the inputs are held over a step: the rigid level locates it exactly, a mesh
level to its integrator's tolerance), so the switch time of a step from ``t`` is the shortest step
``h'`` after which the count has grown: :func:`transition_step` finds it by bisection on ``h'``,
from the state at ``t``, to ``rel_tol h``, and leaves the model stepped by the ``h'`` just past the
switch (the state there is that of a step of ``h'``: no stitching). A switch in the first
``rel_tol h`` of the step (a break-away decided by the inputs at the communication point) is no
reason to stop: the step is then taken whole.
"""
from __future__ import annotations

from typing import Callable

REL_TOL = 1e-6      # the switch time to 1e-6 of the step (5 ns at 5 ms)


def transition_step(step: Callable[[float], int], h: float, switches0: int,
                    rel_tol: float = REL_TOL) -> float | None:
    """The length of the step from the saved state that ends just past the first stick/slip switch
    inside the step of length ``h``, or None when the step has no switch past its first ``rel_tol h``.

    ``step(h')`` restores the state at the step's start, steps the model by ``h'`` and returns its
    switch count, which was ``switches0`` at the start. The model is left stepped by the length
    returned (by ``h`` when None).
    """
    if step(h) == switches0:
        return None
    lo = rel_tol * h
    if step(lo) != switches0:        # at the communication point: not a reason to return early
        step(h)
        return None
    hi = h
    while hi - lo > rel_tol * h:
        mid = 0.5 * (lo + hi)
        if step(mid) == switches0:
            lo = mid
        else:
            hi = mid
    if hi >= h:
        step(h)
        return None
    step(hi)
    return hi


__all__ = ["transition_step", "REL_TOL"]
