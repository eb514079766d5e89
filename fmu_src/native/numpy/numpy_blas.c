/* The BLAS routines numpy's core calls, for the numpy an FMU carries (issue 44 item 1).
 *
 * numpy's wheels link their core (numpy/_core/_multiarray_umath) against OpenBLAS, shipped beside
 * it as numpy.libs/libscipy_openblas64_-<hash>.so (.dll on Windows): 25 MB on Linux, 20 MB on
 * Windows, with libgfortran and libquadmath, 8 of the 23.5 MB a host's unzip wrote for every
 * SpurDifferential FMU. The core calls 22 routines of it (matrix products, matrix-vector products,
 * dot products, axpy and the symmetric rank-k update, for float, double and their complex types:
 * `nm -D --undefined-only` on Linux, the import table on Windows) and the models' matrices are at most
 * 10 x 10. This library is those 22 routines, written from the reference BLAS's definitions
 * (netlib BLAS, the CBLAS interface of its appendix), under the names numpy's wheels use: ILP64
 * (64-bit integers), the `scipy_` prefix and the `64_` suffix. It is built into the FMU's numpy under
 * OpenBLAS's file name (harness/build/numpy_blas.py), so numpy loads it where it loaded OpenBLAS.
 * numpy.linalg (LAPACK) is not carried: its extension modules are replaced by stand-ins that say so.
 *
 * The arithmetic is the reference's, in the routines' own precision, sums in ascending index order
 * (no blocking, no threads: deterministic; tests/fmus/test_numpy_blas.py compares every routine with
 * numpy's OpenBLAS). As the reference says, C (y) is not read when beta is zero, and only the named
 * triangle of C is written by syrk.
 */
#include <complex.h>
#include <stdint.h>

#ifdef _WIN32
#define EXPORT __declspec(dllexport)
#else
#define EXPORT __attribute__((visibility("default")))
#endif

typedef int64_t blasint;
enum { RowMajor = 101, ColMajor = 102 };
enum { NoTrans = 111, Trans = 112, ConjTrans = 113, ConjNoTrans = 114 };
enum { Upper = 121, Lower = 122 };

typedef float complex cfloat;
typedef double complex cdouble;

#define NAME(x) scipy_cblas_##x##64_

/* The element (i, j) of a matrix given by its order and leading dimension: strides (rs, cs). */
static void strides(int order, blasint ld, blasint *rs, blasint *cs)
{
    if (order == RowMajor) { *rs = ld; *cs = 1; }
    else { *rs = 1; *cs = ld; }
}

/* The first element a vector of n elements at increment inc starts from (a negative increment runs
 * backwards from the end, as the reference does). */
#define START(p, n, inc) ((inc) < 0 ? (p) + (1 - (n)) * (inc) : (p))

#define REAL_CONJ(x) (x)
#define CPLX_CONJ_F(x) conjf(x)
#define CPLX_CONJ_D(x) conj(x)

/* dot: sum x_i y_i (real) */
#define DEF_DOT(T, name) \
    EXPORT T NAME(name)(blasint n, const T *x, blasint incx, const T *y, blasint incy) \
    { \
        T s = 0; \
        if (n <= 0) return s; \
        x = START(x, n, incx); y = START(y, n, incy); \
        for (blasint i = 0; i < n; i++) s += x[i * incx] * y[i * incy]; \
        return s; \
    }
DEF_DOT(float, sdot)
DEF_DOT(double, ddot)

/* dotu (x_i y_i) and dotc (conj(x_i) y_i), complex, the result through a pointer */
#define DEF_CDOT(T, name, CONJ) \
    EXPORT void NAME(name)(blasint n, const void *xv, blasint incx, const void *yv, blasint incy, void *ret) \
    { \
        const T *x = xv, *y = yv; \
        T s = 0; \
        if (n > 0) { \
            x = START(x, n, incx); y = START(y, n, incy); \
            for (blasint i = 0; i < n; i++) s += CONJ(x[i * incx]) * y[i * incy]; \
        } \
        *(T *)ret = s; \
    }
DEF_CDOT(cfloat, cdotu_sub, REAL_CONJ)
DEF_CDOT(cfloat, cdotc_sub, CPLX_CONJ_F)
DEF_CDOT(cdouble, zdotu_sub, REAL_CONJ)
DEF_CDOT(cdouble, zdotc_sub, CPLX_CONJ_D)

/* axpy: y += alpha x (complex alpha through a pointer) */
#define AXPY_BODY \
    if (n <= 0 || alpha == 0) return; \
    x = START(x, n, incx); y = START(y, n, incy); \
    for (blasint i = 0; i < n; i++) y[i * incy] += alpha * x[i * incx];
EXPORT void NAME(saxpy)(blasint n, float alpha, const float *x, blasint incx, float *y, blasint incy) { AXPY_BODY }
EXPORT void NAME(daxpy)(blasint n, double alpha, const double *x, blasint incx, double *y, blasint incy) { AXPY_BODY }
#define DEF_CAXPY(T, name) \
    EXPORT void NAME(name)(blasint n, const void *alphav, const void *xv, blasint incx, void *yv, blasint incy) \
    { \
        const T alpha = *(const T *)alphav, *x = xv; \
        T *y = yv; \
        AXPY_BODY \
    }
DEF_CAXPY(cfloat, caxpy)
DEF_CAXPY(cdouble, zaxpy)

/* A complex routine's alpha and beta, given through pointers */
#define CPLX_SCALARS(T) const T alpha = *(const T *)alphav, beta = *(const T *)betav

/* op(A)(i, j) for the transposition t of a matrix with strides (rs, cs) */
#define OPA(A, t, i, j, rs, cs, CONJ) \
    ((t) == NoTrans ? (A)[(i) * (rs) + (j) * (cs)] : (t) == Trans ? (A)[(j) * (rs) + (i) * (cs)] \
     : (t) == ConjTrans ? CONJ((A)[(j) * (rs) + (i) * (cs)]) : CONJ((A)[(i) * (rs) + (j) * (cs)]))

/* gemv: y = alpha op(A) x + beta y, A m x n in the given order */
#define GEMV_BODY(T, CONJ) \
    if (m <= 0 || n <= 0) return; \
    blasint rs, cs; \
    strides(order, lda, &rs, &cs); \
    int nt = trans == NoTrans || trans == ConjNoTrans; \
    blasint leny = nt ? m : n, lenx = nt ? n : m; \
    x = START(x, lenx, incx); y = START(y, leny, incy); \
    for (blasint i = 0; i < leny; i++) { \
        T s = 0; \
        if (alpha != 0) \
            for (blasint j = 0; j < lenx; j++) s += OPA(A, trans, i, j, rs, cs, CONJ) * x[j * incx]; \
        y[i * incy] = beta == 0 ? alpha * s : alpha * s + beta * y[i * incy]; \
    }
#define DEF_GEMV(T, name, CONJ) \
    EXPORT void NAME(name)(int order, int trans, blasint m, blasint n, T alpha, const T *A, blasint lda, \
                           const T *x, blasint incx, T beta, T *y, blasint incy) { GEMV_BODY(T, CONJ) }
#define DEF_CGEMV(T, name, CONJ) \
    EXPORT void NAME(name)(int order, int trans, blasint m, blasint n, const void *alphav, const void *Av, \
                           blasint lda, const void *xv, blasint incx, const void *betav, void *yv, blasint incy) \
    { \
        CPLX_SCALARS(T); \
        const T *A = Av, *x = xv; \
        T *y = yv; \
        GEMV_BODY(T, CONJ) \
    }
DEF_GEMV(float, sgemv, REAL_CONJ)
DEF_GEMV(double, dgemv, REAL_CONJ)
DEF_CGEMV(cfloat, cgemv, CPLX_CONJ_F)
DEF_CGEMV(cdouble, zgemv, CPLX_CONJ_D)

/* gemm: C = alpha op(A) op(B) + beta C, C m x n, op(A) m x k, op(B) k x n */
#define GEMM_BODY(T, CONJ) \
    if (m <= 0 || n <= 0) return; \
    blasint ra, ca, rb, cb, rc, cc; \
    strides(order, lda, &ra, &ca); strides(order, ldb, &rb, &cb); strides(order, ldc, &rc, &cc); \
    for (blasint i = 0; i < m; i++) \
        for (blasint j = 0; j < n; j++) { \
            T s = 0; \
            if (alpha != 0) \
                for (blasint l = 0; l < k; l++) s += OPA(A, ta, i, l, ra, ca, CONJ) * OPA(B, tb, l, j, rb, cb, CONJ); \
            T *c = C + i * rc + j * cc; \
            *c = beta == 0 ? alpha * s : alpha * s + beta * *c; \
        }
#define DEF_GEMM(T, name, CONJ) \
    EXPORT void NAME(name)(int order, int ta, int tb, blasint m, blasint n, blasint k, T alpha, const T *A, \
                           blasint lda, const T *B, blasint ldb, T beta, T *C, blasint ldc) { GEMM_BODY(T, CONJ) }
#define DEF_CGEMM(T, name, CONJ) \
    EXPORT void NAME(name)(int order, int ta, int tb, blasint m, blasint n, blasint k, const void *alphav, \
                           const void *Av, blasint lda, const void *Bv, blasint ldb, const void *betav, void *Cv, \
                           blasint ldc) \
    { \
        CPLX_SCALARS(T); \
        const T *A = Av, *B = Bv; \
        T *C = Cv; \
        GEMM_BODY(T, CONJ) \
    }
DEF_GEMM(float, sgemm, REAL_CONJ)
DEF_GEMM(double, dgemm, REAL_CONJ)
DEF_CGEMM(cfloat, cgemm, CPLX_CONJ_F)
DEF_CGEMM(cdouble, zgemm, CPLX_CONJ_D)

/* syrk: C = alpha A A^T + beta C (trans NoTrans, A n x k) or alpha A^T A (Trans, A k x n), only the
 * uplo triangle of the n x n C; no conjugation (the complex types' symmetric update) */
#define SYRK_BODY(T) \
    if (n <= 0) return; \
    blasint ra, ca, rc, cc; \
    strides(order, lda, &ra, &ca); strides(order, ldc, &rc, &cc); \
    int tt = trans == NoTrans ? NoTrans : Trans; \
    for (blasint i = 0; i < n; i++) \
        for (blasint j = uplo == Upper ? i : 0; j < (uplo == Upper ? n : i + 1); j++) { \
            T s = 0; \
            if (alpha != 0) \
                for (blasint l = 0; l < k; l++) s += OPA(A, tt, i, l, ra, ca, REAL_CONJ) * OPA(A, tt, j, l, ra, ca, REAL_CONJ); \
            T *c = C + i * rc + j * cc; \
            *c = beta == 0 ? alpha * s : alpha * s + beta * *c; \
        }
#define DEF_SYRK(T, name) \
    EXPORT void NAME(name)(int order, int uplo, int trans, blasint n, blasint k, T alpha, const T *A, blasint lda, \
                           T beta, T *C, blasint ldc) { SYRK_BODY(T) }
#define DEF_CSYRK(T, name) \
    EXPORT void NAME(name)(int order, int uplo, int trans, blasint n, blasint k, const void *alphav, const void *Av, \
                           blasint lda, const void *betav, void *Cv, blasint ldc) \
    { \
        CPLX_SCALARS(T); \
        const T *A = Av; \
        T *C = Cv; \
        SYRK_BODY(T) \
    }
DEF_SYRK(float, ssyrk)
DEF_SYRK(double, dsyrk)
DEF_CSYRK(cfloat, csyrk)
DEF_CSYRK(cdouble, zsyrk)
