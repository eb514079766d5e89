"""The three numerical solvers the physics needs, in plain Python (floats, lists and :mod:`math`; no
numpy), so that the FMUs run without scipy or numpy, and the linear solves of their Newton steps.

* :func:`find_root`: a root of a scalar function in a bracket ``[a, b]`` with a sign change, by
  Brent's method (bisection safeguarding secant and inverse quadratic interpolation; R. P. Brent,
  "Algorithms for Minimization without Derivatives", 1973, ch. 4). Same arguments and stopping
  rule as ``scipy.optimize.brentq``: it returns ``x`` once the bracket around the root is shorter
  than ``2 (xtol + rtol |x|)`` (so ``|x - root| <= xtol + rtol |x|``), or ``f(x) == 0`` exactly.
  Used for the inverse involute (:mod:`spurdiff.gears.geometry`), the form radius
  (:mod:`spurdiff.gears.generating`) and the Magic Formula's peak and inverse (:mod:`spurdiff.vehicle.tyre`).
* :func:`minimize_bounded`: a minimum of a scalar function on ``[lo, hi]`` by Brent's bounded
  method (golden section with parabolic steps; Brent, ch. 5), as
  ``scipy.optimize.minimize_scalar(method="bounded")``: stops when ``x`` is within
  ``2 tol - (b - a) / 2`` of the midpoint of the current interval ``[a, b]``, with
  ``tol = 1.483e-8 |x| + xatol / 3`` (``sqrt(2.2e-16)``, scipy's constant). The first term
  usually dominates: the location is found to about 1.5e-8 relative, the minimum value to
  rounding (a smooth minimum is flat). Used for the tool's depth over the rolling angle
  (:mod:`spurdiff.gears.generating`).
* :func:`solve_system`: a root of a small nonlinear system ``F(x) = 0`` by Newton's method with a
  forward-difference Jacobian (or a given one) and a backtracking line search on ``|F|``; for the
  consistent start of the mesh model (2 or 3 unknowns, :mod:`spurdiff.differential.mesh.stickslip`). It stops
  with success when a full Newton step is at most ``xtol |x|`` (Euclidean norms; the relative-step
  test of ``scipy.optimize.fsolve``, there on the Jacobian-scaled norm and the trust radius), when
  ``F(x) == 0``, or when the residual cannot be lowered any more after it fell to ``1e-10`` of its
  start (rounding level).
  It never raises for a numerical failure: it returns the best point with ``success = False`` and
  a message (singular or non-finite Jacobian, non-finite ``F``, no decrease, ``maxiter``).
* :func:`solve_2x2`: ``A x = b`` for a 2 x 2 ``A`` by Cramer's rule, in a fixed order of
  operations (the compiled kernels write it out the same way, so the results agree bit for bit);
  for the Newton steps of the break-away (:mod:`spurdiff.differential.locking`) and the rigid
  level's slip (:mod:`spurdiff.differential.rigid`).
* :func:`lu_factor` / :func:`lu_solve` (LU with partial pivoting), :func:`gj_inverse` (Gauss-Jordan) and
  :func:`mat_mul`: small dense systems on plain floats (lists of rows) in a fixed order of operations,
  the compiled kernels' operation for operation (the mesh integrator's W solves, the mass matrix's
  inverse, the tableaux; :func:`solve_system`'s Newton steps). No LAPACK: an FMU carries no numpy, and a
  LAPACK call costs more in overhead than an 8 x 8 solve.

:func:`find_root` raises :class:`SolverError`, naming the function, for a bracket without a sign
change, a non-finite function value, or no convergence in ``maxiter`` iterations;
:func:`minimize_bounded` for a non-finite value. Bad arguments (tolerances, bounds) raise
``ValueError``.
"""
from __future__ import annotations

import math
import sys

from spurdiff.attrpath import record


EPS = sys.float_info.epsilon     # numpy's finfo(float).eps
_SQRT_EPS = math.sqrt(EPS)
_GOLDEN = 0.5 * (3.0 - math.sqrt(5.0))  # the golden section's smaller part, 0.381966...
_REL_TOL_MIN = math.sqrt(2.2e-16)       # minimize_bounded's relative resolution in x (1.483e-8; the
                                        # value scipy's bounded method uses, so results agree)


def solve_2x2(a11: float, a12: float, a21: float, a22: float, b1: float, b2: float) -> tuple[float, float]:
    """(x1, x2) with ``[[a11, a12], [a21, a22]] x = (b1, b2)`` by Cramer's rule (det = a11 a22 - a12 a21;
    a singular matrix gives ZeroDivisionError, a non-finite one non-finite x; so does a regular one
    whose determinant underflows, entries below about 1e-154)."""
    det = a11 * a22 - a12 * a21
    return (b1 * a22 - a12 * b2) / det, (a11 * b2 - a21 * b1) / det


# Linear algebra on plain floats (lists of rows), in a fixed order of operations: the compiled kernels
# do the same operations in the same order (mesh_kernel.c: lu, lu_solve, gj_inverse), so the two agree
# bit for bit, and no BLAS or LAPACK is needed (an FMU carries neither).

def _pivot_row(A: list, j: int) -> int:
    """Partial pivoting: the row ``p >= j`` with the largest ``|A[p][j]|``, the first of equal ones
    (the kernel's pivot search, the same comparisons)."""
    p, amax = j, abs(A[j][j])
    for i in range(j + 1, len(A)):
        a = abs(A[i][j])
        if a > amax:
            p, amax = i, a
    return p


def lu_factor(A: list) -> tuple:
    """LU factorization with partial pivoting of the rows ``A`` (a list of lists, changed in
    place): (A holding L below the diagonal (unit diagonal) and U, the pivot rows), or (None, None)
    for an exactly singular matrix. Plain floats in a fixed order of operations, the compiled
    kernel's ``lu`` operation for operation (so the two agree bit for bit; a LAPACK call costs
    more in call overhead than the about 170 operations of an 8x8)."""
    N = len(A)
    piv = [0] * N
    for j in range(N):
        p = piv[j] = _pivot_row(A, j)
        if A[p][j] == 0.0:
            return None, None
        if p != j:
            A[j], A[p] = A[p], A[j]
        Aj = A[j]
        inv = 1.0 / Aj[j]
        for i in range(j + 1, N):
            Ai = A[i]
            lij = Ai[j] * inv
            Ai[j] = lij
            if lij != 0.0:
                for k in range(j + 1, N):
                    Ai[k] -= lij * Aj[k]
    return A, piv


def lu_solve(A: list, piv: list, b: list) -> list:
    """x with (P L U) x = b from :func:`lu_factor` (the kernel's ``lu_solve``, the same order)."""
    N = len(A)
    x = list(b)
    for j in range(N):
        p = piv[j]
        if p != j:
            x[j], x[p] = x[p], x[j]
    for i in range(1, N):
        Ai = A[i]
        s = x[i]
        for k in range(i):
            s -= Ai[k] * x[k]
        x[i] = s
    for i in range(N - 1, -1, -1):
        Ai = A[i]
        s = x[i]
        for k in range(i + 1, N):
            s -= Ai[k] * x[k]
        x[i] = s / Ai[i]
    return x


def gj_inverse(A: list) -> list | None:
    """The inverse of the square matrix ``A`` (rows, changed in place) by Gauss-Jordan elimination
    with partial pivoting, or None for an exactly singular one (the kernel's ``gj_inverse``, the
    same order)."""
    m = len(A)
    X = [[1.0 if i == j else 0.0 for j in range(m)] for i in range(m)]
    for j in range(m):
        p = _pivot_row(A, j)
        if A[p][j] == 0.0:
            return None
        if p != j:
            A[j], A[p] = A[p], A[j]
            X[j], X[p] = X[p], X[j]
        Aj, Xj = A[j], X[j]
        inv = 1.0 / Aj[j]
        for k in range(j + 1, m):
            Aj[k] *= inv
        for k in range(m):
            Xj[k] *= inv
        for i in range(m):
            if i == j:
                continue
            Ai, Xi = A[i], X[i]
            lij = Ai[j]
            if lij != 0.0:
                for k in range(j + 1, m):
                    Ai[k] -= lij * Aj[k]
                for k in range(m):
                    Xi[k] -= lij * Xj[k]
    return X


def mat_mul(A: list, B: list) -> list:
    """The product of the matrices ``A`` (m x k) and ``B`` (k x n), rows of plain floats, each entry summed
    in the order of k."""
    k = len(B)
    out = []
    for row in A:
        if len(row) != k:
            raise ValueError(f"a {len(A)} x {len(row)} matrix times a {k} x {len(B[0]) if B else 0} one")
        r = []
        for j in range(len(B[0]) if B else 0):
            acc = row[0] * B[0][j] if k else 0.0
            for q in range(1, k):
                acc += row[q] * B[q][j]
            r.append(acc)
        out.append(r)
    return out


class SolverError(ArithmeticError):
    """A solver could not do its job (no sign change, a non-finite value, no convergence); the
    message names the function it was given and the numbers."""


def _name(f) -> str:
    return getattr(f, "__qualname__", None) or getattr(f, "__name__", None) or repr(f)


def _finite_value(f, x: float, args: tuple) -> float:
    v = float(f(x, *args))
    if not math.isfinite(v):
        raise SolverError(f"{_name(f)}({x!r}) = {v!r}: the function must be finite on the interval")
    return v


def find_root(f, a: float, b: float, args: tuple = (), xtol: float = 2e-12, rtol: float = 4.0 * EPS,
              maxiter: int = 100) -> float:
    """Root of ``f`` in ``[a, b]`` (``f(a)`` and ``f(b)`` of opposite signs) by Brent's method.

    Returns ``x`` with ``|x - root| <= xtol + rtol |x|`` (an endpoint exactly if ``f`` is zero
    there). ``rtol`` must be at least ``4 eps`` (a smaller one cannot be met in floating point).
    Raises :class:`SolverError` when ``f(a)`` and ``f(b)`` have the same sign, ``f`` is not finite
    at a point it is evaluated at, or ``maxiter`` iterations do not converge.
    """
    if not xtol > 0.0:
        raise ValueError(f"xtol = {xtol!r} is invalid: allowed > 0")
    if not rtol >= 4.0 * EPS:
        raise ValueError(f"rtol = {rtol!r} is invalid: allowed >= 4 eps = {4.0 * EPS:.3g}")
    if int(maxiter) < 1:
        raise ValueError(f"maxiter = {maxiter!r} is invalid: allowed >= 1")
    a, b = float(a), float(b)
    fa, fb = _finite_value(f, a, args), _finite_value(f, b, args)
    if fa == 0.0:
        return a
    if fb == 0.0:
        return b
    if (fa > 0.0) == (fb > 0.0):
        raise SolverError(f"{_name(f)} has no sign change on [{a!r}, {b!r}]: f = {fa!r}, {fb!r}")
    # x: the current best estimate; xp, fp: the previous one; xc, fc: the contrapoint (f(xc) of the
    # other sign, so the root lies between x and xc); d, e: the last step and the one before it
    xp, fp, x, fx = a, fa, b, fb
    xc, fc = xp, fp
    d = e = x - xp
    for _ in range(int(maxiter)):
        if (fp > 0.0) != (fx > 0.0):    # the sign changed between xp and x: xp is the contrapoint
            xc, fc = xp, fp
            d = e = x - xp
        if abs(fc) < abs(fx):           # keep the smaller |f| as the estimate
            xp, fp = x, fx
            x, fx = xc, fc
            xc, fc = xp, fp
        tol = 0.5 * (xtol + rtol * abs(x))
        half = 0.5 * (xc - x)           # bisection step
        if fx == 0.0 or abs(half) < tol:
            return x
        step = half
        if abs(e) > tol and abs(fx) < abs(fp):
            if xp == xc:                # two points: secant
                trial = -fx * (x - xp) / (fx - fp)
            else:                       # three points: inverse quadratic interpolation
                sp = (fp - fx) / (xp - x)
                sc = (fc - fx) / (xc - x)
                den = sc * sp * (fc - fp)
                # (an underflowed denominator: no interpolation, bisect; NaN compares false below)
                trial = -fx * (fc * sc - fp * sp) / den if den != 0.0 else math.inf
            # accept the interpolation if it stays well inside the bracket and shrinks fast enough
            if 2.0 * abs(trial) < min(abs(e), 3.0 * abs(half) - tol):
                e, d = d, trial
                step = trial
            else:
                e = d = half
        else:
            e = d = half
        xp, fp = x, fx
        x += step if abs(step) > tol else math.copysign(tol, half)
        fx = _finite_value(f, x, args)
    raise SolverError(f"{_name(f)}: no root found in {int(maxiter)} iterations on [{a!r}, {b!r}] "
                      f"(last x = {x!r}, f = {fx!r}, bracket half width {abs(0.5 * (xc - x))!r})")


@record(frozen=True)
class Minimum:
    """Result of :func:`minimize_bounded`: the point, the value there, function evaluations,
    whether the tolerance was met (``False``: ``maxiter`` evaluations reached) and why it stopped."""

    x: float
    fun: float
    nfev: int
    success: bool
    message: str


def minimize_bounded(f, lo: float, hi: float, args: tuple = (), xatol: float = 1e-5,
                     maxiter: int = 500) -> Minimum:
    """Local minimum of ``f`` on ``[lo, hi]`` by Brent's bounded method (golden section and
    parabolic interpolation; the interior of the interval is searched, the ends are not evaluated).

    Stops when ``x`` is within ``2 tol - (b - a)/2`` of the midpoint of the interval ``[a, b]``
    still bracketing the minimum, ``tol = sqrt(2.2e-16) |x| + xatol / 3``, or after ``maxiter``
    function evaluations (``success = False``). Raises :class:`SolverError` if ``f`` is not finite
    at a point it is evaluated at.
    """
    lo, hi = float(lo), float(hi)
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"bounds = ({lo!r}, {hi!r}) are invalid: allowed finite lo < hi")
    if not xatol > 0.0:
        raise ValueError(f"xatol = {xatol!r} is invalid: allowed > 0")
    if int(maxiter) < 1:
        raise ValueError(f"maxiter = {maxiter!r} is invalid: allowed >= 1")
    a, b = lo, hi
    # x: the best point so far; w: the second best; v: the previous value of w
    x = w = v = a + _GOLDEN * (b - a)
    fx = fw = fv = _finite_value(f, x, args)
    nfev = 1
    d = e = 0.0                 # the last step and the one before the last
    success = True
    while True:
        mid = 0.5 * (a + b)
        tol = _REL_TOL_MIN * abs(x) + xatol / 3.0
        tol2 = 2.0 * tol
        if abs(x - mid) <= tol2 - 0.5 * (b - a):
            break
        if nfev >= int(maxiter):
            success = False
            break
        parabolic = False
        if abs(e) > tol:
            # parabola through (x, fx), (w, fw), (v, fv): its vertex is at x + p / q
            r = (x - w) * (fx - fv)
            q = (x - v) * (fx - fw)
            p = (x - v) * q - (x - w) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            q = abs(q)
            e_old, e = e, d
            # accept it if it is less than half the step before the last and inside (a, b)
            if abs(p) < abs(0.5 * q * e_old) and q * (a - x) < p < q * (b - x):
                parabolic = True
                d = p / q
                u = x + d
                if u - a < tol2 or b - u < tol2:     # not closer than 2 tol to an end
                    d = tol if mid >= x else -tol
        if not parabolic:
            e = (a - x) if x >= mid else (b - x)
            d = _GOLDEN * e
        # never evaluate closer than tol to x
        u = x + (d if abs(d) >= tol else (tol if d >= 0.0 else -tol))
        fu = _finite_value(f, u, args)
        nfev += 1
        if fu <= fx:
            if u >= x:
                a = x
            else:
                b = x
            v, fv, w, fw, x, fx = w, fw, x, fx, u, fu
        else:
            if u < x:
                a = u
            else:
                b = u
            if fu <= fw or w == x:
                v, fv, w, fw = w, fw, u, fu
            elif fu <= fv or v == x or v == w:
                v, fv = u, fu
    message = ("x within 2 tol - (b - a)/2 of the interval's midpoint" if success
               else f"maxiter = {int(maxiter)} function evaluations reached")
    return Minimum(x, fx, nfev, success, message)


@record(frozen=True)
class SystemSolution:
    """Result of :func:`solve_system`: the best point found, ``F`` there (lists of floats), whether a
    convergence test was met and which (or why it failed), Newton iterations and function evaluations."""

    x: list[float]
    fun: list[float]
    success: bool
    message: str
    nit: int
    nfev: int


def _floats(v) -> list[float]:
    """The numbers of the sequence ``v`` (a list, a tuple, a 1-D array) as a list of floats."""
    return [float(a) for a in v]


def _all_finite(v) -> bool:
    return all(math.isfinite(a) for a in v)


def _norm(v) -> float:
    """Euclidean norm without underflow or overflow of the squares (math.hypot)."""
    return math.hypot(*(float(a) for a in v))


def _jacobian_fd(f, x: list[float], fx: list[float], args: tuple, scale: list[float]) -> list[list[float]]:
    """Forward-difference Jacobian (rows), step ``sqrt(eps) max(|x_j|, scale_j)`` (``sqrt(eps)`` where
    that is zero or lost)."""
    m = len(fx)
    J = [[0.0] * len(x) for _ in range(m)]
    for j in range(len(x)):
        xh = list(x)
        xh[j] = x[j] + _SQRT_EPS * max(abs(x[j]), scale[j])
        if xh[j] == x[j]:        # x_j == 0 (and no scale) or subnormal: an absolute step
            xh[j] = x[j] + _SQRT_EPS
        h = xh[j] - x[j]
        fh = _floats(f(xh, *args))
        if len(fh) != m:
            raise ValueError(f"{_name(f)} returns {len(fh)} values at x = {xh}, {m} at x = {x}: "
                             "allowed as many values as unknowns")
        for i in range(m):
            J[i][j] = (fh[i] - fx[i]) / h
    return J


def _square(J, n: int, name: str) -> list[list[float]]:
    """The ``n x n`` matrix ``J`` (rows; or a flat sequence of ``n * n`` numbers, row after row) as
    rows of floats."""
    rows = list(J)
    if len(rows) == n * n and not any(hasattr(a, "__len__") for a in rows):
        return [[float(a) for a in rows[i * n:(i + 1) * n]] for i in range(n)]
    if len(rows) != n or any(len(row) != n for row in rows):
        raise ValueError(f"the Jacobian of {name} is not {n} x {n} (nor {n * n} numbers)")
    return [_floats(row) for row in rows]


def solve_system(f, x0, args: tuple = (), xtol: float = 1.49012e-8, maxiter: int = 100,
                 jac=None) -> SystemSolution:
    """Root of ``F(x) = 0`` (``f(x, *args)`` returns ``n`` values for ``n`` unknowns) by Newton's
    method with a backtracking (Armijo) line search on the Euclidean norm of ``F``.

    ``x0``: a sequence of ``n`` numbers; ``f`` is called with a list of floats and may return any
    sequence of numbers. ``jac(x, *args)``, if given, returns the ``n x n`` Jacobian (rows, or the
    ``n * n`` numbers row after row); else forward differences, the step in ``x_j`` being
    ``sqrt(eps)`` times the largest ``|x_j|`` of the iterates so far, ``x0`` included (a component
    that converges to zero keeps a step on its own scale).
    Success: a full Newton step ``|dx| <= xtol |x|`` (the step is taken if it does not raise
    ``|F|``), or ``|dx| <= xtol |s|`` with ``s`` the largest ``|x_j|`` of the iterates once ``|F|``
    fell below ``1e-10`` of its value at ``x0`` and ``|x| <= 1e-10 |s|`` (a root at zero, where the
    relative test never holds and Newton would otherwise creep into denormals), ``F(x) == 0``, or
    ``|F|`` cannot be lowered any more (halving the step 40 times) after it fell below ``1e-10`` of
    its value at ``x0`` (rounding level). Otherwise ``success = False`` with the reason; ``x`` is
    then the point with the smallest ``|F|`` found (``x0`` if ``F(x0)`` is not finite). ``x`` and
    ``fun`` of the result are lists of floats. It does not raise for a numerical failure.
    """
    if not xtol > 0.0:
        raise ValueError(f"xtol = {xtol!r} is invalid: allowed > 0")
    if int(maxiter) < 1:
        raise ValueError(f"maxiter = {maxiter!r} is invalid: allowed >= 1")
    x = _floats(x0)
    n = len(x)
    fx = _floats(f(x, *args))
    nfev = 1
    name = _name(f)
    if len(fx) != n:
        raise ValueError(f"{name} returns {len(fx)} values for {n} unknowns: "
                         "allowed as many values as unknowns")

    def values(xn: list[float]) -> list[float]:
        fn = _floats(f(xn, *args))
        if len(fn) != n:
            raise ValueError(f"{name} returns {len(fn)} values for {n} unknowns at x = {xn}: "
                             "allowed as many values as unknowns")
        return fn

    def result(ok: bool, message: str, nit: int) -> SystemSolution:
        return SystemSolution(x, fx, ok, message, nit, nfev)

    if not _all_finite(x):
        raise ValueError(f"x0 = {x} is invalid: allowed finite values")
    if not _all_finite(fx):
        return result(False, f"{name}(x0) is not finite: {fx}", 0)
    fnorm = fnorm0 = _norm(fx)
    if fnorm == 0.0:
        return result(True, "F(x0) = 0", 0)
    scale = [abs(a) for a in x]
    for it in range(1, int(maxiter) + 1):
        if jac is None:
            J = _jacobian_fd(f, x, fx, args, scale)
            nfev += n
        else:
            J = _square(jac(x, *args), n, name)
        if not all(_all_finite(row) for row in J):
            return result(False, f"the Jacobian of {name} is not finite at x = {x}", it)
        LU, piv = lu_factor(J)
        dx = None if LU is None else lu_solve(LU, piv, [-a for a in fx])
        if dx is None or not _all_finite(dx):
            return result(False, f"the Jacobian of {name} is singular at x = {x}", it)
        step = _norm(dx)
        at_zero = (fnorm <= 1e-10 * fnorm0 and _norm(x) <= 1e-10 * _norm(scale)
                   and step <= xtol * _norm(scale))
        if step <= xtol * _norm(x) or at_zero:
            xn = [a + d for a, d in zip(x, dx)]
            fn = values(xn)
            nfev += 1
            if _all_finite(fn) and _norm(fn) <= fnorm:
                x, fx = xn, fn
            if step <= xtol * _norm(x):
                return result(True, f"Newton step <= xtol |x| (xtol = {xtol:g})", it)
            return result(True, f"Newton step <= xtol times the iterates' scale at |F| <= 1e-10 of "
                                f"its value at x0 (a root at zero; xtol = {xtol:g})", it)
        t = 1.0
        for _ in range(40):
            xn = [a + t * d for a, d in zip(x, dx)]
            fn = values(xn)
            nfev += 1
            if _all_finite(fn):
                nn = _norm(fn)
                if nn <= (1.0 - 1e-4 * t) * fnorm:
                    break
            t *= 0.5
        else:
            if fnorm <= 1e-10 * fnorm0:
                return result(True, f"|F| = {fnorm:.3g} cannot be lowered further (rounding level; "
                                    f"{fnorm0:.3g} at x0)", it)
            return result(False, f"{name}: |F| = {fnorm:.3g} does not decrease along the Newton step "
                                 f"at x = {x} (not a root; {fnorm0:.3g} at x0)", it)
        x, fx, fnorm = xn, fn, nn
        scale = [max(s, abs(a)) for s, a in zip(scale, x)]
        if fnorm == 0.0:
            return result(True, "F(x) = 0", it)
    return result(False, f"{name}: no convergence in maxiter = {int(maxiter)} Newton iterations "
                         f"(|F| = {fnorm:.3g} at x = {x}, {fnorm0:.3g} at x0)", int(maxiter))


__all__ = ["EPS", "SolverError", "find_root", "minimize_bounded", "Minimum", "solve_system", "SystemSolution",
           "lu_factor", "lu_solve", "gj_inverse", "mat_mul"]
