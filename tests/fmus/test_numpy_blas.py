"""The numpy an FMU carries has our BLAS in place of OpenBLAS and a stand-in for numpy.linalg's LAPACK
(harness/build/numpy_blas.py, fmu_src/native/numpy/numpy_blas.c).

* each of the 22 routines, called through ctypes, against numpy (this environment's, on OpenBLAS) on
  both orders, every transposition, increments of 1, 2 and -1, alpha and beta of 0 (C is not read when
  beta is 0: NaN there stays out), both triangles of syrk;
* the FMU's numpy (the built SpurDifferential.fmu's resources/python/numpy.zip), imported in a fresh
  interpreter of this Python (the runtime's 3.X): products of every kind equal this numpy's to
  rounding, numpy.linalg raises naming the cause, and numpy.libs holds our library and nothing OpenBLAS
  needed.
"""
from __future__ import annotations

import ctypes as C
import json
import subprocess
import sys
import zipfile

import numpy as np
import pytest

from harness.build import numpy_blas

_i = C.c_int64
ROW, COL = 101, 102
NOTRANS, TRANS, CONJTRANS = 111, 112, 113
UPPER, LOWER = 121, 122
TYPES = {"s": (np.float32, 2e-5), "d": (np.float64, 1e-13), "c": (np.complex64, 2e-5), "z": (np.complex128, 1e-13)}


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    from harness.build.fmu import c_compiler
    return C.CDLL(str(numpy_blas.compile_blas(tmp_path_factory.mktemp("blas") / "libnb.so", False, c_compiler())))


def _rand(shape, dtype, rng):
    a = rng.standard_normal(shape)
    if np.issubdtype(dtype, np.complexfloating):
        a = a + 1j * rng.standard_normal(shape)
    return np.ascontiguousarray(a.astype(dtype))


def _logical(buf, n, inc):
    """The n elements a routine reads at increment ``inc`` from ``buf`` (negative: from the end backwards)."""
    v = buf[::abs(inc)][:n]
    return v if inc > 0 else v[::-1]


def _ptr(a):
    return C.c_void_p(a.ctypes.data)


def _scalar(t, dtype, v):
    """alpha/beta as the routine takes them: by value (real) or through a pointer (complex)."""
    if t in "sd":
        return (C.c_float if t == "s" else C.c_double)(v)
    box = np.array([v], dtype=dtype)
    return box, _ptr(box)


def _arg(t, s):
    return s if t in "sd" else s[1]


def _routine(lib, t, name, seed):
    """(dtype, tolerance, random generator, the routine ``name`` of type ``t``) for a test."""
    dtype, tol = TYPES[t]
    return dtype, tol, np.random.default_rng(seed), getattr(lib, f"scipy_cblas_{t}{name}64_")


def _close(got, want, tol):
    scale = max(1.0, float(np.max(np.abs(want)))) if want.size else 1.0
    assert np.max(np.abs(got - want), initial=0.0) <= tol * scale * 10, (got, want)


def _op(a, trans):
    return a if trans == NOTRANS else (a.T if trans == TRANS else a.conj().T)


def _stored(a, order):
    """a as the routine reads it in ``order`` (a contiguous array) and its leading dimension."""
    return (np.ascontiguousarray(a), a.shape[1]) if order == ROW else (np.asfortranarray(a), a.shape[0])


@pytest.mark.parametrize("t", list(TYPES))
@pytest.mark.parametrize("order", [ROW, COL])
def test_gemm_every_transposition(lib, t, order):
    dtype, tol, rng, f = _routine(lib, t, "gemm", 1)
    for ta in (NOTRANS, TRANS, CONJTRANS):
        for tb in (NOTRANS, TRANS, CONJTRANS):
            for alpha, beta in ((1.0, 0.0), (0.7, -1.3), (0.0, 2.0)):
                m, n, k = 3, 4, 5
                A = _rand((m, k) if ta == NOTRANS else (k, m), dtype, rng)
                B = _rand((k, n) if tb == NOTRANS else (n, k), dtype, rng)
                C0 = _rand((m, n), dtype, rng)
                want = alpha * (_op(A, ta) @ _op(B, tb)) + beta * C0
                As, lda = _stored(A, order)
                Bs, ldb = _stored(B, order)
                Cs, ldc = _stored(C0.copy(), order)
                if beta == 0.0:
                    Cs[...] = np.nan          # not read when beta is 0
                al, be = _scalar(t, dtype, alpha), _scalar(t, dtype, beta)
                f(order, ta, tb, _i(m), _i(n), _i(k), _arg(t, al), _ptr(As), _i(lda), _ptr(Bs), _i(ldb),
                  _arg(t, be), _ptr(Cs), _i(ldc))
                _close(np.asarray(Cs), want, tol)


@pytest.mark.parametrize("t", list(TYPES))
@pytest.mark.parametrize("order", [ROW, COL])
def test_gemv_with_increments(lib, t, order):
    dtype, tol, rng, f = _routine(lib, t, "gemv", 2)
    m, n = 4, 3
    A = _rand((m, n), dtype, rng)
    As, lda = _stored(A, order)
    for trans in (NOTRANS, TRANS, CONJTRANS):
        lx, ly = (n, m) if trans == NOTRANS else (m, n)
        for incx, incy in ((1, 1), (2, 3), (-1, 2), (1, -2)):
            for alpha, beta in ((1.0, 0.0), (-0.5, 0.25)):
                xs = _rand(lx * abs(incx), dtype, rng)
                ys = _rand(ly * abs(incy), dtype, rng)
                x, y0 = _logical(xs, lx, incx), _logical(ys, ly, incy).copy()
                want = alpha * (_op(A, trans) @ x) + beta * y0
                if beta == 0.0:
                    ys[::abs(incy)] = np.nan
                al, be = _scalar(t, dtype, alpha), _scalar(t, dtype, beta)
                f(order, trans, _i(m), _i(n), _arg(t, al), _ptr(As), _i(lda), _ptr(xs), _i(incx), _arg(t, be),
                  _ptr(ys), _i(incy))
                _close(_logical(ys, ly, incy), want, tol)


@pytest.mark.parametrize("t", list(TYPES))
def test_dot_and_axpy(lib, t):
    dtype, tol = TYPES[t]
    rng = np.random.default_rng(3)
    n = 7
    for incx, incy in ((1, 1), (2, 1), (-1, 3)):
        xs, ys = _rand(n * abs(incx), dtype, rng), _rand(n * abs(incy), dtype, rng)
        x, y = _logical(xs, n, incx), _logical(ys, n, incy).copy()
        if t in "sd":
            f = getattr(lib, f"scipy_cblas_{t}dot64_")
            f.restype = C.c_float if t == "s" else C.c_double
            _close(np.array(f(_i(n), _ptr(xs), _i(incx), _ptr(ys), _i(incy))), np.array(np.sum(x * y)), tol)
        else:
            for kind, want in (("u", np.sum(x * y)), ("c", np.vdot(x, y))):
                out = np.zeros(1, dtype)
                getattr(lib, f"scipy_cblas_{t}dot{kind}_sub64_")(_i(n), _ptr(xs), _i(incx), _ptr(ys), _i(incy),
                                                                  _ptr(out))
                _close(out, np.array([want]), tol)
        alpha = 0.75 if t in "sd" else 0.75 - 0.5j
        want = y + alpha * x
        al = _scalar(t, dtype, alpha)
        getattr(lib, f"scipy_cblas_{t}axpy64_")(_i(n), _arg(t, al), _ptr(xs), _i(incx), _ptr(ys), _i(incy))
        _close(_logical(ys, n, incy), want, tol)


@pytest.mark.parametrize("t", list(TYPES))
@pytest.mark.parametrize("order", [ROW, COL])
def test_syrk_writes_only_its_triangle(lib, t, order):
    dtype, tol, rng, f = _routine(lib, t, "syrk", 4)
    n, k = 4, 3
    for trans in (NOTRANS, TRANS):
        A = _rand((n, k) if trans == NOTRANS else (k, n), dtype, rng)
        full = A @ A.T if trans == NOTRANS else A.T @ A          # no conjugation: the symmetric update
        for uplo in (UPPER, LOWER):
            for alpha, beta in ((1.0, 0.0), (2.0, 0.5)):
                C0 = _rand((n, n), dtype, rng)
                As, lda = _stored(A, order)
                Cs, ldc = _stored(C0.copy(), order)
                al, be = _scalar(t, dtype, alpha), _scalar(t, dtype, beta)
                f(order, uplo, trans, _i(n), _i(k), _arg(t, al), _ptr(As), _i(lda), _arg(t, be), _ptr(Cs), _i(ldc))
                tri = np.triu(np.ones((n, n), bool)) if uplo == UPPER else np.tril(np.ones((n, n), bool))
                got = np.asarray(Cs)
                _close(got[tri], (alpha * full + beta * C0)[tri], tol)
                assert np.array_equal(got[~tri], C0[~tri]), "syrk wrote outside its triangle"


# run in the FMU's numpy: products of every kind (pickled as lists of [real, imag]) and the linalg error
_FMU_RUN = r"""
import json, sys
if sys.argv[1] != "-":                       # the FMU's numpy; "-": this environment's
    sys.path[:0] = [sys.argv[1]]
import numpy as np
assert sys.argv[1] == "-" or np.__file__.startswith(sys.argv[1]), np.__file__
rng = [0.1 * ((7 * i) % 13 - 6) for i in range(400)]
out = {}
for dt in ("f4", "f8", "c8", "c16"):
    def m(r, c, off):
        a = np.array(rng[off:off + r * c]).reshape(r, c)
        return (a + 1j * np.array(rng[off + 50:off + 50 + r * c]).reshape(r, c)).astype(dt) if dt[0] == "c" else a.astype(dt)
    A, B, v = m(6, 5, 0), m(5, 4, 100), m(5, 1, 200)[:, 0]
    res = {"AB": A @ B, "AtA": A.T @ A, "AAt": A @ A.T, "Av": A @ v, "vA": v @ A.T, "dot": np.dot(v, v),
           "vdot": np.vdot(v, v), "inner": np.inner(A, A), "BtAt": B.T @ A.T, "F": np.asfortranarray(A) @ B,
           "strided": A[::2, ::2] @ B[::2, :]}
    out[dt] = {k: np.stack([np.real(r), np.imag(r)]).tolist() for k, r in res.items()}
try:
    np.linalg.inv(np.eye(3))
    out["linalg"] = "no error"
except RuntimeError as e:
    out["linalg"] = str(e)
print(json.dumps(out))
"""


def test_the_fmus_numpy_multiplies_as_openblas_and_refuses_linalg(differential_fmu, tmp_path):
    with zipfile.ZipFile(differential_fmu) as fmu:
        inner = fmu.read("resources/python/numpy.zip")
    (tmp_path / "numpy.zip").write_bytes(inner)
    site = tmp_path / "site"
    with zipfile.ZipFile(tmp_path / "numpy.zip") as z:
        z.extractall(site)
        libs = [n for n in z.namelist() if n.startswith("numpy.libs/")]
        size = {i.filename: i.file_size for i in z.infolist()}
    for p in site.rglob("*"):
        if p.suffix == ".so" or ".so." in p.name:
            p.chmod(0o755)
    assert len(libs) == 1 and libs[0].split("/")[1].startswith(numpy_blas.BLAS_PREFIX), libs
    assert size[libs[0]] < 200_000, f"{libs[0]}: {size[libs[0]]} bytes (OpenBLAS is 25 MB; ours about 30 kB)"
    assert not [n for n in size if n.startswith("numpy/linalg/") and n.endswith(".so")]
    r = subprocess.run([sys.executable, "-I", "-c", _FMU_RUN, str(site)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    got = json.loads(r.stdout)
    assert "numpy.linalg is not carried" in got["linalg"] and "inv" in got["linalg"], got["linalg"]
    ref = json.loads(subprocess.run([sys.executable, "-I", "-c", _FMU_RUN, "-"], capture_output=True, text=True,
                                    timeout=120, check=True).stdout)
    assert ref["linalg"] == "no error"       # this environment's numpy has LAPACK: the reference is OpenBLAS
    for dt, tol in (("f4", 2e-5), ("f8", 1e-13), ("c8", 2e-5), ("c16", 1e-13)):
        for k, want in ref[dt].items():
            w, g = np.array(want), np.array(got[dt][k])
            assert w.shape == g.shape, (dt, k)
            assert np.max(np.abs(w - g)) <= tol * max(1.0, np.max(np.abs(w))), (dt, k, w, g)
