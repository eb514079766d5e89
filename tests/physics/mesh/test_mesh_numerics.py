"""Mesh dynamics, numerics: large and tiny communication steps, the integrators' orders (Rosenbrock-W,
RODAS5P), the loss quadrature, the right-hand side and its Jacobian, the integrator's LU solves, the
split solve of W and the dense output (split from test_mesh_dynamics.py)."""
import math

import numpy as np
import pytest

from spurdiff.differential.mesh import MeshDifferential, MeshParams
from spurdiff.differential.params import DifferentialParams
from tests.physics.mesh.mesh_cases import CORNER, LEVELS, model, outputs, run


# ------------------------------------------------------------------ numerics
@pytest.mark.parametrize("level", LEVELS)
def test_large_communication_steps_are_stable_and_accurate(level):
    def reverse(mm):
        mm.tau_L, mm.tau_R = 1050.0, 1040.0

    results = []
    for h in (1e-2, 1e-3):
        m = model(level, backlash=True, preload=False)
        rows = run(m, 0.3, h, events={int(round(0.1 / h)): reverse})
        assert np.all(np.isfinite(rows))
        results.append((rows[-1], m.energy_loss))
    (ra, la), (rb, lb) = results
    # all but F_12 (index 5) to 1e-4. The run ends stuck, and a stuck pair's F_12 is statically
    # indeterminate (anything inside both planets' friction intervals holds): it keeps the mesh-12
    # deflection of the moment the planets stuck, which depends on the step. Measured over h = 0.5 ..
    # 10 ms: a spread of 1.0e-4 with planar pins, 4.9e-4 with the end reactions (issue 41); held
    # to 1e-3 here
    keep = [0, 1, 2, 3, 4, 6, 7]
    assert ra[keep] == pytest.approx(rb[keep], rel=1e-4, abs=1e-6)
    assert ra[5] == pytest.approx(rb[5], rel=1e-3)
    assert la == pytest.approx(lb, rel=1e-4)


def test_tiny_communication_steps():
    m = model("contact", CORNER)
    rows = run(m, 2e-3, 1e-5)
    ref = model("contact", CORNER)
    run(ref, 2e-3, 1e-3)
    assert rows[-1] == pytest.approx(outputs(ref), rel=1e-6)


def test_rosenbrock_w_method_has_order_3_even_with_a_wrong_jacobian():
    from spurdiff.differential.mesh.integrator import RosenbrockW

    def f(y, out, J):  # oscillator driving a stiff component (eigenvalue -1e4)
        out[0], out[1], out[2] = -y[1], y[0], -1e4 * (y[2] - math.sin(y[0]))
        if J is not None:          # (rows of plain floats, as the mesh model's)
            for row in J:
                row[:] = [0.0, 0.0, 0.0]
            J[0][1], J[1][0], J[2][2], J[2][0] = -1.0, 1.0, -1e4, 1e4 * math.cos(y[0])

    for wrong in (False, True):
        errs = []
        for n in (20, 40, 80, 160):
            r = RosenbrockW(3, f)
            y, h, f0 = [1.0, 0.0, math.sin(1.0)], 2.0 / n, [0.0] * 3
            for _ in range(n):
                f(y, f0, r.J)
                if wrong:
                    r.J[2][0] = 0.0
                    r.J[0][1] *= 0.5
                assert r.step(y, f0, h)
                y = list(r.y_new)
            errs.append(np.max(np.abs(np.array(y[:2]) - [math.cos(2.0), math.sin(2.0)])))
        orders = [math.log2(a / b) for a, b in zip(errs, errs[1:])]
        assert all(2.9 < p < 3.1 for p in orders), (wrong, orders)


def test_rodas5p_has_order_5_and_its_estimate_and_dense_output_order_4():
    """RODAS5P with the exact Jacobian (it is not a W-method) on the same problem: global order 5;
    over one step from the exact solution, the embedded estimate and the dense output at the
    midpoint and the quarter points have local errors of order 5 (methods of order 4)."""
    from spurdiff.differential.mesh.integrator import RODAS5P, RosenbrockW

    def f(y, out, J):
        out[0], out[1], out[2] = -y[1], y[0], -1e4 * (y[2] - math.sin(y[0]))
        if J is not None:          # (rows of plain floats, as the mesh model's)
            for row in J:
                row[:] = [0.0, 0.0, 0.0]
            J[0][1], J[1][0], J[2][2], J[2][0] = -1.0, 1.0, -1e4, 1e4 * math.cos(y[0])

    errs = []
    for n in (5, 10, 20, 40):     # (at 80 steps the error, 1e-14, is rounding)
        r = RosenbrockW(3, f, RODAS5P)
        y, h, f0 = [1.0, 0.0, math.sin(1.0)], 2.0 / n, [0.0] * 3
        for _ in range(n):
            f(y, f0, r.J)
            assert r.step(y, f0, h)
            y = list(r.y_new)
        errs.append(np.max(np.abs(np.array(y[:2]) - [math.cos(2.0), math.sin(2.0)])))
    orders = [math.log2(a / b) for a, b in zip(errs, errs[1:])]
    assert all(4.7 < p < 6.5 for p in orders), orders     # (about 6 here: 6.0, 5.9, 5.9)
    est, dense = [], []
    for h in (0.2, 0.1, 0.05):
        r = RosenbrockW(3, f, RODAS5P)
        y, f0 = [1.0, 0.0, math.sin(1.0)], [0.0] * 3
        f(y, f0, r.J)
        assert r.step(y, f0, h)
        est.append(max(abs(v) for v in r.err[:2]))
        exact = lambda th: np.array([math.cos(th * h), math.sin(th * h)])   # noqa: E731
        pts = [(0.5, r.midpoint(y)), (0.25, r.dense_at(RODAS5P.dquarter[0], y)),
               (0.75, r.dense_at(RODAS5P.dquarter[1], y))]
        dense.append(max(np.max(np.abs(np.array(v[:2]) - exact(th))) for th, v in pts))
    for e in (est, dense):
        rates = [math.log2(a / b) for a, b in zip(e, e[1:])]
        assert all(4.5 < p < 5.7 for p in rates), (e, rates)


def test_the_five_point_loss_quadrature_is_exact_to_degree_5_and_estimates_beyond_3():
    """loss_quadrature5 (RODAS5P's): Boole's rule, exact for polynomials of degree <= 5; its
    estimate |Simpson(halves) - Simpson| vanishes to degree 3 and not for degree 4."""
    from spurdiff.differential.mesh.stepper import E_REF, loss_quadrature5

    h = 0.37
    for deg in range(6):
        P = lambda t: 2.0 + sum((k + 1) * t ** k for k in range(1, deg + 1))   # noqa: E731
        exact = 2.0 * h + sum((k + 1) * h ** (k + 1) / (k + 1) for k in range(1, deg + 1))
        d, e = loss_quadrature5(P(0.0), P(h / 4), P(h / 2), P(3 * h / 4), P(h), h, 1e-6)
        assert d == pytest.approx(exact, rel=1e-13), deg
        assert (e < 1e-6) if deg <= 3 else (e > 1.0), (deg, e)
    assert E_REF > 0.0


def test_rhs_is_the_integrated_ode():
    # the same ODE integrated by scipy's Radau (analytic Jacobian) gives the same state
    from scipy.integrate import solve_ivp

    m = model("contact", preload=False, pinFriction=False, tolerance=1e-9)
    y0 = m.state_vector()
    sol = solve_ivp(m.rhs, (0.0, 0.02), y0, method="Radau", jac=m.jac, rtol=1e-10,
                    atol=1e-10 * np.array([1, 1e-5, 1e-5, 1e-5, 1, 1, 1, 1]))
    run(m, 0.02, 1e-3)
    scale = np.array([1, 1e-5, 1e-5, 1e-5, 1, 1, 1, 1])
    assert np.max(np.abs(np.array(m.state_vector()) - sol.y[:, -1]) / scale) < 1e-6


def test_analytic_jacobian_matches_finite_differences():
    rng = np.random.default_rng(3)
    for drive in ("speed", "torque"):
        for mesh in (dict(level="compliant"), dict(level="contact", backlash=True)):
            mesh = dict(mesh)
            m = model(mesh.pop("level"), CORNER, drive, 2000.0, **mesh)
            for modes in ([0, 0], [1, -1], [0, 1]):
                m.s = modes
                y = np.array(m.state_vector())
                y[4:8] += rng.normal(0.0, 0.5, 4)
                y[1:4] *= 1.0 + rng.normal(0.0, 0.05, 3)
                y[6] = 0.0 if modes[0] == 0 else y[6]
                y[7] = 0.0 if modes[1] == 0 else y[7]
                J = np.array(m.jac(0.0, y))
                for j in range(len(y)):
                    e = np.zeros(len(y))
                    e[j] = 1e-7 * max(1e-4 if j in (1, 2, 3) else 1.0, abs(y[j]))
                    col = (np.array(m.rhs(0.0, y + e)) - np.array(m.rhs(0.0, y - e))) / (2 * e[j])
                    assert J[:, j] == pytest.approx(col, rel=1e-5, abs=1e-6 * np.abs(J).max())


# ------------------------------------------------------------------ the integrator's linear algebra and dense output
def test_the_integrators_lu_solves_with_partial_pivoting_and_refuses_a_singular_matrix():
    from spurdiff.differential.mesh.integrator import lu_factor, lu_solve

    rng = np.random.default_rng(3)
    for n in (1, 8, 10):
        A = rng.standard_normal((n, n))
        A[0, 0] = 0.0 if n > 1 else 2.0    # needs a row exchange
        b = rng.standard_normal(n)
        lu, piv = lu_factor(A.tolist())
        assert np.allclose(lu_solve(lu, piv, b.tolist()), np.linalg.solve(A, b), rtol=1e-10, atol=1e-12)
    S = np.ones((3, 3))
    assert lu_factor(S.tolist()) == (None, None)


def test_the_split_solve_of_w_is_the_solve_of_the_whole_matrix():
    """W = I/(gamma h) - J through the Schur complement on the velocities (integrator.split_factor,
    split_solve; the compiled kernel's solve) equals numpy's solve of the whole W, for the model's
    own Jacobian (the carrier's speed imposed; contact with flank friction) at step sizes from far
    below to far above the mesh period; the carrier free takes the general LU (no split); and
    Gauss-Jordan refuses a singular Schur complement."""
    from spurdiff.differential.mesh import MeshDifferential, MeshParams
    from spurdiff.differential.mesh.integrator import RODAS5P, gj_inverse, split_factor, split_solve
    from spurdiff.differential.mesh.layout import split
    from spurdiff.differential.params import DifferentialParams

    rng = np.random.default_rng(5)
    assert split(10) is None
    for drive in ("speed",):
        m = MeshDifferential(DifferentialParams(carrierDrive=drive),
                             MeshParams(level="contact", flankFriction=True, kernel="python"))
        m.w_ref = m.w_start_carrier = 20.0
        m.tau_c, m.tau_L, m.tau_R = 250.0, 150.0, 100.0
        m.initialize()
        N = m._N
        pos, vel = split(N)
        J = np.asarray(m.jac(0.0, m.state_vector()), dtype=float)
        assert np.all(J[np.ix_(pos, pos)] == 0.0)              # the split's premise: x_p' = B x_v
        assert np.count_nonzero(J[np.ix_(vel, pos)]) > 0 and np.count_nonzero(J[np.ix_(vel, vel)]) > 0
        for h in (1e-7, 1e-5, 1e-3, 1e-1, 10.0):
            e = RODAS5P.gamma * h
            F = split_factor(J.tolist(), e, pos, vel)
            W = np.eye(N) / e - J          # condition numbers 1e4 to 3e11 over these steps
            for _ in range(3):
                r = rng.standard_normal(N)
                x = np.array(split_solve(F, None, r.tolist()))
                xs = np.linalg.solve(W, r)
                # backward stable (normwise backward error at rounding level) and LAPACK's answer
                back = np.abs(W @ x - r).max() / (np.abs(W).max() * np.abs(x).max() + np.abs(r).max())
                assert back < 1e-15, (drive, h, back)
                assert np.abs(x - xs).max() <= 1e-12 * np.abs(xs).max(), (drive, h)
    assert gj_inverse([[1.0, 2.0], [2.0, 4.0]]) is None
    X = gj_inverse([[0.0, 2.0], [3.0, 1.0]])                     # a row exchange
    assert np.allclose(np.array(X) @ np.array([[0.0, 2.0], [3.0, 1.0]]), np.eye(2))


def test_the_dense_output_polynomial_is_the_tableaus_dense_output():
    """dpoly (the dense output's weights as a polynomial in theta, what the stepper and the kernel
    evaluate) gives the weights B(theta) Gamma^-1 of the tableau, for both methods."""
    from spurdiff.differential.mesh.integrator import METHODS, dense_weights

    for tr in METHODS.values():
        for th in (0.0, 0.1, 0.25, 0.5, 0.9, 1.0):
            d = sum(np.array(tr.dpoly[p]) * th ** (p + 1) for p in range(4))
            assert np.allclose(d, dense_weights(th, tr), rtol=1e-13, atol=1e-13), (tr.name, th)
        # at theta = 1 the dense output is the step's solution
        assert np.allclose(sum(np.array(tr.dpoly[p]) for p in range(4)), tr.m, rtol=1e-12, atol=1e-12), tr.name
