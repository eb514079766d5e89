"""The Rosenbrock tableaux (spurdiff.differential.mesh.integrator: ROS34PW2, RODAS5P) against their order
conditions to rounding, in the form the integrators use and in the tables the compiled kernel receives
(issue 47 item 2).

The conditions are generated from rooted trees (Hairer, Wanner, Solving ODEs II, 2nd ed., sec. IV.7:
the order conditions of Rosenbrock methods, Table 7.1; those of W-methods, where the matrix is
arbitrary, with trees whose vertices are either ``f`` or the matrix ``A``, same section) and computed directly
in the transformed variables ``u_i = sum_j Gamma_ij k_j`` the integrators step with (``a``, ``c``,
``m``, ``e``, the dense output ``d(theta)``): for a stage, ``k_i = h f(y + sum_j a_ij u_j) + h A u_i``
and ``u_i = gamma (k_i + sum_{j<i} c_ij u_j)``, so the elementary weights of ``u`` follow by a
forward substitution with ``c`` (no inverse taken). ``A = J`` (a Rosenbrock method) makes the
``A`` vertex a single-child ``f`` vertex; a W-method satisfies the conditions of every tree with
``A`` vertices as well (their exact coefficient is 0). Claimed (docstring and sources): ROS34PW2 (Rang
and Angermann, BIT 45 (2005) 761; Rang, "Improved traditional Rosenbrock-Wanner methods for stiff
ODEs and DAEs", J. Comput. Appl. Math. 286 (2015) 128) a W-method of order 3 with an embedded
W-method of order 2, dense output of order 3; RODAS5P (Steinebach, BIT 63 (2023) 27) a Rosenbrock
method of order 5 with embedded order 4 and a dense output of order 4.

Found here, and asserted: ROS34PW2's dense output has order 3 only with the exact Jacobian; with an
arbitrary matrix (as a W-method) it has order 2 (the trees with an ``A`` vertex of order 3 fail).

Tolerance: a residual ``sum_i w_i U_i(t) - exact(t)`` counts as zero when it is below ``TOL`` times
the size of its terms ``sum_i |w_i U_i(t)|`` (at least 1): 1e-14, a few units of rounding of the
16-17 digit coefficients; a coefficient changed at its 12th significant digit moves a residual by
about 1e-12 and fails (test_a_change_at_the_12th_digit_of_any_ros34pw2_coefficient_is_caught).
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import pytest

from spurdiff.differential.mesh import integrator as I

TOL = 1e-14
THETAS = (0.1, 0.25, 0.5, 0.75, 0.9, 1.0)


# ------------------------------------------------------------------ trees
@lru_cache(maxsize=None)
def trees(n: int, w_vertices: bool = False) -> tuple:
    """The rooted trees with ``n`` vertices, each ``("f", children)`` or ``("A", (child,))`` (an ``A``
    vertex has exactly one child: the matrix applied to a stage); children as a sorted tuple."""
    if n == 1:
        return (("f", ()),)
    out = {("f", forest) for forest in forests(n - 1, w_vertices)}
    if w_vertices:
        out |= {("A", (t,)) for t in trees(n - 1, True)}
    return tuple(sorted(out, key=repr))


@lru_cache(maxsize=None)
def forests(n: int, w_vertices: bool) -> tuple:
    """The multisets of trees with ``n`` vertices in all, as sorted tuples."""
    out = set()
    for k in range(1, n + 1):
        for t in trees(k, w_vertices):
            if k == n:
                out.add((t,))
            else:
                out |= {tuple(sorted((t,) + rest, key=repr)) for rest in forests(n - k, w_vertices)}
    return tuple(sorted(out, key=repr))


def size(t) -> int:
    return 1 + sum(size(c) for c in t[1])


def density(t) -> int:
    """gamma(t) of Butcher: the exact solution's coefficient is 1 / gamma(t)."""
    return size(t) * math.prod(density(c) for c in t[1])


def has_a(t) -> bool:
    return t[0] == "A" or any(has_a(c) for c in t[1])


def exact(t, theta: float = 1.0) -> float:
    """The exact solution's coefficient of tree t at theta h (0 for a tree with an A vertex)."""
    return 0.0 if has_a(t) else theta ** size(t) / density(t)


# ------------------------------------------------------------------ the tables in the form used
class Table:
    """A method in the transformed variables: gamma, a and c (s x s, strictly lower), the solution
    weights m, the error weights e (the embedded method's weights m - e), and the dense output's
    weights d_j(theta) = sum_p dpoly[p][j] theta^(p+1); plus dmid (theta 1/2) and dquarter (1/4, 3/4)
    where given."""

    def __init__(self, name, gamma, a, c, m, e, dpoly, dmid, dquarter, order, embedded_order, w_method):
        self.name, self.gamma, self.a, self.c = name, float(gamma), np.array(a, float), np.array(c, float)
        self.m, self.e, self.dpoly = np.array(m, float), np.array(e, float), np.array(dpoly, float)
        self.dmid = np.array(dmid, float)
        self.dquarter = None if dquarter is None else np.array(dquarter, float)
        self.order, self.embedded_order, self.w_method = order, embedded_order, w_method
        self.s = len(self.m)

    def dense(self, theta: float) -> np.ndarray:
        return sum(self.dpoly[p] * theta ** (p + 1) for p in range(self.dpoly.shape[0]))


def from_python(tr: I.Transformed) -> Table:
    s = tr.stages
    a, c = np.zeros((s, s)), np.zeros((s, s))
    for i in range(s):
        a[i, :i], c[i, :i] = tr.a_rows[i], tr.c_rows[i]
    return Table(tr.name, tr.gamma, a, c, tr.m, tr.e, tr.dpoly, tr.dmid, tr.dquarter, tr.order, tr.embedded_order,
                 tr.w_method)


def from_kernel(method: str, tr: I.Transformed) -> Table:
    """The table as the compiled kernel receives it: read back from the ctypes structure
    (kernel.MkParams) the model passes to mk_advance by pointer."""
    from harness.build.fmu import kernel_library
    from spurdiff.differential.mesh import MeshDifferential, MeshParams
    from spurdiff.differential.params import DifferentialParams

    kernel_library()
    model = MeshDifferential(DifferentialParams(), MeshParams(level="compliant", kernel="compiled", method=method))
    model.initialize()
    assert model.kernel_in_use == "compiled"
    P = model._kernel.params
    s = int(P.stages)
    assert s == tr.stages and bool(P.w_method) == tr.w_method
    A, Cc = np.ctypeslib.as_array(P.a).copy(), np.ctypeslib.as_array(P.cc).copy()
    # what the kernel does not read (k >= i in row i, stages past s) is zero
    assert not np.triu(A).any() and not np.triu(Cc).any() and not A[s:].any()
    dq = np.ctypeslib.as_array(P.dq)[:, :s].copy() if P.loss5 else None
    arr = np.ctypeslib.as_array
    return Table(f"{tr.name} (kernel)", P.gamma, A[:s, :s], Cc[:s, :s], arr(P.m)[:s], arr(P.ew)[:s],
                 arr(P.dpoly)[:, :s], arr(P.dmid)[:s], dq, tr.order, tr.embedded_order, tr.w_method)


def stage_weights(tab: Table, t, exact_jacobian: bool, memo: dict) -> np.ndarray:
    """U_i(t): the elementary weights of the transformed stages u_i for tree t."""
    if t in memo:
        return memo[t]
    kind, children = t
    if kind == "f":
        K = np.ones(tab.s)
        for ch in children:
            K = K * (tab.a @ stage_weights(tab, ch, exact_jacobian, memo))
        if exact_jacobian and len(children) == 1:       # h J u_i, J the exact Jacobian
            K = K + stage_weights(tab, children[0], exact_jacobian, memo)
    else:                                               # h A u_i
        K = stage_weights(tab, children[0], exact_jacobian, memo).copy()
    U = np.zeros(tab.s)
    for i in range(tab.s):
        U[i] = tab.gamma * (K[i] + tab.c[i, :i] @ U[:i])
    memo[t] = U
    return U


def residuals(tab: Table, weights: np.ndarray, order: int, w_trees: bool, theta: float = 1.0) -> list:
    """[(tree, residual, size of its terms)] for every tree of order 1..order: sum_i w_i U_i(t) against
    the exact coefficient; with ``w_trees`` the trees with A vertices too (W-method)."""
    memo, out = {}, []
    for n in range(1, order + 1):
        for t in trees(n, w_trees):
            terms = weights * stage_weights(tab, t, not w_trees, memo)
            out.append((t, float(terms.sum() - exact(t, theta)), max(1.0, float(np.abs(terms).sum()))))
    return out


def failing(res: list) -> list:
    return [(t, r) for t, r, scale in res if abs(r) > TOL * scale]


def worst(res: list) -> float:
    return max(abs(r) / scale for _, r, scale in res)


def order_of(tab: Table, weights: np.ndarray, w_trees: bool, theta: float = 1.0, top: int = 7) -> int:
    """The highest p such that all the conditions up to order p hold to rounding."""
    p = 0
    while p < top and not failing(residuals(tab, weights, p + 1, w_trees, theta)):
        p += 1
    return p


TABLES = {"ros34pw2": I.METHOD, "rodas5p": I.RODAS5P}
DENSE_ORDER = {"ros34pw2": (3, 2), "rodas5p": (4, None)}    # (exact Jacobian, any matrix: W-method)


@pytest.fixture(scope="module", params=[(m, src) for m in TABLES for src in ("python", "kernel")],
                ids=lambda p: f"{p[0]}-{p[1]}")
def table(request) -> tuple[str, Table]:
    method, src = request.param
    tr = TABLES[method]
    return method, (from_python(tr) if src == "python" else from_kernel(method, tr))


# ------------------------------------------------------------------ the tests
def test_the_trees_are_the_known_ones():
    """Rooted trees (OEIS A000081: 1, 1, 2, 4, 9, 20) and densities (HW II Table 7.1's right-hand sides
    at gamma = 0: 1, 1/2, 1/3, 1/6, ...); the W trees: 1, 2, 5, 13 up to order 4."""
    assert [len(trees(n)) for n in range(1, 7)] == [1, 1, 2, 4, 9, 20]
    assert [len(trees(n, True)) for n in range(1, 5)] == [1, 2, 5, 13]
    assert sorted(density(t) for t in trees(3)) == [3, 6]
    assert sorted(density(t) for t in trees(4)) == [4, 8, 12, 24]


def test_the_solution_has_the_claimed_order_and_not_more(table):
    method, tab = table
    assert worst(residuals(tab, tab.m, tab.order, False)) <= TOL, failing(residuals(tab, tab.m, tab.order, False))
    assert order_of(tab, tab.m, False) == tab.order
    if tab.w_method:     # the order for any matrix in W (ROS34PW2)
        assert order_of(tab, tab.m, True) == tab.order
    else:                # RODAS5P is no W-method: with A != J it has order 1 only
        assert order_of(tab, tab.m, True) < tab.order


def test_the_error_estimator_has_the_embedded_order_and_not_more(table):
    """The embedded solution y + sum (m_i - e_i) u_i has the embedded order (W: for any matrix where the
    method claims it), and not the method's order (else the estimate would not see the error)."""
    method, tab = table
    emb = tab.m - tab.e
    assert order_of(tab, emb, False) == tab.embedded_order
    if tab.w_method:
        assert order_of(tab, emb, True) == tab.embedded_order
    # the estimate itself: sum e_i U_i(t) vanishes to the embedded order, not beyond
    res = residuals(tab, tab.e, tab.embedded_order + 1, False)
    low = [(t, r + exact(t), sc) for t, r, sc in res if size(t) <= tab.embedded_order]
    assert max(abs(r) / sc for _, r, sc in low) <= TOL
    assert any(abs(r + exact(t)) > 1e-6 for t, r, _ in res if size(t) == tab.embedded_order + 1)


@pytest.mark.parametrize("theta", THETAS)
def test_the_dense_output_has_its_order_at_every_theta(table, theta):
    """sum_j d_j(theta) U_j(t) = theta^|t| / gamma(t): order 3 (ROS34PW2, exact Jacobian; 2 as a
    W-method), 4 (RODAS5P); at theta = 1 the dense output is the solution."""
    method, tab = table
    d = tab.dense(theta)
    exact_order, w_order = DENSE_ORDER[method]
    if theta == 1.0:            # the solution's order (for any matrix where it is a W-method)
        exact_order, w_order = tab.order, (tab.order if tab.w_method else None)
    assert order_of(tab, d, False, theta) == exact_order, (theta, failing(residuals(tab, d, exact_order, False, theta)))
    if w_order is not None:
        assert order_of(tab, d, True, theta) == w_order
    if theta == 1.0:
        assert np.allclose(d, tab.m, rtol=0, atol=TOL * max(1.0, np.abs(tab.m).max()) * 4)


def test_the_midpoint_and_quarter_weights_are_the_dense_output(table):
    """dmid (theta 1/2) and dquarter (1/4, 3/4; RODAS5P's five-point loss quadrature) as passed are the
    dense output's, and have its order."""
    method, tab = table
    exact_order = DENSE_ORDER[method][0]
    points = [(0.5, tab.dmid)] + ([] if tab.dquarter is None else [(0.25, tab.dquarter[0]), (0.75, tab.dquarter[1])])
    assert (tab.dquarter is not None) == (tab.order > 3)
    for theta, w in points:
        assert np.allclose(w, tab.dense(theta), rtol=0, atol=1e-14 * max(1.0, np.abs(w).max()))
        assert not failing(residuals(tab, w, exact_order, False, theta)), theta


def stability(tab: Table, z: complex, weights: np.ndarray) -> complex:
    """R(z) of y' = lambda y, z = h lambda, in the transformed form: (1/gamma - z) u_i = z (1 + sum a_ij
    u_j) + sum c_ij u_j; R = 1 + sum w_i u_i."""
    M = np.diag(np.full(tab.s, 1.0 / tab.gamma - z)) - z * tab.a - tab.c
    return 1.0 + weights @ np.linalg.solve(M.astype(complex), np.full(tab.s, z, dtype=complex))


def test_both_methods_are_l_stable(table):
    """R(infinity) = 0 (the limit: u = -(I + a)^-1 1, R = 1 + m u) and |R(iy)| <= 1 on the imaginary axis
    (A-stable: R has its poles at 1/gamma > 0), as the docstring claims."""
    _, tab = table
    r_inf = 1.0 - tab.m @ np.linalg.solve(np.eye(tab.s) + tab.a, np.ones(tab.s))
    assert abs(r_inf) <= 1e-13
    assert abs(stability(tab, -1e12, tab.m)) < 1e-9
    for y in np.geomspace(1e-3, 1e6, 200):
        assert abs(stability(tab, 1j * y, tab.m)) <= 1.0 + 1e-13, y


def test_the_kernel_receives_the_python_tables_bit_for_bit():
    for method, tr in TABLES.items():
        k, p = from_kernel(method, tr), from_python(tr)
        for f in ("a", "c", "m", "e", "dpoly", "dmid"):
            assert np.array_equal(getattr(k, f), getattr(p, f)), (method, f)
        assert k.gamma == p.gamma and (k.dquarter is None) == (p.dquarter is None)
        if p.dquarter is not None:
            assert np.array_equal(k.dquarter, p.dquarter)


# ------------------------------------------------------------------ the stored ROS34PW2 data itself
def hw_table_7_1(alpha, Gamma, b) -> list[float]:
    """HW II Table 7.1's conditions up to order 3, written out (beta = alpha + Gamma without its diagonal,
    beta'_j = sum_k beta_jk, alpha_j = sum_k alpha_jk, g = the diagonal): residuals."""
    g = Gamma[0, 0]
    beta = alpha + Gamma - np.diag(np.diag(Gamma))
    bp, al = beta.sum(1), alpha.sum(1)
    return [b.sum() - 1.0, b @ bp - (0.5 - g), b @ al ** 2 - 1.0 / 3.0, b @ (beta @ bp) - (1.0 / 6.0 - g + g * g)]


def test_the_stored_hairer_wanner_form_of_ros34pw2_meets_table_7_1():
    """The data as stored (alpha, Gamma, b, bhat), with the conditions of HW II Table 7.1 as printed
    there: an independent check of the tree machinery and of the transformation."""
    T = I.ROS34PW2._replace(**{f: np.array(getattr(I.ROS34PW2, f)) for f in ("alpha", "Gamma", "b", "bhat")})
    assert np.all(np.diag(T.Gamma) == T.gamma)
    assert max(abs(r) for r in hw_table_7_1(T.alpha, T.Gamma, T.b)) <= 4 * TOL
    assert max(abs(r) for r in hw_table_7_1(T.alpha, T.Gamma, T.bhat)[:2]) <= 4 * TOL
    assert max(abs(r) for r in hw_table_7_1(T.alpha, T.Gamma, T.bhat)[2:]) > 1e-3
    # W-method of order 2 for the embedded method (HW II (7.31)-type: sum b_j gamma_j = 0 with the diagonal)
    assert abs(T.bhat @ T.Gamma.sum(1)) <= 4 * TOL and abs(T.b @ T.Gamma.sum(1)) <= 4 * TOL
    # stiffly accurate: b is the last row of beta (alpha + Gamma), and the last stage's argument is y + sum k
    assert np.allclose(T.b, (T.alpha + T.Gamma)[-1], rtol=0, atol=TOL) and T.alpha[-1].sum() == 1.0


def ros34pw2_table(tab: I.RosenbrockTableau) -> Table:
    return from_python(I.transform(tab))


def ros34pw2_fails(tab: I.RosenbrockTableau) -> bool:
    """Some condition the unchanged ROS34PW2 meets fails (order, embedded order, dense order, as W-method)."""
    t = ros34pw2_table(tab)
    emb = t.m - t.e
    checks = [residuals(t, t.m, 3, True), residuals(t, emb, 2, True)]
    checks += [residuals(t, t.dense(th), 3, False, th) for th in THETAS]
    checks += [residuals(t, t.dense(th), 2, True, th) for th in THETAS]
    return any(failing(r) for r in checks)


def test_a_change_at_the_12th_digit_of_any_ros34pw2_coefficient_is_caught():
    """Each nonzero stored coefficient (alpha, Gamma, b, bhat, binterp, gamma) changed by 1e-11
    relative (its 12th significant digit) breaks a condition the stored tableau meets."""
    T = I.ROS34PW2
    assert not ros34pw2_fails(T)
    missed = []
    for field in ("alpha", "Gamma", "b", "bhat", "binterp"):
        arr = np.array(getattr(T, field))
        for idx in zip(*np.nonzero(arr)):
            for sign in (1.0, -1.0):
                changed = arr.copy()
                changed[idx] *= 1.0 + sign * 1e-11
                if not ros34pw2_fails(T._replace(**{field: changed.tolist()})):
                    missed.append((field, idx, sign))
    assert ros34pw2_fails(T._replace(gamma=T.gamma * (1.0 + 1e-11)))
    assert not missed, missed
