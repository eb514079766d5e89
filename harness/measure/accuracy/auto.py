"""``fidelity = "auto"``: the cheapest stored fidelity and step that meet a scene's tolerance on
its requested outputs, with convergence shown and a reference that resolves the tolerance."""
from __future__ import annotations

import json
import math
import tomllib
from dataclasses import replace

from harness.measure.accuracy import data as _data
from harness.measure.accuracy.data import STATS, Point, load_grid, read_csv
from harness.scene.spec import Scene, SceneError

SANE_ERROR = 1.0   # fidelity auto ignores settings with any metric off by more than its scale


REFERENCE_FRACTION = 0.25   # fidelity auto needs a reference converged to this fraction of the tolerance


def reference_resolution(facts: dict, keys: list[str]) -> float:
    """How well the reference resolves the metrics ``keys``: the largest relative difference on
    them between the reference and its run one refinement coarser (``convergence_metrics`` of the
    stored facts; where a metric is missing there, the largest over all metrics, ``convergence``,
    which is never smaller). Infinite when nothing is stored: unknown is not resolved."""
    per = facts.get("convergence_metrics") or {}
    whole = float(facts.get("convergence", math.inf))
    vals = [float(per[k]) if k in per else whole for k in keys]
    return max(vals) if vals else whole


def _stored_facts(source: str) -> dict:
    try:
        return json.loads(_data.FACTS_FILE.read_text()).get("facts", {}).get(source, {})
    except (OSError, ValueError):
        return {}


def choose(scene: Scene, data: list[Point] | None = None, facts: dict | None = None) -> tuple[Point, str]:
    """Cheapest stored point of this scene whose error on the scene's requested outputs is within
    the requested tolerance, with convergence shown. Returns the point and a one-paragraph reason.

    The rule (errors are on the requested outputs, relative to their scales, against the grid's
    reference run):

    1. The reference must resolve the tolerance: its difference from its own run one refinement
       coarser (:func:`reference_resolution`) must be at most ``REFERENCE_FRACTION`` (1/4) of the
       tolerance, else the choice is refused (:class:`SceneError`, one line naming the scene, the
       tolerance and the reference's resolution). Why: an error measured against the reference is
       only known to within the reference's own error, which its next-coarser run bounds (for a
       method converging at order p >= 1 the reference's own error is about conv / (2^p - 1) <= conv).
       With a quarter, a point accepted at the tolerance is within 1.25 x the tolerance of the
       converged answer; with a reference worse than the tolerance, "within the tolerance" means
       "close to a reference that is itself off", and a coarse step can land there by chance.
    2. A (fidelity, internal tolerance, step) qualifies only if its error AND the errors of every
       finer stored step of the same fidelity and internal tolerance meet the tolerance (and every
       one of those runs succeeded and is sane: no metric off by more than ``SANE_ERROR`` of its
       scale). Why: errors of a convergent setting shrink as the step does; a coarse step that
       meets the tolerance while finer ones miss it is a cancellation of errors at that step (a
       peak sampled luckily), not accuracy the scene can rely on when its inputs change.
    3. Of the qualifying points, the one with the least stored wall time."""
    fid = scene.fidelity
    outputs = fid.get("outputs")
    tol = float(fid.get("tolerance", 0.01))
    if not outputs:
        raise SceneError(f"{scene.name}: fidelity = auto needs 'outputs' (quantities) and 'tolerance'")
    data = read_csv() if data is None else data
    source = fid.get("data", scene.name)
    everything = [p for p in data if p.scene == source]
    rows = [p for p in everything if p.ok]
    if not rows:
        raise SceneError(f"{scene.name}: no accuracy data stored for scene {source!r}; run `spurdiff accuracy {source}`")
    keys = [f"{k}({q})" for q in outputs for k in STATS]
    facts = _stored_facts(source) if facts is None else facts
    conv = reference_resolution(facts, keys)
    if not conv <= REFERENCE_FRACTION * tol:
        ref = (f"{facts.get('reference', '?')} at step {facts['ref_step']:g} s" if "ref_step" in facts
               else "no stored reference")
        raise SceneError(f"{scene.name}: fidelity = auto refused: tolerance {tol:g} on {', '.join(outputs)} is not "
                         f"resolved by the reference of {source!r} ({ref}), which differs from its next-coarser run "
                         f"by {conv:.2e} (at most {REFERENCE_FRACTION:g} x {tol:g} = {REFERENCE_FRACTION * tol:.2e} "
                         f"needed); rerun `spurdiff accuracy {source}` with a finer reference (harness/measure/accuracy/accuracy_grid.toml)")

    def err(p: Point) -> float:
        vals = [p.metric_errors.get(k, math.inf) for k in keys]
        return max(vals) if vals else math.inf

    # the requested outputs within the tolerance, and nothing else off by more than its own scale:
    # a step at which the coupling misbehaves elsewhere (a torque spike through the backlash) is
    # not a valid choice even if the requested outputs happen to be fine
    def meets(p: Point) -> bool:
        return p.ok and err(p) <= tol and p.error <= SANE_ERROR

    def finer(p: Point) -> list[Point]:
        return [q for q in everything if q.fidelity == p.fidelity and q.tolerance == p.tolerance and q.step < p.step]

    met = [p for p in rows if meets(p)]
    good = [p for p in met if all(meets(q) for q in finer(p))]
    lucky = [p for p in met if p not in good]
    if not good:
        best = min(rows, key=err)
        raise SceneError(f"{scene.name}: no stored fidelity meets tolerance {tol:g} on {', '.join(outputs)} "
                         f"with convergence shown (best: {best.fidelity} at step {best.step:g} with {err(best):.2e}"
                         + (f"; {len(lucky)} coarse point(s) met it while a finer step of theirs did not" if lucky else "")
                         + ")")
    pick = min(good, key=lambda p: p.wall)
    costliest = max(rows, key=lambda p: p.wall)
    reason = (f"fidelity auto: chose {pick.fidelity} at step {pick.step:g} s"
              + (f", tolerance {pick.tolerance:g}" if pick.tolerance else "")
              + f": error {err(pick):.2e} <= {tol:g} on {', '.join(outputs)}"
              + (f" and at its {len(finer(pick))} finer step(s)" if finer(pick) else "")
              + f", stored wall time {pick.wall:.4f} s, "
              f"{costliest.wall / pick.wall:.0f}x cheaper than the costliest stored setting "
              f"({costliest.fidelity} at step {costliest.step:g} s)")
    top = _highest_fidelity(source)
    full = [p for p in rows if p.fidelity == top and math.isclose(p.step, scene.step)]
    if full and top != pick.fidelity:
        f = min(full, key=lambda p: p.wall)
        reason += (f" and {f.wall / pick.wall:.1f}x cheaper than the highest fidelity ({top}) at the scene's step "
                   f"{scene.step:g} s")
    reason += f"; {len(good)} of {len(rows)} stored settings met it with convergence shown"
    if lucky:
        cheapest_lucky = min(lucky, key=lambda p: p.wall)
        reason += (f" ({len(lucky)} more met it only at a coarse step, a finer step of the same fidelity missing it, "
                   f"e.g. {cheapest_lucky.fidelity} at {cheapest_lucky.step:g} s: {err(cheapest_lucky):.2e})")
    return pick, reason + f"; reference resolved to {conv:.1e} on these outputs"


def _highest_fidelity(scene_name: str) -> str | None:
    """The reference fidelity of the scene's accuracy grid (its highest), if it has one."""
    try:
        return load_grid()[scene_name]["reference"]["fidelity"]
    except (KeyError, OSError, tomllib.TOMLDecodeError):
        return None


def apply_choice(scene: Scene, pick: Point) -> Scene:
    effects = {**scene.effects, **pick.effects}
    if pick.tolerance is not None:
        effects["tolerance"] = pick.tolerance
    return replace(scene, effects=effects, step=pick.step, output_interval=max(pick.step, scene.output_interval))
