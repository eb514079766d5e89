"""The differential with the half-shafts inside (``shaftCoupling = wheel``) and two WheelLoads,
coupled in plain Python (no FMI) as the vehicle scenes couple them: the loop the shaft tests step
(tests/physics/test_shafts.py) and the cost of the shafts' Newton on the sun torques.

``python -m harness.measure.bench.shafts``: inner-model evaluations and Jacobians per shaft sub-step
(:attr:`ShaftedDifferential.n_evals` / ``n_substeps``) on four cases at 1, 5 and 20 ms, 0.8 s
each; printed, never asserted.
"""
from __future__ import annotations

import math
import time

import numpy as np

from spurdiff.differential.mesh import MeshDifferential, MeshParams
from spurdiff.differential.params import DifferentialParams
from spurdiff.differential.rigid import RigidDifferential
from spurdiff.differential.shafts import ShaftedDifferential, ShaftParams, ShaftsParams, WheelSurrogate
from spurdiff.vehicle.wheel import WheelLoad, WheelLoadParams

R_WHEEL = WheelLoadParams.defaults().wheel.R


def make(mesh: str = "rigid", w0: float = 0.0, twist: float = 0.0, backlash: bool = False, tol: float = 1e-6,
         **kw):
    """A torque-driven differential (``mesh``: rigid or a mesh level) with its shafts inside and two
    WheelLoads (``shaftCoupling = wheel``, 3000 N, grip 1), all at the speed ``w0``; ``kw``: the
    ShaftsParams fields."""
    p = DifferentialParams(carrierDrive="torque", J_carrier=13.1)
    inner = (RigidDifferential(p) if mesh == "rigid"
             else MeshDifferential(p, MeshParams(level=mesh, backlash=backlash, tolerance=tol)))
    inner.w_start_carrier = w0
    inner.w_start_left = w0
    diff = ShaftedDifferential(inner, ShaftsParams(ShaftParams(phi_rel_start=twist), ShaftParams(phi_rel_start=twist),
                                                  **kw))
    wheels = []
    for _ in range(2):
        wp = WheelLoadParams.defaults()
        wp.shaftCoupling = "wheel"
        wp.wheel.w_start = w0
        wl = WheelLoad(wp)
        wl.Fz, wl.mu, wl.vx = 3000.0, 1.0, w0 * R_WHEEL
        wheels.append(wl)
    return diff, wheels


def surrogate_of(w: WheelLoad) -> WheelSurrogate:
    """The wheel's interface-model outputs as the differential's input (what the scenes connect)."""
    return WheelSurrogate(w.sur_a, w.sur_invJ, w.sur_dadw, w.sur_qrate, w.sur_ct, w.sur_rt)


class Loop:
    """Differential + two wheels, Gauss-Seidel (differential first); ``tau_c(t)``, ``Fz(t)``,
    ``mu(t)`` per side and ``vx(t)`` the wheel-centre speed (the car is not modelled here)."""

    def __init__(self, diff, wheels, tau_c, Fz=lambda t: (3000.0, 3000.0), mu=lambda t: (1.0, 1.0),
                 vx=lambda t: None, surrogate: bool = True):
        self.diff, self.wheels = diff, wheels
        self.surrogate = surrogate   # the wheels' interface model connected (False: speed held)
        self.tau_c, self.Fz, self.mu, self.vx = tau_c, Fz, mu, vx
        for w, fz, m in zip(wheels, Fz(0.0), mu(0.0)):
            w.Fz, w.mu = fz, m
        diff.tau_c = tau_c(0.0)
        self._wheel_inputs()
        diff.initialize(0.0)
        for w, tau in zip(wheels, (diff.tau_mean_L, diff.tau_mean_R)):
            w.tau_in = tau
            w.initialize(0.0)
        self.t = 0.0
        self.rows = []
        self.work_c = 0.0

    def _wheel_inputs(self):
        d, (wl, wr) = self.diff, self.wheels
        d.wheelL_phi, d.wheelL_w = getattr(wl, "phi", 0.0), getattr(wl, "w", wl.params.wheel.w_start)
        d.wheelR_phi, d.wheelR_w = getattr(wr, "phi", 0.0), getattr(wr, "w", wr.params.wheel.w_start)
        if self.surrogate and hasattr(wl, "sur_a"):
            d.wheelL_model, d.wheelR_model = surrogate_of(wl), surrogate_of(wr)

    def step(self, h: float):
        d, ws, t = self.diff, self.wheels, self.t
        d.tau_c = self.tau_c(t)
        self._wheel_inputs()
        d.do_step(t, h)
        vx = self.vx(t)
        for w, tau, dw, fz, m in zip(ws, (d.tau_mean_L, d.tau_mean_R), (d.dw_pred_L, d.dw_pred_R), self.Fz(t),
                                     self.mu(t)):
            w.tau_in, w.Fz, w.mu = tau, fz, m
            w.dw_in = dw
            w.vx = vx if vx is not None else w.vx
            w.do_step(t, h)
        self.t = t + h
        self.rows.append((self.t, d.wc, d.w_L, d.w_R, d.locking_torque, d.locking_capacity, ws[0].w, ws[1].w,
                          d.tau_mean_L, d.tau_mean_R, float(d.stuck)))

    def run(self, t_end: float, h):
        steps = h if callable(h) else (lambda: h)
        while self.t < t_end - 1e-12:
            self.step(min(steps(), t_end - self.t))
        return np.array(self.rows)


def start(loop: Loop) -> Loop:
    """The loop with its energy offset at the start (``E0``: work in minus stored minus lost)."""
    d = loop.diff
    loop.E0 = d.work_in - d.kinetic_energy - d.potential_energy - d.energy_loss
    return loop


# the Newton-cost cases: constant, patchy and oscillating loads, one wheel on ice
COST_CASES = {
    "steady 300 N m, split mu": dict(tau_c=lambda t: 300.0, mu=lambda t: (0.6, 1.0), vx=lambda t: 10.0),
    "stick-slip patch": dict(tau_c=lambda t: 300.0, mu=lambda t: (0.05 if 0.1 <= t < 0.3 else 1.0, 1.0),
                             vx=lambda t: 10.0),
    "sine torque": dict(tau_c=lambda t: 150.0 + 100.0 * math.sin(8.0 * t), mu=lambda t: (0.8, 1.0),
                        vx=lambda t: 10.0),
    "mu 0 one side": dict(tau_c=lambda t: 300.0, mu=lambda t: (0.0, 1.0), vx=lambda t: 5.0),
}


def newton_cost(steps=(1e-3, 5e-3, 2e-2), t_end: float = 0.8) -> list[dict]:
    """Inner-model evaluations and Jacobians per shaft sub-step, sub-steps and wall time of each
    case of COST_CASES (rigid inner model, 10 m/s) at each communication step; printed, returned."""
    rows = []
    for h in steps:
        for name, kw in COST_CASES.items():
            diff, wheels = make(w0=10.0 / R_WHEEL)
            loop = start(Loop(diff, wheels, **kw))
            t0 = time.perf_counter()
            loop.run(t_end, h)
            rows.append({"case": name, "step": h, "evals": diff.n_evals / diff.n_substeps,
                         "jacobians": diff.n_jacobians / diff.n_substeps, "substeps": diff.n_substeps,
                         "wall": time.perf_counter() - t0})
    print("| case | step ms | evaluations / sub-step | Jacobians / sub-step | sub-steps | wall s |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['case']} | {r['step'] * 1e3:g} | {r['evals']:.3f} | {r['jacobians']:.3f} | {r['substeps']} | "
              f"{r['wall']:.2f} |")
    return rows


if __name__ == "__main__":
    newton_cost()
