"""The mesh phase as a mode (issue 32): the stiffness factor and the pairs in contact held over each
internal step and switched at the located single/double contact boundary, so the hard cases run
at tight tolerances with both methods; the compiled kernel equals the Python reference through
the switches; the analytic Jacobian with flank friction (the lever arms' dependence on the mesh
phase) against central differences."""
from __future__ import annotations

import math

import numpy as np
import pytest

from harness.measure.bench.mesh_cases import paper_case
from harness.build.fmu import kernel_library
from spurdiff.differential.mesh import MeshDifferential, MeshParams
from spurdiff.differential.mesh.events import leave, phase_mode
from spurdiff.differential.mesh.layout import DA, PSI, VA, VB, W1, W2, rolls
from spurdiff.differential.params import DifferentialParams

SCALE = np.array([1.0, 1e-5, 1e-5, 1e-5, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0])   # rad, m, rad/s (the error norm's)
OPTIONS = {"stiffness wave": {"meshStiffnessVariation": True}, "flank friction": {"flankFriction": True}}
METHODS = ("ros34pw2", "rodas5p")
# the shortened hard cases (contact level, unloaded meshes, 1 ms steps): paper-cornering's relative
# speeds grow from rest; the loaded flanks cross their first single/double contact boundary after
# 4.0 ms (where the runs stopped before), 7 boundaries in 8 ms with the stiffness wave and in 10 ms
# with flank friction (which slows the slip); paper-straight's phases are frozen (the gears do not
# roll relative to the carrier: no boundary): 3 ms, its start transient at the tight tolerance
DURATION = {("paper-cornering", "stiffness wave"): 0.008, ("paper-cornering", "flank friction"): 0.010,
            ("paper-straight", "stiffness wave"): 0.003, ("paper-straight", "flank friction"): 0.003}


@pytest.fixture(scope="module", autouse=True)
def compiled_kernel():
    return kernel_library()


def model(scene, kernel="auto", drive="speed", **mesh):
    case = paper_case(scene)
    p = DifferentialParams(carrierDrive=drive, lockingLaw=case["lockingLaw"],
                           J_carrier=13.0 if drive == "torque" else 0.0)
    m = MeshDifferential(p, MeshParams(level="contact", kernel=kernel, **mesh))
    m.w_ref = m.w_start_carrier = case["w0"]
    m.tau_c = 2100.0 if drive == "torque" else 0.0
    m.tau_L, m.tau_R = case["loads"]
    m.initialize()
    return m


def run(m, t_end, h=1e-3):
    for k in range(int(round(t_end / h))):
        m.do_step(k * h, h)
    return m


def boundaries(m, y0, y1) -> int:
    """Single/double contact boundaries between two states on the drive flanks (the loaded ones
    in these cases), counted from the phases (the rolls are monotone over these runs)."""
    u0, u1 = rolls(m, list(y0)), rolls(m, list(y1))
    count = 0
    for i, md in enumerate(m.md):
        z0 = md.xi0 - md.sigma * u0[i] / md.pb
        z1 = md.xi0 - md.sigma * u1[i] / md.pb
        for off in (0.0, md.eps - 1.0):
            count += abs(math.floor(z1 - off) - math.floor(z0 - off))
    return count


# ------------------------------------------------------------------ the hard cases
@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("tol", [1e-9, 1e-10])
@pytest.mark.parametrize("option", list(OPTIONS))
@pytest.mark.parametrize("scene", ["paper-cornering", "paper-straight"])
def test_tight_tolerances_run_through_the_phase_boundaries(scene, option, tol, method):
    """Contact level from unloaded meshes: ran into a StepError (internal step below 1e-13 s) at a
    single/double contact boundary before the phase was a mode. Now it runs, switches the mode
    at every boundary the loaded flanks cross, and agrees with the other method at 1e-10."""
    m = model(scene, preload=False, tolerance=tol, method=method, maxInternalSteps=10 ** 6, **OPTIONS[option])
    y0 = m.state_vector()
    run(m, DURATION[scene, option])
    crossed = boundaries(m, y0, m.state_vector())
    counts = m.solver_counts()
    if scene == "paper-cornering":
        assert crossed >= 6 and counts["phase_switches"] == crossed, (crossed, counts)
    else:
        assert crossed == 0 and counts["phase_switches"] == 0, (crossed, counts)
    other = model(scene, preload=False, tolerance=1e-10, method=METHODS[1 - METHODS.index(method)],
                  maxInternalSteps=10 ** 6, **OPTIONS[option])
    run(other, DURATION[scene, option])
    ym, yo = np.array(list(m.y)), np.array(list(other.y))
    sc = np.maximum(np.abs(yo), SCALE[:ym.size])
    assert np.max(np.abs(ym - yo) / sc) < 1e3 * tol


def test_the_held_mode_switches_at_the_boundary_and_converges_there():
    """The switch lands just past the boundary: at tolerance 1e-10 the sun speeds of the 6 ms
    cornering run with the stiffness wave agree with the tolerance-1e-9 run to 1e-8 relative
    (before, both stopped with a StepError at the first boundary)."""
    a = run(model("paper-cornering", preload=False, tolerance=1e-9, meshStiffnessVariation=True), 0.006)
    b = run(model("paper-cornering", preload=False, tolerance=1e-10, meshStiffnessVariation=True), 0.006)
    ya, yb = np.array(list(a.y)), np.array(list(b.y))
    assert np.max(np.abs(ya[VA:W2 + 1] - yb[VA:W2 + 1]) / np.abs(yb[VA:W2 + 1])) < 1e-8


def test_leave_finds_where_the_phase_leaves_its_interval():
    assert leave(0.1, 0.2, 0.3, 0.0, 0.5) == 1.0
    assert leave(0.4, 0.6, 0.8, 0.0, 0.5) == pytest.approx(0.25)
    assert leave(0.4, 0.45, 0.55, 0.0, 0.5) == pytest.approx(0.75)
    assert leave(0.1, -0.1, -0.3, 0.0, 0.5) == pytest.approx(0.25)
    assert leave(0.1, 0.05, -0.05, 0.0, 0.5) == pytest.approx(0.75)


# ------------------------------------------------------------------ kernel and reference
@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("option", ["stiffness wave", "flank friction", "all"])
def test_kernel_equals_the_reference_through_the_phase_switches(option, method):
    """Bit for bit, every communication step, over boundaries (tolerance 1e-7 keeps the Python
    reference's cost small; the switches are the same code at any tolerance)."""
    mesh = (dict(backlash=True, meshStiffnessVariation=True, flankFriction=True) if option == "all"
            else OPTIONS[option])
    a = model("paper-cornering", kernel="python", preload=False, tolerance=1e-7, method=method, **mesh)
    b = model("paper-cornering", kernel="compiled", preload=False, tolerance=1e-7, method=method, **mesh)
    for k in range(8 if option == "stiffness wave" else 10):
        a.do_step(k * 1e-3, 1e-3)
        b.do_step(k * 1e-3, 1e-3)
        assert list(a.y) == list(b.y), k
    for name in ("n_internal_steps", "n_rejected_steps", "n_mode_switches", "n_contact_transitions",
                 "work_in", "energy_loss", "parametric_work"):
        assert getattr(a, name) == getattr(b, name), name
    assert a.solver_counts() == b.solver_counts()
    assert a.solver_counts()["phase_switches"] >= 4


def held_states(m, rng, n, near_stick):
    """States off the trajectory with the gears rolling; near_stick: a pair of each mesh sliding
    inside the stiction band (|v| < v_s, where mu(v) is steepest)."""
    y0 = np.array(m.state_vector())
    out = []
    for _ in range(n):
        y = y0.copy()
        y[PSI] = rng.uniform(-0.5, 0.5)
        y[1:4] = np.abs(y0[1:4]) * (1.0 + rng.normal(0.0, 0.05, 3))
        y[VA:W2 + 1] = rng.normal(0.0, 20.0, 4)
        if near_stick:           # planets 1 and 2 rolling so that mesh 12's pair slides at ~v_s
            md = m.md[2]
            xi = phase_mode_xi(m, y, 2)
            l1 = md.l1min + xi * md.pb
            l2 = md.L - l1
            v_target = rng.uniform(-1.0, 1.0) * m.mesh.vStiction
            y[W2] = (v_target - y[W1] * l1) / l2
        out.append(y)
    return out


def phase_mode_xi(m, y, i):
    md = m.md[i]
    u = rolls(m, list(y))[i]
    z = md.xi0 - md.sigma * u / md.pb
    return z - math.floor(z)


@pytest.mark.parametrize("drive", ["speed", "torque"])
@pytest.mark.parametrize("near_stick", [False, True])
def test_the_jacobian_with_flank_friction_matches_central_differences(drive, near_stick):
    """The analytic Jacobian with flank friction (and the stiffness wave), the phase mode held at
    the state's own (so the differences do not cross a boundary), against central differences
    in every column including sun A's angle (the lever arms), stuck and slipping planets."""
    rng = np.random.default_rng(7)
    for kern in ("python", "compiled"):
        m = model("paper-cornering", kernel=kern, drive=drive, flankFriction=True, meshStiffnessVariation=True)
        checked = 0
        for modes in ([1, -1], [0, 0], [0, 1]):
            m.s = modes
            for y in held_states(m, rng, 6, near_stick):
                if modes[0] == 0:
                    y[W1] = 0.0
                if modes[1] == 0:
                    y[W2] = 0.0
                m._mode = phase_mode(m, y)
                try:
                    J = np.array(m.jac(0.0, y))
                    for j in range(len(y)):
                        e = np.zeros(len(y))
                        e[j] = 1e-7 * max(1e-4 if j in (1, 2, 3) else 1.0, abs(y[j]))
                        if near_stick and j >= VA:
                            e[j] = 1e-10          # inside the stiction band mu(v) turns within 1e-4 m/s
                        col = (np.array(m.rhs(0.0, y + e)) - np.array(m.rhs(0.0, y - e))) / (2 * e[j])
                        assert J[:, j] == pytest.approx(col, rel=1e-5, abs=1e-6 * np.abs(J).max()), (kern, j)
                finally:
                    m._mode = None
                checked += 1
        assert checked == 18


def test_the_lever_arms_are_in_the_jacobian():
    """With flank friction the suns' accelerations depend on sun A's angle and sun B's on the
    deflection of mesh A1 (the lever arms move with the mesh phases, which the rolls set);
    without it they do not (speed drive: no coupling through the carrier)."""
    for flank in (True, False):
        m = model("paper-cornering", flankFriction=flank)
        y = m.state_vector()
        y[VA:W2 + 1] = (-3.0, 3.0, 8.0, -8.0)
        J = np.array(m.jac(0.0, y))
        assert (J[VA, PSI] != 0.0 and J[VB, PSI] != 0.0 and J[VB, DA] != 0.0) == flank
        assert (J[VA, PSI] == 0.0 and J[VB, PSI] == 0.0 and J[VB, DA] == 0.0) == (not flank)
