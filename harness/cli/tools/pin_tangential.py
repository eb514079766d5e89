"""What the planets' tangential pin loads change, and what holding the carrier acceleration of the
last step costs (docs/locking-law.md, "Carrier acceleration in the pin loads").

    python -m harness.cli.tools.pin_tangential [SCENE ...]     (default: vehicle-cornering tip-in-tip-out)

Runs each scene (rigid level, direct physics calls, its own communication step) three ways:

* ``lag``: the model as it is: with ``pinSpeedLoads`` the pins carry ``-m_i a_i alpha_c e_t,i``
  with ``alpha_c`` held over each step (carrierDrive = torque: the carrier acceleration at the end of
  the last step);
* ``mean``: the reference for the lag: each step repeated with the mean carrier acceleration of
  the step itself, ``(w_c(t+h) - w_c(t)) / h``, until it repeats (a fixed point, 1e-9 relative);
* ``off``: no tangential loads (the centrifugal ones stay).

and prints the largest and mean differences of the locking torque and the wheel speeds, lag
against mean (the error of the lag) and lag against off (what the term changes), with the largest
carrier acceleration and tangential pin load of the run.
"""
from __future__ import annotations

import argparse
import contextlib
import math
import sys

import numpy as np

from harness.run.direct import run_direct
from harness.run.runner import prepare_scene
from spurdiff.differential.rigid import RigidDifferential

SCENES = ("vehicle-cornering", "tip-in-tip-out")
SIGNALS = ("diff.lockingTorque", "wheelL.wheel.w", "wheelR.wheel.w")


@contextlib.contextmanager
def variant(kind: str):
    """The rigid model's class patched for the run: ``off`` zeroes the tangential loads, ``mean``
    repeats each carrier torque-driven step with its own mean carrier acceleration."""
    init, step = RigidDifferential.initialize, RigidDifferential.do_step
    stats = {"iterations": 0, "steps": 0}

    def initialize(self, t0: float = 0.0) -> None:
        init(self, t0)
        stats["m_a"] = tuple(math.hypot(*v) for v in self._ct)      # m_i a_i, kg m
        if kind == "off":
            self._ct = ((0.0, 0.0), (0.0, 0.0))

    def do_step_mean(self, t: float, h: float) -> None:
        if self.speed_drive or not self._exact:
            return step(self, t, h)
        snap = self.get_state()
        wc0, a = self.wc, self.ac
        for _ in range(20):
            self.ac = a                      # the held acceleration of this try (do_step reads it)
            step(self, t, h)
            stats["iterations"] += 1
            a_new = (self.wc - wc0) / h
            if abs(a_new - a) <= 1e-9 * (abs(a_new) + 1.0):
                break
            self.set_state(snap)
            a = a_new
        stats["steps"] += 1

    RigidDifferential.initialize = initialize
    if kind == "mean":
        RigidDifferential.do_step = do_step_mean
    try:
        yield stats
    finally:
        RigidDifferential.initialize, RigidDifferential.do_step = init, step


def measure(name: str) -> list[str]:
    runs = {}
    for kind in ("lag", "mean", "off"):
        # the patched Python step must be the one that runs: the compiled kernel and the native
        # step would bypass it (every difference would read 0)
        with variant(kind) as stats:
            r = run_direct(prepare_scene(name, mesh="rigid",
                                         sets=["diff.solver.kernel=python", "diff.solver.nativeStep=false"]))
        if r.failure is not None:
            raise SystemExit(f"{name} ({kind}) failed: {r.failure}")
        runs[kind] = r
        if kind == "mean":
            if stats["steps"] == 0:
                raise SystemExit(f"{name}: the reference's Python step never ran (a compiled step took its "
                                 "place): no lag can be measured")
            it = stats["iterations"] / stats["steps"]
        m_a = stats["m_a"]
    lag = runs["lag"]
    t = lag.time
    wc = lag["diff.carrier.w"]
    alpha = np.diff(wc) / np.diff(t)
    amax = float(np.max(np.abs(alpha)))
    out = [f"{name}: {len(t) - 1} communication steps of {t[1] - t[0]:g} s; largest carrier acceleration "
           f"{amax:.4g} rad/s^2 (mean |alpha_c| {np.mean(np.abs(alpha)):.4g}), so tangential pin loads up to "
           f"{m_a[0] * amax:.3g} / {m_a[1] * amax:.3g} N (planet 1 / 2, m_i a_i = {m_a[0]:.4g} / {m_a[1]:.4g} kg m); "
           f"reference: {it:.2f} tries per inner step"]
    for sig in SIGNALS:
        a, b, c = lag[sig], runs["mean"][sig], runs["off"][sig]
        out.append(f"  {sig:20s} lag - mean: max {np.max(np.abs(a - b)):.3e}, mean {np.mean(np.abs(a - b)):.3e};"
                   f"  lag - off: max {np.max(np.abs(a - c)):.3e}, mean {np.mean(np.abs(a - c)):.3e}"
                   f"  (largest |value| {np.max(np.abs(a)):.4g})")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m harness.cli.tools.pin_tangential", description=__doc__.split("\n")[0])
    ap.add_argument("scenes", nargs="*", default=list(SCENES))
    args = ap.parse_args(argv)
    for name in args.scenes:
        print("\n".join(measure(name)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
