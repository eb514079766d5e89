"""The paper's two cases as direct models for the mesh benchmarks (:mod:`harness.measure.bench.mesh`,
:mod:`harness.measure.bench.mesh_ivp`): read from the scenes ``paper-straight`` and ``paper-cornering``
(carrier speed, sun loads, locking law, duration, step), made at a mesh level, stepped and sampled."""
from __future__ import annotations

import time

import numpy as np

from harness.scene.spec import load_scene
from spurdiff.differential.mesh import MeshDifferential, MeshParams
from spurdiff.differential.params import DifferentialParams
from spurdiff.differential.rigid import RigidDifferential

PAPER_SCENES = ("paper-straight", "paper-cornering")
SCALE = np.array([1.0, 1e-5, 1e-5, 1e-5, 1.0, 1.0, 1.0, 1.0])  # state units for error norms


def paper_case(scene_name: str) -> dict:
    """Carrier speed, sun loads, locking law, duration and step of a paper scene (its differential
    instance ``diff`` with constant inputs)."""
    sc = load_scene(scene_name)
    inp = sc.inputs
    params = next(i.parameters for i in sc.instances if i.name == "diff")
    return {"w0": inp["diff.carrier.w_ref"].value, "loads": (inp["diff.left.tau"].value, inp["diff.right.tau"].value),
            "lockingLaw": params.get("lockingLaw", "pinFriction"), "duration": sc.duration, "step": sc.step}


def make(level: str, case: dict, **mesh):
    """A model of the paper case ``case`` (:func:`paper_case`) at ``level``, initialized."""
    p = DifferentialParams(lockingLaw=case["lockingLaw"])
    if level == "rigid":
        m = RigidDifferential(p)
    else:
        m = MeshDifferential(p, MeshParams(level=level, **mesh))
    m.w_ref, m.w_start_carrier = case["w0"], case["w0"]
    m.tau_L, m.tau_R = case["loads"]
    m.initialize()
    return m


def sample(m) -> list[float]:
    f = m.mesh_forces
    return [m.tau_drive, m.tau_mesh_L, m.tau_mesh_R, f.F_A1, f.F_B2, f.F_12, m.w_L, m.w_R]


def simulate(m, t_end=0.3, h=1e-3):
    """Step with the paper's 1 ms output step; returns (time averages, final sample, wall s)."""
    n = int(round(t_end / h))
    rows = [sample(m)]
    t0 = time.perf_counter()
    for k in range(n):
        m.do_step(k * h, h)
        rows.append(sample(m))
    wall = time.perf_counter() - t0
    rows = np.array(rows)
    return np.trapezoid(rows, dx=h, axis=0) / t_end, rows[-1], wall


def trajectory(m, t_end=0.3, h=1e-3, events=None, clock=time.perf_counter):
    """States at the communication points of a do_step loop, and the time it took by ``clock``
    (default wall time)."""
    n = int(round(t_end / h))
    ys = [m.state_vector()]
    t0 = clock()
    for k in range(n):
        if events and k in events:
            events[k](m)
        m.do_step(k * h, h)
        ys.append(m.state_vector())
    return np.array(ys), clock() - t0
