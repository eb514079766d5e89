"""Time derivatives of the differential's outputs at the end of the last step (FMI 3.0
``fmi3GetOutputDerivatives``, first order), from the model's end-of-step state:

* the rigid level holds its end-of-step accelerations (``ac``, ``ad``: those of the inputs held
  over the step, the carrier's 0 under the speed drive); the suns' are ``a_L = a_c + a_d`` and
  ``a_R = a_c + lam a_d``; a mesh level's come from its right-hand side at the end state;
* the half-shafts (``shaftCoupling = wheel``, :mod:`spurdiff.differential.shafts`): the torque on the
  wheel ``tau = c theta + d dtheta/dt`` changes at ``dtau/dt = c theta' + d theta''`` with the
  twist rate ``theta' = w_s - w_w`` and its rate ``theta'' = a_s - a_w``; the sun side's speed
  and acceleration are the inner model's at the end of the last sub-step (under the converged sun
  torques it held), the wheel side's those of the wheel's linear model the step was computed with
  (``w_w = w_k + dw``, ``a_w = a_free + inv_J (tau - q) + dadw dw`` with the end-of-step deviations
  ``dw``, ``q``; all zero with nothing connected: the wheel side turns at constant speed).

The derivative of ``leftShaft.tau`` (the mean over the last step) is the same as that of
``leftShaft.tauEnd``: the rate of the shaft torque at the communication point, which a host
extrapolates the exchanged torque with. Only first derivatives are given: the second would need
the rates of the accelerations, which the stick/slip switches make discontinuous.

:func:`output_rates` returns ``{attribute: derivative}`` for every attribute it has one for; the FMU
interface maps its variables onto these attributes (``spurdiff.fmi.differential_fmu``).
"""
from __future__ import annotations

from typing import Callable

from spurdiff.errors import StepError


def sun_accelerations(model, level_accelerations: Callable | None = None) -> tuple[float, float, float]:
    """(a_c, a_L, a_R): carrier and sun (flange) accelerations at the end of the last step of a
    torque-coupled differential model: the rigid level's own, another level's from
    ``level_accelerations(model)`` (a mesh level's: :func:`spurdiff.differential.mesh.rates.sun_accelerations`)."""
    if getattr(model, "mesh_model", "") == "rigid":
        ac, ad = model.ac, model.ad
        return ac, ac + ad, ac + model.lam * ad
    if level_accelerations is None:
        raise StepError(f"no accelerations for the {getattr(model, 'mesh_model', '') or type(model).__name__} level")
    return level_accelerations(model)


def output_rates(model, level_accelerations: Callable | None = None) -> dict[str, float]:
    """{attribute name: its time derivative at the end of the last step} of a differential model
    (a torque-coupled level or :class:`~spurdiff.differential.shafts.ShaftedDifferential`);
    ``level_accelerations`` as for :func:`sun_accelerations`."""
    inner = getattr(model, "inner", None)
    level = inner if inner is not None else model
    ac, aL, aR = sun_accelerations(level, level_accelerations)
    wL, wR = level.w_L, level.w_R
    rates = {"wc": ac, "w_L": aL, "w_R": aR, "phic": level.wc, "phi_L": wL, "phi_R": wR}
    if inner is None:   # shaftCoupling = torque: no shafts (their outputs are the inputs or 0)
        return rates
    sp = model.shafts
    for side, shaft, w_k, surrogate, w_s, a_s in (
            ("L", sp.left, model.wheelL_w, model.wheelL_model, wL, aL),
            ("R", sp.right, model.wheelR_w, model.wheelR_model, wR, aR)):
        dw = getattr(model, f"dw_pred_{side}")
        q = getattr(model, f"q_end_{side}")
        tau = getattr(model, f"tau_end_{side}")
        w_w = w_k + dw
        a_w = surrogate.a_free + surrogate.inv_J * (tau - q) + surrogate.dadw * dw
        theta_rate = w_s - w_w
        tau_rate = shaft.c * theta_rate + shaft.d * (a_s - a_w)
        rates[f"theta_{side}"] = theta_rate
        rates[f"tau_end_{side}"] = tau_rate
        rates[f"tau_mean_{side}"] = tau_rate
    return rates


__all__ = ["output_rates", "sun_accelerations"]
