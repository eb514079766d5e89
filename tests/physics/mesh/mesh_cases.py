"""The mesh-level test cases the mesh-dynamics tests share: the paper's loads and forces, a model at a
level, its outputs, a run of communication steps, time averages, the energy balance."""
import numpy as np

from spurdiff.differential.mesh import MeshDifferential, MeshParams
from spurdiff.differential.params import DifferentialParams

W0 = 1.389
STRAIGHT = (-1050.0, -1050.0)
CORNER = (-1110.201, -989.799)
F_THEORY = 6897.45  # N, normal force per pair at T0 = 2100 N m (statics, exact radii)
LEVELS = ("compliant", "contact")


def model(level="contact", loads=STRAIGHT, drive="speed", tau_c=0.0, w_left=float("nan"), law="pinFriction",
          locking_preload=0.0, **mesh):
    m = MeshDifferential(DifferentialParams(carrierDrive=drive, lockingLaw=law, lockingPreload=locking_preload),
                         MeshParams(level=level, **mesh))
    m.w_ref, m.tau_c = W0, tau_c
    m.tau_L, m.tau_R = loads
    m.w_start_carrier = W0
    m.w_start_left = w_left
    m.initialize()
    return m


def outputs(m):
    f = m.mesh_forces
    return np.array([m.tau_drive, m.tau_mesh_L, m.tau_mesh_R, f.F_A1, f.F_B2, f.F_12, m.w_L, m.w_R])


def run(m, t_end=0.3, h=1e-3, t0=0.0, events=None):
    """Step to t_end; returns the sampled outputs (rows: t = t0, t0 + h, ...)."""
    n = int(round((t_end - t0) / h))
    rows = [outputs(m)]
    for k in range(n):
        if events and k in events:
            events[k](m)
        m.do_step(t0 + k * h, h)
        rows.append(outputs(m))
    return np.array(rows)


def means(rows, h):
    """Time averages (trapezoidal rule), as the harness computes them."""
    return np.trapezoid(rows, dx=h, axis=0) / (h * (len(rows) - 1))


def energy_balance(m, e0):
    """work in - (change of kinetic + elastic energy) - loss (+ parametric work of the stiffness wave)."""
    return m.work_in + m.parametric_work - (m.kinetic_energy + m.potential_energy - e0) - m.energy_loss
