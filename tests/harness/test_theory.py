"""Theory values from the run's parameters (harness.scene.theory, issue 41 item 6): a scene's
{theory.INST.NAME} follows --set and the gear set, and names what does not fit."""
from __future__ import annotations

import numpy as np
import pytest

from harness.scene import theory
from harness.run.report import series
from harness.run.result import Result
from harness.run.runner import prepare_scene
from harness.scene.schema import SceneError
from spurdiff.differential.inertia import mass_properties
from spurdiff.differential.locking import pin_friction
from spurdiff.differential.params import DifferentialParams
from spurdiff.differential.speed_law import breakaway_at_speed
from spurdiff.gears.design_sets import gear_set

VARS = ["diff.carrier.w", "diff.left.w", "diff.left.tauMesh", "diff.right.tauMesh", "car.driveTorque"]


def _result(scene, wc=30.7, dw=-1.17, TA=89.0, TB=63.0):
    t = np.linspace(0.0, 1.0, 5)
    cols = [np.full_like(t, v) for v in (wc, wc + dw, TA, TB, TA + TB)]
    return Result(scene, list(VARS), np.column_stack([t] + cols))


def _expected_K(mu, pin_model="endReactions", wc=30.7, T0=152.0, s=-1.0):
    p = DifferentialParams(table=gear_set("designed"), mu_pin=mu, pinModel=pin_model)
    geo = p.validate()
    mp = mass_properties(p, geo)
    pf = pin_friction(geo, mu, p.r_collar, 0.0, "pinFriction", pin_model)
    return breakaway_at_speed(pf, geo, (mp.m_planet1, mp.m_planet2), wc, T0, s).K


def test_the_scene_records_what_its_theory_reads():
    scene = prepare_scene("vehicle-cornering")
    assert set(theory.needed("diff")) <= set(scene.record)


@pytest.mark.parametrize("sets, mu, model", [([], 0.26, "endReactions"),
                                             (["diff.mu_pin=0.3"], 0.3, "endReactions"),
                                             (["diff.mu_pin=0.3", "diff.pinModel=planar"], 0.3, "planar")])
def test_theory_follows_the_runs_parameters(sets, mu, model):
    scene = prepare_scene("vehicle-cornering", sets=sets)
    r = _result(scene)
    K = series(r, "{theory.diff.K_sliding} * 1.0")
    assert K == pytest.approx(np.full(5, _expected_K(mu, model)), rel=1e-12)
    # sun A ahead: the other direction's K
    r2 = _result(scene, dw=+1.17)
    assert series(r2, "theory.diff.K") == pytest.approx(np.full(5, _expected_K(mu, model, s=1.0)), rel=1e-12)


def test_a_stuck_sample_takes_the_direction_the_torques_push():
    scene = prepare_scene("vehicle-cornering")
    r = _result(scene, dw=0.0)      # T_A > T_B: sun A is the more loaded one, it falls behind
    assert series(r, "theory.diff.K")[0] == pytest.approx(_expected_K(0.26, s=-1.0), rel=1e-12)


@pytest.mark.parametrize("ref, why", [("theory.diff.Kv", "unknown theory value"),
                                      ("theory.nope.K", "unknown FMU instance"),
                                      ("theory.K", "not of the form")])
def test_bad_references_are_one_line(ref, why):
    with pytest.raises(SceneError, match=why):
        theory.parse("here", ref, {"diff", "car"})
