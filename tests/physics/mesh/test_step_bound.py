"""The measurement of which error estimate sets the mesh solver's step (harness.measure.bench.mesh.step_bound):
its instrumentation wraps the driver's two error tests without changing the arithmetic, classifies
every trial, puts the driver back afterwards, and its quadrature-state experiment integrates the loss."""
from __future__ import annotations

import numpy as np
import pytest

import spurdiff.differential.mesh.stepper as stepper
from harness.measure.bench.mesh import step_bound
from harness.measure.bench.mesh_ivp import ivp_model
from spurdiff.differential.mesh.integrator import RosenbrockW

CASE = "contact, unloaded start"


def _plain(tol: float, t_end: float) -> dict:
    m = ivp_model(CASE, tol, "python", "ros34pw2")    # the measurement is of ROS34PW2's steps
    m.run_dense(t_end, np.arange(1, int(round(t_end / 1e-3)) + 1) * 1e-3)
    return {**m.solver_counts(), "loss": m.energy_loss}


def test_step_bound_counts_every_trial_and_changes_nothing():
    keep = stepper.error_norm, stepper.loss_quadrature, RosenbrockW.step
    (r,) = step_bound(tols=(1e-4,), t_end=0.02, ref_tol=1e-7)
    assert (stepper.error_norm, stepper.loss_quadrature, RosenbrockW.step) == keep
    plain = _plain(1e-4, 0.02)
    assert r["steps"] == plain["steps"]                     # the same run as without the wrappers
    assert abs(r["loss_error"]) < 1e-3 * plain["loss"]
    # every accepted step passed both tests (events may cut a passing trial: more passing than steps)
    assert r["loss_limited"] + r["state_limited"] >= r["steps"]
    assert r["rejected_state"] + r["rejected_loss"] <= plain["rejected"]
    assert r["loss_limited"] > 0 and r["state_limited"] > 0


@pytest.mark.parametrize("row", ["zero row", "gradient"])
def test_quadrature_state_experiment_integrates_the_loss(row):
    (r,) = step_bound(tols=(1e-5,), t_end=0.02, ref_tol=1e-8, quadrature_state=row)
    plain = _plain(1e-5, 0.02)
    assert r["quadrature"] == f"state, {row}"
    assert r["steps"] != plain["steps"]                     # its own step-size control
    assert r["loss_error"] < 1e-4 * plain["loss"]


def test_quadrature_state_unknown_variant_is_refused():
    with pytest.raises(ValueError, match="quadrature_state"):
        step_bound(tols=(1e-3,), t_end=0.002, ref_tol=1e-4, quadrature_state="exact")
