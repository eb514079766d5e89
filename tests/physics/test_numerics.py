"""Our solvers (spurdiff.numerics) against scipy's: Brent's root finder against ``brentq``, the
bounded minimiser against ``minimize_scalar(method="bounded")``, the Newton system solver against
``fsolve`` on the mesh model's consistent-start system, the 2 x 2 solve against numpy's; and the
package runs without scipy."""
from __future__ import annotations

import math
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st
from scipy.optimize import brentq, fsolve, minimize_scalar

from spurdiff.numerics import (EPS, SolverError, find_root, gj_inverse, lu_factor, lu_solve, mat_mul, minimize_bounded,
                               solve_2x2, solve_system)

TOLS = [(2e-12, 4 * EPS), (1e-15, 1e-15), (1e-6, 1e-9), (1e-3, 1e-3)]   # (xtol, rtol)


class Counted:
    """A function that counts its calls."""

    def __init__(self, f):
        self.f, self.n = f, 0
        self.__qualname__ = getattr(f, "__qualname__", "f")

    def __call__(self, x, *args):
        self.n += 1
        return self.f(x, *args)


def within(f, x: float, tol: float) -> bool:
    """The root of f lies within tol of x: f(x) == 0 or f changes sign over [x - tol, x + tol]."""
    fx = f(x)
    if fx == 0.0:
        return True
    lo, hi = f(x - tol), f(x + tol)
    return lo == 0.0 or hi == 0.0 or (lo > 0.0) != (hi > 0.0)


def _inv(a):
    return math.tan(a) - a


# (name, f, a, b): roots in the middle, near either end, of flat and of discontinuous functions
ROOT_CASES = [
    ("cubic", lambda x: x ** 3 - 2.0 * x - 5.0, 0.0, 3.0),
    ("cos", lambda x: math.cos(x) - x, 0.0, 1.0),
    ("involute 1e-2", lambda a: _inv(a) - 1e-2, 1e-9, math.radians(60.0)),
    ("involute 1e-18 (root near a)", lambda a: _inv(a) - 1e-18, 1e-9, math.radians(60.0)),
    ("involute near 60 deg (near b)", lambda a: _inv(a) - (_inv(math.radians(60.0)) - 1e-12), 1e-9,
     math.radians(60.0)),
    ("root 1e-13 from b", lambda x: x - (1.0 - 1e-13), 0.0, 1.0),
    ("root 1e-300 from a", lambda x: x - 1e-300, 0.0, 1.0),
    ("exp, root at -690.8", lambda x: math.exp(x) - 1e-300, -800.0, 1.0),
    ("tiny values", lambda x: 1e-300 * math.atan(x - 0.7), -1e3, 1e3),
    ("flat: (x - 0.3)^5", lambda x: (x - 0.3) ** 5, -1.0, 2.0),
    ("flat: x^3 / 1e12", lambda x: (x - 1e-10) ** 3 * 1e-12, 0.0, 1.0),
    ("step", lambda x: 1.0 if x > 0.5 else -1.0, 0.0, 1.0),
    ("magic formula inverse", lambda s: math.sin(1.9 * math.atan(10 * s - 0.97 * (10 * s - math.atan(10 * s))))
     - 0.7, 0.0, 0.1),
]


@pytest.mark.parametrize("xtol,rtol", TOLS)
@pytest.mark.parametrize("name,f,a,b", ROOT_CASES, ids=[c[0] for c in ROOT_CASES])
def test_root_meets_the_tolerance_asked_and_agrees_with_brentq(name, f, a, b, xtol, rtol):
    fc = Counted(f)
    x = find_root(fc, a, b, xtol=xtol, rtol=rtol, maxiter=500)
    assert a <= x <= b
    tol = xtol + rtol * abs(x)
    assert within(f, x, tol), (x, tol)
    ref, r = brentq(f, a, b, xtol=xtol, rtol=rtol, maxiter=500, full_output=True)
    assert abs(x - ref) <= 2.0 * tol, (x, ref)
    assert fc.n <= r.function_calls + 2, (fc.n, r.function_calls)   # Brent's speed, not bisection's


def test_endpoint_zeros_are_returned_exactly():
    assert find_root(lambda x: x - 1.0, 1.0, 5.0) == 1.0
    assert find_root(lambda x: x - 5.0, 1.0, 5.0) == 5.0
    assert find_root(lambda x: x * (x - 5.0), 0.0, 5.0) == 0.0
    # an interior exact zero stops the iteration there
    x = find_root(lambda x: x - 0.5, 0.0, 1.0)
    assert x == 0.5


def test_args_are_passed_and_the_bracket_may_be_reversed():
    x = find_root(lambda x, c, p: x ** p - c, 0.0, 2.0, args=(2.0, 2))
    assert abs(x - math.sqrt(2.0)) <= 2e-12 + 4 * EPS * x
    assert find_root(lambda x: x ** 2 - 2.0, 2.0, 0.0) == pytest.approx(math.sqrt(2.0), abs=1e-11)


@given(r=st.floats(-50.0, 50.0), p=st.floats(-10.0, 10.0), gap=st.floats(1e-3, 100.0),
       scale=st.floats(1e-8, 1e8), left=st.floats(1e-9, 30.0), right=st.floats(1e-9, 30.0),
       tols=st.sampled_from(TOLS))
def test_cubics_with_one_real_root(r, p, gap, scale, left, right, tols):
    """f = scale (x - r) (x^2 + p x + q), q > p^2/4: one real root r, anywhere in the bracket."""
    q = p * p / 4.0 + gap

    def f(x):
        return scale * (x - r) * (x * x + p * x + q)

    xtol, rtol = tols
    a, b = r - left, r + right
    assume(f(a) < 0.0 < f(b))     # (not when the bracket's ends rounded onto the root)
    x = find_root(f, a, b, xtol=xtol, rtol=rtol, maxiter=500)
    tol = xtol + rtol * abs(x)
    assert within(f, x, tol)
    assert abs(x - brentq(f, a, b, xtol=xtol, rtol=rtol, maxiter=500)) <= 2.0 * tol


@given(kind=st.sampled_from(["involute", "exp", "atan", "magic"]), c=st.floats(1e-12, 0.999),
       tols=st.sampled_from(TOLS))
def test_transcendental_roots(kind, c, tols):
    """The kinds of equation the physics solves: inverse involute, exponential, arctangent, Magic
    Formula inverse (each monotone on its bracket, the root set by c)."""
    hi60 = math.radians(60.0)
    f, a, b = {
        "involute": (lambda x: _inv(x) - c * _inv(hi60), 1e-9, hi60),
        "exp": (lambda x: math.expm1(x) - (1.0 / c - 1.0), 0.0, 30.0),
        "atan": (lambda x: math.atan(x) - c * math.pi / 2.0, 0.0, 1e13),
        "magic": (lambda s: math.sin(1.9 * math.atan(10 * s - 0.97 * (10 * s - math.atan(10 * s)))) - c,
                  0.0, 0.1615),
    }[kind]
    assume(f(a) < 0.0 < f(b))
    xtol, rtol = tols
    x = find_root(f, a, b, xtol=xtol, rtol=rtol, maxiter=500)
    tol = xtol + rtol * abs(x)
    assert within(f, x, tol)
    assert abs(x - brentq(f, a, b, xtol=xtol, rtol=rtol, maxiter=500)) <= 2.0 * tol


def test_no_sign_change_is_an_error_naming_the_function():
    def no_change(x):
        return x * x + 1.0

    with pytest.raises(SolverError, match=r"no_change has no sign change on \[-1.0, 1.0\]"):
        find_root(no_change, -1.0, 1.0)
    with pytest.raises(ValueError):
        brentq(no_change, -1.0, 1.0)     # scipy refuses it too


def test_non_finite_values_are_an_error_naming_the_function():
    def has_nan(x):
        return float("nan") if 0.4 < x < 0.6 else x - 0.5

    with pytest.raises(SolverError, match=r"has_nan\(.*\) = nan: the function must be finite"):
        find_root(has_nan, 0.0, 1.0)

    def inf_at_end(x):
        return math.inf if x == 1.0 else x - 0.5

    with pytest.raises(SolverError, match=r"inf_at_end\(1.0\) = inf"):
        find_root(inf_at_end, 0.0, 1.0)


def test_no_convergence_in_maxiter_is_an_error_as_in_scipy():
    def ninth(x):
        return x ** 9

    with pytest.raises(SolverError, match=r"ninth: no root found in 100 iterations"):
        find_root(ninth, -1.0, 2.0)
    with pytest.raises(RuntimeError):
        brentq(ninth, -1.0, 2.0)          # scipy gives up at the same count
    assert abs(find_root(ninth, -1.0, 2.0, maxiter=1000)) <= 2e-12


@pytest.mark.parametrize("kw", [{"xtol": 0.0}, {"xtol": -1.0}, {"rtol": EPS}, {"maxiter": 0}])
def test_invalid_tolerances_are_refused(kw):
    with pytest.raises(ValueError, match=next(iter(kw))):
        find_root(lambda x: x, -1.0, 1.0, **kw)


# ----------------------------------------------------------------------------- minimiser

def _min_tol(x, xatol):
    """The minimiser's resolution at x: 1.483e-8 |x| + xatol / 3."""
    return math.sqrt(2.2e-16) * abs(x) + xatol / 3.0


# (name, f, lo, hi, x* (the minimiser), f''(x*) (0: a kink or a bound, None: flat bottom))
MIN_CASES = [
    ("parabola", lambda x: (x - 0.3) ** 2, 0.0, 1.0, 0.3, 2.0),
    ("sin", math.sin, 0.0, 6.0, 1.5 * math.pi, 1.0),
    ("|x - c| (kink)", lambda x: abs(x - 0.1234567), -1.0, 2.0, 0.1234567, 0.0),
    ("cosh", lambda x: math.cosh(x - 1e-3), -1.0, 1.0, 1e-3, 1.0),
    ("quartic (flat bottom)", lambda x: (x - 1.0) ** 4, 0.0, 3.0, 1.0, None),
    ("double well, one in range", lambda x: (x * x - 1.0) ** 2, 0.0, 3.0, 1.0, 8.0),
    ("narrow gaussian well", lambda x: -math.exp(-((x - 0.31) / 1e-3) ** 2), 0.3, 0.32, 0.31, 2e6),
    ("minimum at the upper bound", lambda x: -x, 0.0, 1.0, 1.0, 0.0),
    ("minimum at the lower bound", lambda x: x, 0.0, 1.0, 0.0, 0.0),
    ("far from zero", lambda x: (x - 1234.5) ** 2, 1000.0, 2000.0, 1234.5, 2.0),
]


@pytest.mark.parametrize("xatol", [1e-5, 1e-14])
@pytest.mark.parametrize("name,f,lo,hi,xmin,curv", MIN_CASES, ids=[c[0] for c in MIN_CASES])
def test_minimum_against_the_bounded_method(name, f, lo, hi, xmin, curv, xatol):
    m = minimize_bounded(f, lo, hi, xatol=xatol)
    s = minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": xatol})
    assert m.success and lo < m.x < hi and m.fun == f(m.x)
    tol = _min_tol(m.x, xatol)
    fmin = f(xmin)
    # the value to rounding plus what a location error of 4 tol costs (kinks and bounds: slope 1)
    cost = 0.0 if curv is None else (4.0 * tol if curv == 0.0 else 0.5 * curv * (4.0 * tol) ** 2)
    assert m.fun - fmin <= 8 * EPS * max(1.0, abs(fmin)) + cost
    if curv is None:
        assert abs(m.x - xmin) <= 1e-3            # flat bottom: only the value is resolved
    else:
        # the location to a few resolutions, or to where f is flat to rounding: f(x*) + f'' dx^2 / 2
        flat = math.sqrt(8.0 * EPS * max(1.0, abs(fmin)) / curv) if curv else 0.0
        assert abs(m.x - xmin) <= 4.0 * tol + flat, (m.x, xmin, tol, flat)
    assert abs(m.x - s.x) <= 4.0 * tol, (m.x, s.x)
    assert m.fun <= s.fun + 1e-12 * max(1.0, abs(s.fun))
    assert m.nfev <= s.nfev + 2


def _generating_minimisations():
    """The minimisations form_radius does (spurdiff.gears.generating): the tool's depth over the rolling
    angle near each sampled peak, recorded while computing the form radius of undercut gears."""
    import spurdiff.gears.generating as g

    calls = []

    def record(f, lo, hi, **kw):
        calls.append((f, lo, hi, kw))
        return minimize_bounded(f, lo, hi, **kw)

    m, alpha = 0.003, math.radians(20.0)
    original = g.minimize_bounded
    g.minimize_bounded = record
    try:
        for z, x in ((13, -0.3), (9, 0.0), (7, -0.6), (11, -0.2)):
            g.form_radius.__wrapped__(z, x, m, alpha, 1.25, 0.38, m * (z + 2 + 2 * x) / 2)
    finally:
        g.minimize_bounded = original
    return calls


def test_minimiser_on_the_form_radius_depth_functions():
    calls = _generating_minimisations()
    assert len(calls) > 100
    worst_x = worst_f = 0.0
    for f, lo, hi, kw in calls:
        assert kw == {"xatol": 1e-14}
        ours = minimize_bounded(f, lo, hi, **kw)
        ref = minimize_scalar(f, bounds=(lo, hi), method="bounded", options=kw)
        assert ours.success
        tol = _min_tol(ours.x, 1e-14)
        assert abs(ours.x - ref.x) <= 4.0 * tol
        # the depth is what form_radius uses: equal to rounding (1e-12 of the module, m = 3 mm)
        assert abs(ours.fun - ref.fun) <= 1e-15
        worst_x, worst_f = max(worst_x, abs(ours.x - ref.x) / tol), max(worst_f, abs(ours.fun - ref.fun))
    print(f"{len(calls)} minimisations: max |dx| / tol = {worst_x:.3g}, max |d depth| = {worst_f:.3g} m")


def test_form_radius_with_our_solvers_matches_scipy():
    """form_radius (brentq + minimize_scalar before) with our solvers and with scipy's: equal to
    its own tolerance (1e-12 m = xtol) for undercut gears."""
    import spurdiff.gears.generating as g

    m, alpha = 0.003, math.radians(20.0)
    cases = ((13, -0.3), (9, 0.0), (7, -0.6), (11, -0.2), (15, -0.5))
    ours = [g.form_radius.__wrapped__(z, x, m, alpha, 1.25, 0.38, m * (z + 2 + 2 * x) / 2) for z, x in cases]

    def scipy_min(f, lo, hi, xatol):
        return minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": xatol})

    saved = g.find_root, g.minimize_bounded
    g.find_root, g.minimize_bounded = brentq, scipy_min
    try:
        ref = [g.form_radius.__wrapped__(z, x, m, alpha, 1.25, 0.38, m * (z + 2 + 2 * x) / 2) for z, x in cases]
    finally:
        g.find_root, g.minimize_bounded = saved
    for (r1, u1), (r2, u2) in zip(ours, ref):
        assert u1 == u2
        assert abs(r1 - r2) <= 2.0 * (1e-12 * m + 4 * EPS * r2), (r1, r2)


def test_minimiser_stops_at_maxiter_and_says_so():
    m = minimize_bounded(math.sin, 0.0, 6.0, maxiter=5)
    s = minimize_scalar(math.sin, bounds=(0.0, 6.0), method="bounded", options={"maxiter": 5})
    assert not m.success and "maxiter = 5" in m.message and m.nfev == 5
    assert not s.success and m.x == pytest.approx(s.x, abs=1e-12)


def test_minimiser_refuses_non_finite_values_and_bad_bounds():
    def nan_inside(x):
        return float("nan") if x > 0.3 else x

    with pytest.raises(SolverError, match=r"nan_inside\(.*\) = nan"):
        minimize_bounded(nan_inside, 0.0, 1.0)
    for lo, hi in ((1.0, 1.0), (2.0, 1.0), (0.0, math.inf), (math.nan, 1.0)):
        with pytest.raises(ValueError, match="bounds"):
            minimize_bounded(math.sin, lo, hi)
    with pytest.raises(ValueError, match="xatol"):
        minimize_bounded(math.sin, 0.0, 1.0, xatol=0.0)


# ----------------------------------------------------------------------------- system solver

def _stickslip_systems():
    """The consistent-start systems the mesh model solves (spurdiff.differential.mesh.stickslip.initial_forces),
    recorded while building mesh models: speed and torque drive (2 and 3 unknowns), stuck and
    slipping starts, loaded and unloaded, with and without pin friction and preload."""
    import itertools

    import spurdiff.differential.mesh.stickslip as ss
    from spurdiff.fmi import differential_fmu as d

    calls = []

    def record(f, x0, **kw):
        calls.append((f, list(x0), kw))
        return solve_system(f, x0, **kw)

    start = {v.name: v.start for v in d.VARIABLES}
    original = ss.solve_system
    ss.solve_system = record
    try:
        for drive, pin, wd, taus, pre in itertools.product(
                ("speed", "torque"), (True, False), (0.0, 0.5, -2.0),
                ((0.0, 0.0, 0.0), (2100.0, -1050.0, -1050.0), (2100.0, -1110.201, -989.799),
                 (500.0, -100.0, -400.0), (-800.0, 300.0, 500.0)), (0.0, 50.0)):
            values = dict(start, meshModel="compliant", carrierDrive=drive, pinFriction=pin, lockingPreload=pre,
                          **{"differential.w_start": wd, "carrier.tau": taus[0], "left.tau": taus[1],
                             "right.tau": taus[2], "carrier.w_ref": 1.389, "carrier.w_start": 1.389})
            d.build_model(values)
    finally:
        ss.solve_system = original
    return calls


# fsolve warns where it stops at rounding level without meeting its xtol (its answer is used)
FSOLVE_WARNINGS = [pytest.mark.filterwarnings("ignore:The iteration is not making good progress"),
                   pytest.mark.filterwarnings("ignore:xtol=.* is too small")]


@FSOLVE_WARNINGS[0]
@FSOLVE_WARNINGS[1]
def test_system_solver_on_the_stick_slip_systems_matches_fsolve():
    calls = _stickslip_systems()
    assert len(calls) >= 80 and {len(x0) for _, x0, _ in calls} == {2, 3}
    worst = 0.0
    for f, x0, kw in calls:
        assert kw == {"xtol": 1e-13}
        ours = solve_system(f, x0, **kw)
        assert ours.success, ours.message
        ref = fsolve(f, x0, xtol=1e-13)
        scale = float(np.max(np.abs(ref)))
        if scale < 1e-100:                    # the root is x = 0 (no load, no motion)
            # to the same relative accuracy as every other root (1e-12 of the problem's scale,
            # x0's), where Newton's relative step test cannot hold; the residual as below
            assert np.max(np.abs(ours.x)) <= 1e-12 * np.max(np.abs(x0)), (x0, ours.x)
            assert np.linalg.norm(ours.fun) <= 1e-11
            continue
        err = float(np.max(np.abs(ours.x - ref))) / scale
        worst = max(worst, err)
        assert err <= 1e-12, (x0, ours.x, ref)
        # the residual (N m) at rounding level of the terms (torques ~ 100 N m)
        assert np.linalg.norm(ours.fun) <= 1e-11
    print(f"{len(calls)} stick-slip systems: max |x - x_fsolve| / max|x_fsolve| = {worst:.3g}")


def _rosenbrock(x):
    return [10.0 * (x[1] - x[0] ** 2), 1.0 - x[0]]


def _powell_badly_scaled(x):
    return [1e4 * x[0] * x[1] - 1.0, math.exp(-x[0]) + math.exp(-x[1]) - 1.0001]


def _circle_line(x):
    return [x[0] ** 2 + x[1] ** 2 - 4.0, x[0] - 2.0 * x[1] + 0.5]


def _trig3(x):
    return [math.sin(x[0]) + x[1] ** 3 - 0.5, x[0] * x[2] - 1.0, x[1] + x[2] ** 2 - 2.0 * x[0] - 1.0]


@pytest.mark.parametrize("f,x0", [
    (_rosenbrock, [-1.2, 1.0]),
    (_powell_badly_scaled, [0.0, 1.0]),
    (_circle_line, [1.0, 1.0]),
    (_trig3, [1.0, 1.0, 1.0]),
    (lambda x: [x[0] + 2.0 * x[1] - 3.0, 3.0 * x[0] - x[1] + 1.0], [100.0, -50.0]),      # linear
    (lambda x: [x[0] + 2.0 * x[1], 3.0 * x[0] - x[1]], [1.0, 1.0]),                        # root 0
], ids=["rosenbrock", "powell-badly-scaled", "circle-line", "trig3", "linear", "root-at-zero"])
@FSOLVE_WARNINGS[0]
@FSOLVE_WARNINGS[1]
def test_system_solver_on_standard_systems(f, x0):
    ours = solve_system(f, x0, xtol=1e-12)
    assert ours.success, ours.message
    ref, info, ier, msg = fsolve(f, x0, xtol=1e-12, full_output=True)
    if ier == 1:
        scale = max(float(np.max(np.abs(ref))), 1e-300)
        assert float(np.max(np.abs(ours.x - ref))) <= 1e-10 * scale + 1e-300
    # a root in any case (scipy's or not): |F| at rounding level of its terms
    assert np.linalg.norm(f(ours.x)) <= 1e-12 * max(1.0, float(np.max(np.abs(ours.x)))) * 10


def test_system_solver_reports_failures():
    r = solve_system(lambda x: [x[0] ** 2 + 1.0, x[1]], [0.5, 0.5])          # no real root
    assert not r.success and len(r.x) == 2 and all(math.isfinite(v) for v in r.x)
    assert "not a root" in r.message or "singular" in r.message or "maxiter" in r.message
    r = solve_system(lambda x: [x[0] + x[1] - 1.0, 2.0 * x[0] + 2.0 * x[1]], [0.0, 0.0])  # singular
    assert not r.success and "singular" in r.message and "<lambda>" in r.message
    r = solve_system(lambda x: [math.nan, x[1]], [1.0, 2.0])                 # F(x0) not finite
    assert not r.success and "not finite" in r.message and list(r.x) == [1.0, 2.0]
    r = solve_system(_rosenbrock, [-1.2, 1.0], maxiter=1)
    assert not r.success and "maxiter = 1" in r.message and "_rosenbrock" in r.message
    with pytest.raises(ValueError, match="values for 2 unknowns"):
        solve_system(lambda x: [x[0]], [1.0, 2.0])
    with pytest.raises(ValueError, match="xtol"):
        solve_system(_rosenbrock, [1.0, 1.0], xtol=0.0)


def test_system_solver_uses_a_given_jacobian():
    def jac(x):
        return [[-20.0 * x[0], 10.0], [-1.0, 0.0]]

    ours = solve_system(_rosenbrock, [-1.2, 1.0], jac=jac, xtol=1e-14)
    assert ours.success and np.allclose(ours.x, [1.0, 1.0], rtol=0.0, atol=1e-13)


# ----------------------------------------------------------------------------- no scipy at run time

_NO_SCIPY = textwrap.dedent("""
    import importlib, pkgutil, sys

    blocked = []

    class BlockScipy:
        def find_spec(self, name, path=None, target=None):
            if name == "scipy" or name.startswith("scipy."):
                blocked.append(name)
                raise ImportError(f"scipy is blocked: {name}")
            return None

    sys.meta_path.insert(0, BlockScipy())
    import spurdiff
    names = [m.name for m in pkgutil.walk_packages(spurdiff.__path__, "spurdiff.")]
    for name in names:
        importlib.import_module(name)
    from spurdiff.fmi import differential_fmu, vehicle_fmu, wheel_fmu
    for iface, config in ((differential_fmu, {}), (differential_fmu, {"meshModel": "contact"}),
                          (differential_fmu, {"meshModel": "compliant", "carrierDrive": "torque",
                                              "differential.w_start": 0.5, "carrier.tau": 500.0}),
                          (wheel_fmu, {}), (vehicle_fmu, {})):
        values = {v.name: v.start for v in iface.VARIABLES}
        values.update(config)
        model = iface.build_model(values)
        model.do_step(0.0, 1e-3)
    # the undercut gear's form radius (brent root + bounded minimum) and the tyre's inverse
    from spurdiff.gears.generating import form_radius
    from spurdiff.vehicle.tyre import slip_for_force_ratio
    assert form_radius(13, -0.3, 0.003, 0.3490658503988659, 1.25, 0.38, 0.021)[1]
    assert slip_for_force_ratio(0.5, 10.0, 1.9, 0.97) > 0.0
    assert not blocked, blocked
    assert not [m for m in sys.modules if m == "scipy" or m.startswith("scipy.")]
    print(len(names), "modules")
""")


# entries of the physics' scale: Cramer's determinant a11 a22 - a12 a21 underflows to 0 for entries
# below about 1e-154 even when the matrix is well conditioned (hypothesis found [[0, 1.8e-227],
# [1.8e-227, 0]]): refused then as singular (ZeroDivisionError), as the inline Cramer solves it replaced
# did; the locking law's 2x2 systems have entries of the physics' scale
_ENTRY = st.floats(-1e3, 1e3).filter(lambda x: x == 0.0 or abs(x) > 1e-100)


@given(st.lists(_ENTRY, min_size=6, max_size=6))
def test_solve_2x2_solves_the_system(v):
    """solve_2x2 agrees with numpy's solve wherever the matrix is well conditioned, and a singular
    matrix is refused (ZeroDivisionError), not answered."""
    a11, a12, a21, a22, b1, b2 = v
    A = np.array([[a11, a12], [a21, a22]])
    assume(np.linalg.cond(A) < 1e6)
    x = solve_2x2(a11, a12, a21, a22, b1, b2)
    ref = np.linalg.solve(A, [b1, b2])
    scale = 1.0 + np.max(np.abs(ref))
    assert np.max(np.abs(np.array(x) - ref)) <= 1e-9 * scale


def test_solve_2x2_exact_and_singular():
    assert solve_2x2(2.0, 1.0, 1.0, 3.0, 5.0, 10.0) == (1.0, 3.0)
    with pytest.raises(ZeroDivisionError):
        solve_2x2(1.0, 2.0, 2.0, 4.0, 1.0, 1.0)


@given(st.integers(1, 10), st.integers(0, 2**32 - 1))
def test_small_dense_solves_agree_with_lapack(n, seed):
    """lu_factor/lu_solve and gj_inverse (which replaced numpy.linalg in the models: the FMUs' numpy
    has no LAPACK) agree with LAPACK on well-conditioned systems up to 10 x 10; mat_mul with numpy's
    product."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    assume(np.linalg.cond(A) < 1e6)
    b = rng.standard_normal(n)
    LU, piv = lu_factor(A.tolist())
    x = np.array(lu_solve(LU, piv, b.tolist()))
    ref = np.linalg.solve(A, b)
    assert np.max(np.abs(x - ref)) <= 1e-8 * (1.0 + np.max(np.abs(ref)))
    inv = np.array(gj_inverse(A.tolist()))
    assert np.max(np.abs(inv - np.linalg.inv(A))) <= 1e-8 * (1.0 + np.max(np.abs(inv)))
    B = rng.standard_normal((n, 3))
    assert np.max(np.abs(np.array(mat_mul(A.tolist(), B.tolist())) - A @ B)) <= 1e-12 * (1.0 + np.max(np.abs(A @ B)))


def test_small_dense_solves_refuse_a_singular_matrix_and_mat_mul_a_shape_mismatch():
    singular = [[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 1.0, 1.0]]
    assert lu_factor([r[:] for r in singular]) == (None, None)
    assert gj_inverse([r[:] for r in singular]) is None
    with pytest.raises(ValueError, match="3 x 2 matrix times a 3 x 1"):
        mat_mul([[1.0, 2.0]] * 3, [[1.0]] * 3)


def test_the_newton_solver_reports_a_singular_jacobian():
    r = solve_system(lambda x: [x[0] + x[1], 2.0 * x[0] + 2.0 * x[1] + 1.0], [1.0, 1.0])
    assert not r.success and "singular" in r.message


def test_the_package_runs_without_scipy():
    """Every module of spurdiff imports, and the three models build and step, with scipy made
    unimportable (the FMUs' run time carries numpy only); no module even tries to import it."""
    proc = subprocess.run([sys.executable, "-c", _NO_SCIPY], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert int(proc.stdout.split()[-2]) >= 40


# ----------------------------------------------------------------------------- no numpy in the solvers

_NO_NUMPY = textwrap.dedent("""
    import builtins, json, sys

    sys.modules['numpy'] = None           # any import of numpy fails
    tried = []
    _import = builtins.__import__

    def recording_import(name, *args, **kwargs):
        if name == 'numpy' or name.startswith('numpy.'):
            tried.append(name)            # (also an import whose ImportError is caught)
        return _import(name, *args, **kwargs)

    builtins.__import__ = recording_import
    from spurdiff import numerics
    from spurdiff.gears import generating
    generating._TABLE = {}                # no build-time table: the generation is simulated
    sol = numerics.solve_system(lambda x: [x[0] ** 2 + x[1] ** 2 - 4.0, x[0] - 2.0 * x[1] + 0.5], (1.0, 1.0),
                                xtol=1e-13)
    rF, undercut = generating.form_radius(13, -0.3, 0.003, 0.3490658503988659, 1.25, 0.38, 0.021)
    assert not tried, tried
    assert sys.modules['numpy'] is None
    print(json.dumps({"x": sol.x, "fun": sol.fun, "success": sol.success, "rF": rF, "undercut": undercut}))
""")


def test_the_solvers_and_the_form_radius_run_without_numpy(monkeypatch):
    """solve_system and the simulated generation of an undercut gear (spurdiff.gears.generating) in a
    fresh Python with numpy made unimportable: they never try to import it, and their results are
    those of this process (plain floats: the same with or without numpy around)."""
    import json

    import spurdiff.gears.generating as g

    proc = subprocess.run([sys.executable, "-c", _NO_NUMPY], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.splitlines()[-1])
    ref = solve_system(_circle_line, [1.0, 1.0], xtol=1e-13)
    assert out["success"] and ref.success
    assert out["x"] == ref.x and out["fun"] == ref.fun
    assert type(ref.x) is list and all(type(v) is float for v in ref.x + ref.fun)
    assert _circle_line(out["x"]) == pytest.approx([0.0, 0.0], abs=1e-14)
    monkeypatch.setattr(g, "_TABLE", {})
    assert (out["rF"], out["undercut"]) == g.form_radius.__wrapped__(13, -0.3, 0.003, 0.3490658503988659, 1.25,
                                                                     0.38, 0.021)
    assert out["undercut"] and 0.003 * 13 / 2 * math.cos(0.3490658503988659) < out["rF"] < 0.021
