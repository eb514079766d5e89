/*
 * Compiled kernel of the mesh levels (compliant, contact) of SpurDifferential: the model
 * evaluation (right-hand side, Jacobian, side values), the Rosenbrock step (ROS34PW2 or RODAS5P,
 * the tableau as data) with its error control,
 * and the whole internal stepping loop over one communication step (events, loss quadrature,
 * stick-slip, work accounting), so Python is entered once per communication step.
 *
 * A line-by-line transcription of the pure-Python reference, which stays the specification and the
 * fallback: fmu_src/spurdiff/differential/mesh/{forces,events,stickslip,stepper,integrator}.py (the comments
 * name the Python function each C function mirrors). Called through ctypes
 * (fmu_src/spurdiff/differential/mesh/kernel.py); the structures (mesh_kernel.h) are mirrored there field by
 * field. The model evaluation is in mesh_kernel_model.c; this file holds the method, the events,
 * stick-slip, the driver and the exported functions. Depends on libm only.
 *
 * Agreement with the reference: the same operations in the same order (sums in the order the
 * reference sums, no contraction into fused multiply-adds: build with -ffp-contract=off), the same
 * libm, and the same solve of W (integrator.split_factor / split_solve with the carrier's speed imposed:
 * the Schur complement on the velocities, inverted by Gauss-Jordan with partial pivoting; else the
 * partial-pivoting LU, integrator.lu_factor / lu_solve; a LAPACK call cost more in call overhead than
 * the whole solve of an 8x8): the states agree bit for bit
 * (tests/physics/mesh/test_mesh_kernel.py).
 */
#include "mesh_kernel.h"

int mk_abi(void) { return MK_ABI; }
int64_t mk_sizeof_params(void) { return (int64_t)sizeof(MkParams); }
int64_t mk_sizeof_state(void) { return (int64_t)sizeof(MkState); }

/* ------------------------------------------------------------ the method (spurdiff.differential.mesh.integrator) */

typedef struct {
    double J1[NMAX * NMAX], W[NMAX * NMAX], Q[4][NMAX];
    double U[SMAX][NMAX], ynew[NMAX], err[NMAX], ym[NMAX], yq[NMAX], Ys[NMAX], F[NMAX], rhs[NMAX];
    double f0[NMAX], f1[NMAX], fs[NMAX];
} Work;

/* integrator.lu_factor / lu_solve: the general solve of W (N = 10: the carrier free) */
static int lu(double *A, int N, int *piv) {
    for (int j = 0; j < N; j++) {
        int p = j;
        double amax = fabs(A[j * N + j]);
        for (int i = j + 1; i < N; i++)
            if (fabs(A[i * N + j]) > amax) { amax = fabs(A[i * N + j]); p = i; }
        piv[j] = p;
        if (A[p * N + j] == 0.0) return 0;
        if (p != j)
            for (int k = 0; k < N; k++) { double t = A[j * N + k]; A[j * N + k] = A[p * N + k]; A[p * N + k] = t; }
        double inv = 1.0 / A[j * N + j];
        for (int i = j + 1; i < N; i++) {
            double l = A[i * N + j] *= inv;
            if (l != 0.0)
                for (int k = j + 1; k < N; k++) A[i * N + k] -= l * A[j * N + k];
        }
    }
    return 1;
}

static void lu_solve(const double *A, int N, const int *piv, const double *b, double *x) {
    for (int i = 0; i < N; i++) x[i] = b[i];
    for (int j = 0; j < N; j++)
        if (piv[j] != j) { double t = x[j]; x[j] = x[piv[j]]; x[piv[j]] = t; }
    for (int i = 1; i < N; i++) {
        double s = x[i];
        for (int k = 0; k < i; k++) s -= A[i * N + k] * x[k];
        x[i] = s;
    }
    for (int i = N - 1; i >= 0; i--) {
        double s = x[i];
        for (int k = i + 1; k < N; k++) s -= A[i * N + k] * x[k];
        x[i] = s / A[i * N + i];
    }
}

/* the factorization of W (row-major) into LU (integrator.lu_factor); 0: exactly singular */
static int factor(const double *W, double *LU, int *piv, int N) {
    memcpy(LU, W, sizeof(double) * N * N);
    return lu(LU, N, piv);
}

/* the positions and velocities of the state with the carrier's speed imposed (layout.split; N = 8) */
static const int POS[MSPLIT] = {PSI, DA, DB, D12}, VEL[MSPLIT] = {VA, VB, W1, W2};

/* integrator.gj_inverse: X = A^-1 (m x m, row-major, A changed) by Gauss-Jordan with partial pivoting; 0: singular */
static int gj_inverse(double *A, int m, double *X) {
    for (int i = 0; i < m; i++)
        for (int j = 0; j < m; j++) X[i * m + j] = i == j ? 1.0 : 0.0;
    for (int j = 0; j < m; j++) {
        int p = j;
        double amax = fabs(A[j * m + j]);
        for (int i = j + 1; i < m; i++)
            if (fabs(A[i * m + j]) > amax) { amax = fabs(A[i * m + j]); p = i; }
        if (A[p * m + j] == 0.0) return 0;
        if (p != j)
            for (int k = 0; k < m; k++) {
                double t = A[j * m + k]; A[j * m + k] = A[p * m + k]; A[p * m + k] = t;
                t = X[j * m + k]; X[j * m + k] = X[p * m + k]; X[p * m + k] = t;
            }
        double *Aj = A + j * m, *Xj = X + j * m, inv = 1.0 / Aj[j];
        for (int k = j + 1; k < m; k++) Aj[k] *= inv;
        for (int k = 0; k < m; k++) Xj[k] *= inv;
        for (int i = 0; i < m; i++) {
            if (i == j) continue;
            double *Ai = A + i * m, *Xi = X + i * m, l = Ai[j];
            if (l != 0.0) {
                for (int k = j + 1; k < m; k++) Ai[k] -= l * Aj[k];
                for (int k = 0; k < m; k++) Xi[k] -= l * Xj[k];
            }
        }
    }
    return 1;
}

/* integrator.split_factor: the factors of W = I/e - Jf (e = gamma h) into F (S^-1, J_vp, B; see MkState.LU) */
static int split_factor(const double *Jf, int N, double e, double *F) {
    const int m = MSPLIT, mm = MSPLIT * MSPLIT;
    double *Si = F, *Jvp = F + mm, *B = F + 2 * mm, Sm[MSPLIT * MSPLIT], d = 1.0 / e;
    for (int i = 0; i < m; i++)
        for (int k = 0; k < m; k++) {
            Jvp[i * m + k] = Jf[VEL[i] * N + POS[k]];
            B[i * m + k] = Jf[POS[i] * N + VEL[k]];
        }
    for (int i = 0; i < m; i++)
        for (int j = 0; j < m; j++) {
            double jb = Jvp[i * m] * B[j];
            for (int k = 1; k < m; k++) jb += Jvp[i * m + k] * B[k * m + j];
            Sm[i * m + j] = ((i == j ? d : 0.0) - Jf[VEL[i] * N + VEL[j]]) - e * jb;
        }
    return gj_inverse(Sm, m, Si);
}

/* integrator.split_solve: x with W x = r from split_factor's factors F */
static void split_solve(const double *F, int N, double e, const double *r, double *x) {
    const int m = MSPLIT, mm = MSPLIT * MSPLIT;
    const double *Si = F, *Jvp = F + mm, *B = F + 2 * mm;
    double t[MSPLIT], xv[MSPLIT];
    for (int i = 0; i < m; i++) {
        const double *a = Jvp + i * m;
        double s = a[0] * r[POS[0]];
        for (int k = 1; k < m; k++) s += a[k] * r[POS[k]];
        t[i] = r[VEL[i]] + e * s;
    }
    for (int i = 0; i < m; i++) {
        const double *a = Si + i * m;
        double s = a[0] * t[0];
        for (int k = 1; k < m; k++) s += a[k] * t[k];
        xv[i] = s;
    }
    for (int i = 0; i < m; i++) {
        const double *a = B + i * m;
        double s = a[0] * xv[0];
        for (int k = 1; k < m; k++) s += a[k] * xv[k];
        x[POS[i]] = e * (r[POS[i]] + s);
        x[VEL[i]] = xv[i];
    }
}

/* out = sum_k c[k] U[k] in the order of k (integrator._combine) */
static void combine(const double *c, int nk, double U[SMAX][NMAX], int N, double *out) {
    for (int j = 0; j < N; j++) {
        double s = U[0][j] * c[0];
        for (int k = 1; k < nk; k++) s += U[k][j] * c[k];
        out[j] = s;
    }
}

/* ya = y + sum_k a[k] U[k], yc = sum_k c[k] U[k] (k < nk): two combines in one pass, each element summed in
 * the order of k as combine sums it (so the same bits) */
static void stage_sums(const double *a, const double *c, int nk, double U[SMAX][NMAX], int N, const double *y,
                       double *ya, double *yc) {
    for (int j = 0; j < N; j++) {
        double sa = U[0][j] * a[0], sc = U[0][j] * c[0];
        for (int k = 1; k < nk; k++) {
            sa += U[k][j] * a[k];
            sc += U[k][j] * c[k];
        }
        ya[j] = sa + y[j];
        yc[j] = sc;
    }
}

/* RosenbrockW.step: with f0 = f(y) and S->Jf an approximation of J(y) (a W-method; else J(y)); W factored
 * unless S->LU is for Jf and h (S->lu_h); fills ynew, err, U. 0: singular / not finite */
static int ros_step(const MkParams *P, MkState *S, const double *y, const double *f0, double h, Work *wk) {
    const int N = (int)P->N, sp = N == 8;     /* the split (layout.split), else the general LU */
    int *piv = (int *)S->piv;
    double e = P->gamma * h;
    if (h != S->lu_h) {
        S->lu_h = 0.0;
        S->n_lu++;
        if (sp) {
            if (!split_factor(S->Jf, N, e, S->LU)) return 0;
        } else {
            double d = 1.0 / e;
            for (int i = 0; i < N; i++)
                for (int j = 0; j < N; j++) wk->W[i * N + j] = (i == j ? d : 0.0) - S->Jf[i * N + j];
            if (!factor(wk->W, S->LU, piv, N)) return 0;
        }
        S->lu_h = h;
    }
    if (sp) split_solve(S->LU, N, e, f0, wk->U[0]);
    else lu_solve(S->LU, N, piv, f0, wk->U[0]);
    double ih = 1.0 / h;
    const int ns = (int)P->stages;
    for (int i = 1; i < ns; i++) {
        stage_sums(P->a[i], P->cc[i], i, wk->U, N, y, wk->Ys, wk->rhs);
        mk_eval(P, S, wk->Ys, wk->F, NULL, NULL);
        for (int j = 0; j < N; j++) wk->rhs[j] = wk->rhs[j] * ih + wk->F[j];
        if (sp) split_solve(S->LU, N, e, wk->rhs, wk->U[i]);
        else lu_solve(S->LU, N, piv, wk->rhs, wk->U[i]);
    }
    stage_sums(P->m, P->ew, ns, wk->U, N, y, wk->ynew, wk->err);   /* the solution and the error estimate */
    int finite = 1;
    for (int j = 0; j < N; j++)
        if (!isfinite(wk->ynew[j])) finite = 0;
    return finite;
}

static void midpoint(const MkParams *P, const double *y, Work *wk) {
    combine(P->dmid, (int)P->stages, wk->U, (int)P->N, wk->ym);
    for (int j = 0; j < (int)P->N; j++) wk->ym[j] += y[j];
}

/* RosenbrockW.dense_at: the dense output with the weights w into wk->yq */
static const double *dense_at(const MkParams *P, const double *w, const double *y, Work *wk) {
    combine(w, (int)P->stages, wk->U, (int)P->N, wk->yq);
    for (int j = 0; j < (int)P->N; j++) wk->yq[j] += y[j];
    return wk->yq;
}

static double error_norm(const MkParams *P, const double *err, const double *y, const double *yn) {
    const int N = (int)P->N;
    double ss = 0.0;
    for (int i = 0; i < N; i++) {
        double sc = fabs(y[i]), b = fabs(yn[i]);
        if (b > sc) sc = b;
        double q = err[i] / (sc * P->rtol + P->atol[i]);
        ss += q * q;
    }
    return sqrt(ss / N);
}

static double new_step_size(const MkParams *P, double h, double err, int rejected) {
    double fac = err <= 0.0 ? 5.0 : 0.9 * pow(err, P->err_exp);
    double hi = rejected ? 1.0 : 5.0;
    if (fac < 0.2) fac = 0.2;
    if (fac > hi) fac = hi;
    return h * fac;
}

/* ------------------------------------------------------------ events (spurdiff.differential.mesh.events) */
#define JAC_AGE_MAX 10     /* stepper.JAC_AGE_MAX */
#define H_KEEP 1.2         /* stepper.H_KEEP */
#define STICK_RTOL 1e-9
#define PHASE_RTOL 1e-8    /* events.PHASE_RTOL */
#define PHASE_PAST 1e-9    /* events.PHASE_PAST */

static void contact_flags(const MkParams *P, const double *y, int64_t *fl) {
    for (int i = 0; i < 3; i++) {
        double d = y[P->md[i].d];
        fl[2 * i] = d > 0.0;
        fl[2 * i + 1] = -(d + P->md[i].jn) > 0.0;
    }
}

static double crossing(double g0, double gm, double g1, int closed) {
    if (closed) {
        if (g0 > 0.0 && gm <= 0.0) return 0.5 * g0 / (g0 - gm);
        if (g0 > 0.0 && g1 <= 0.0) return gm != g1 ? 0.5 + 0.5 * gm / (gm - g1) : 1.0;
        return 1.0;
    }
    int p0 = g0 > 0.0, pm = gm > 0.0, p1 = g1 > 0.0;
    if (pm != p0) return 0.5 * g0 / (g0 - gm);
    if (p1 != pm) return 0.5 + 0.5 * gm / (gm - g1);
    return 1.0;
}

static double min2(double a, double b) { return b < a ? b : a; }

static double state_events(const MkParams *P, const MkState *S, const double *y0, const double *ym, const double *y1) {
    double theta = 1.0;
    if (P->bl || P->contact) {
        for (int i = 0; i < 3; i++) {
            const MkMesh *m = &P->md[i];
            double a = y0[m->d], c = ym[m->d], b = y1[m->d];
            theta = min2(theta, min2(crossing(a, c, b, 0), crossing(-(a + m->jn), -(c + m->jn), -(b + m->jn), 0)));
        }
    }
    if (P->pin) {
        for (int i = 0; i < 2; i++) {
            int idx = i ? W2 : W1;
            double s = (double)S->s[i];
            if (S->s[i] != 0) theta = min2(theta, crossing(s * y0[idx], s * ym[idx], s * y1[idx], 1));
        }
    }
    return theta;
}

static void margins(const MkParams *P, const MkState *S, const double *sv, double *g) {
    for (int i = 0; i < 2; i++)
        g[i] = (P->pin && S->s[i] == 0) ? sv[SV_CAP1 + i] - fabs(sv[SV_M1 + i]) : INFINITY;
}

static double breakaway(const MkParams *P, const MkState *S, const double *sv0, const double *svm, const double *sv1, double theta) {
    double tolc = STICK_RTOL * (sv1[SV_CAP1] + sv1[SV_CAP2]), g0[2], gm[2], g1[2];
    margins(P, S, sv0, g0);
    margins(P, S, svm, gm);
    margins(P, S, sv1, g1);
    for (int i = 0; i < 2; i++)
        if (g0[i] != INFINITY && g0[i] >= 0.0)
            theta = min2(theta, crossing(g0[i] + tolc, gm[i] + tolc, g1[i] + tolc, 1));
    return theta;
}

static double phase_limit(const MkParams *P, const MkState *S, const double *y) {
    double best = INFINITY;
    double rates[3] = {P->rbA * y[VA], P->rbB * y[VB], P->rb1 * y[W1]};
    double om[3][2] = {{y[VA], y[W1]}, {y[VB], y[W2]}, {y[W1], y[W2]}};
    int unilateral = P->bl || P->contact, have_us = 0;
    double us[3] = {0.0, 0.0, 0.0};
    for (int mi = 0; mi < 3; mi++) {
        const MkMesh *m = &P->md[mi];
        double d = y[m->d], sgn;
        if (unilateral) {
            if (d > 0.0) sgn = -1.0;
            else if (-(d + m->jn) > 0.0) sgn = 1.0;
            else continue;
        } else {
            sgn = d >= 0.0 ? -1.0 : 1.0;
        }
        double rate = sgn * m->sigma * rates[mi] / m->pb;
        if (rate == 0.0) continue;
        if (!have_us) {
            double psiB, th1, th2;
            mk_relative_angles(S, P, y, &psiB, &th1, &th2);
            us[0] = P->rbA * y[PSI]; us[1] = P->rbB * psiB; us[2] = P->rb1 * th1;
            have_us = 1;
        }
        double z = (sgn < 0.0 ? m->xi0 : m->xi0c) + sgn * m->sigma * us[mi] / m->pb;
        double xi = mk_pymod(z, 1.0);
        double ar = fabs(rate);
        double bounds[3] = {0.0, m->eps - 1.0, m->xip};
        int nb = P->flank ? 3 : 2;
        for (int j = 0; j < nb; j++) {
            double dist = rate > 0.0 ? mk_pymod(bounds[j] - xi, 1.0) : mk_pymod(xi - bounds[j], 1.0);
            if (dist == 0.0) dist = 1.0;
            double dt = dist / ar;
            dt += PHASE_PAST * dt + 4e-16 * (fabs(z) + 1.0) / ar;
            if (dt < 1e-12) dt = 1e-12;
            if (j == 2) {
                double grad = fabs(om[mi][0] - om[mi][1]) * ar * m->pb;
                if (grad > 0.0) dt += 1.5 * P->v_s / grad;
            }
            if (dt < best) best = dt;
        }
    }
    return best;
}

/* events.leave: the fraction of the step where x leaves [lo, hi) */
static double leave(double x0, double xm, double x1, double lo, double hi) {
    if (xm < lo) return 0.5 * (x0 - lo) / (x0 - xm);
    if (xm >= hi) return 0.5 * (hi - x0) / (xm - x0);
    if (x1 < lo) return 0.5 + 0.5 * (xm - lo) / (xm - x1);
    if (x1 >= hi) return 0.5 + 0.5 * (hi - xm) / (x1 - xm);
    return 1.0;
}

static void rolls(const MkParams *P, const MkState *S, const double *y, double *u) {
    double psiB, th1, th2;
    mk_relative_angles(S, P, y, &psiB, &th1, &th2);
    u[0] = P->rbA * y[PSI]; u[1] = P->rbB * psiB; u[2] = P->rb1 * th1;
}

/* events.phase_events: where a loaded flank leaves the interval of its held phase mode */
static double phase_events(const MkParams *P, const MkState *S, const double *y0, const double *ym, const double *y1) {
    double u0[3], um[3], u1[3], theta = 1.0;
    int unilateral = P->bl || P->contact;
    rolls(P, S, y0, u0);
    rolls(P, S, ym, um);
    rolls(P, S, y1, u1);
    for (int i = 0; i < 3; i++) {
        const MkMesh *m = &P->md[i];
        double a = y0[m->d], b = y1[m->d], e1 = m->eps - 1.0;
        int drive, coast;
        if (unilateral) {
            drive = a > 0.0 || b > 0.0;
            coast = -(a + m->jn) > 0.0 || -(b + m->jn) > 0.0;
        } else {
            drive = a >= 0.0 || b >= 0.0;
            coast = a < 0.0 || b < 0.0;
        }
        if (drive) {
            double k = S->pk[2 * i], lo = S->pnc[2 * i] == 2 ? 0.0 : e1, hi = S->pnc[2 * i] == 2 ? e1 : 1.0;
            double x0 = (m->xi0 - m->sigma * u0[i] / m->pb) - k;
            double xm = (m->xi0 - m->sigma * um[i] / m->pb) - k;
            double x1 = (m->xi0 - m->sigma * u1[i] / m->pb) - k;
            theta = min2(theta, leave(x0, xm, x1, lo, hi));
        }
        if (coast) {
            double k = S->pk[2 * i + 1], lo = S->pnc[2 * i + 1] == 2 ? 0.0 : e1, hi = S->pnc[2 * i + 1] == 2 ? e1 : 1.0;
            double x0 = (m->xi0c + m->sigma * u0[i] / m->pb) - k;
            double xm = (m->xi0c + m->sigma * um[i] / m->pb) - k;
            double x1 = (m->xi0c + m->sigma * u1[i] / m->pb) - k;
            theta = min2(theta, leave(x0, xm, x1, lo, hi));
        }
    }
    return theta;
}

/* ------------------------------------------------------------ stick-slip (spurdiff.differential.mesh.stickslip) */
static int64_t settle_modes(const MkParams *P, MkState *S, const double *y, const int *zeroed, int nz, Work *wk, double *sv) {
    int64_t before[2] = {S->s[0], S->s[1]};
    for (int k = 0; k < nz; k++) S->s[zeroed[k]] = 0;
    for (int it = 0; it < 4; it++) {
        mk_eval(P, S, y, wk->f0, S->Jf, sv);
        S->n_jac++;
        S->jac_age = 0;
        S->lu_h = 0.0;
        int changed = 0;
        for (int i = 0; i < 2; i++) {
            if (S->s[i] == 0) {
                double Mreq = sv[SV_M1 + i], cap = sv[SV_CAP1 + i];
                if (fabs(Mreq) > cap * (1.0 + STICK_RTOL)) { S->s[i] = Mreq > 0.0 ? -1 : 1; changed = 1; }
            }
        }
        if (!changed) break;
    }
    return (before[0] != S->s[0]) + (before[1] != S->s[1]);
}

static int slip_speed_reached_zero(const MkParams *P, const MkState *S, const double *y, const double *f1, int i) {
    int64_t s = S->s[i];
    int idx = i ? W2 : W1;
    double w = y[idx];
    return s != 0 && ((double)s * w <= 0.0 || (fabs(w) <= P->w_stick && (double)s * f1[idx] < 0.0));
}

static void stick_impulse(const MkParams *P, MkState *S, double *y, int i, double wc) {
    int idx = i ? W2 : W1;
    double w = y[idx];
    if (w == 0.0) return;
    double nJ = P->n * (i ? P->J2 : P->J1);
    if (P->speed_drive) {
        S->work_in += -nJ * wc * w;
        S->energy_loss += 0.5 * nJ * w * w;
        y[idx] = 0.0;
        return;
    }
    int k = 3 + i;
    double col[5], v[5] = {y[WC], y[VA], y[VB], y[W1], y[W2]};
    for (int r = 0; r < 5; r++) col[r] = P->Minv[r][k];
    double q = w / col[k];
    for (int r = 0; r < 5; r++) v[r] -= col[r] * q;
    S->energy_loss += 0.5 * w * w / col[k];
    y[WC] = v[0]; y[VA] = v[1]; y[VB] = v[2]; y[W1] = v[3]; y[W2] = v[4];
    y[idx] = 0.0;
}

/* ------------------------------------------------------------ the driver (spurdiff.differential.mesh.stepper) */
static void book_parametric_work(const MkParams *P, MkState *S, const double *ya, const double *yb) {
    double psiBa, th1a, th2a, psiBb, th1b, th2b;
    mk_relative_angles(S, P, ya, &psiBa, &th1a, &th2a);
    mk_relative_angles(S, P, yb, &psiBb, &th1b, &th2b);
    double ua[3] = {P->rbA * ya[PSI], P->rbB * psiBa, P->rb1 * th1a};
    double ub[3] = {P->rbA * yb[PSI], P->rbB * psiBb, P->rb1 * th1b};
    for (int mi = 0; mi < 3; mi++) {
        const MkMesh *m = &P->md[mi];
        double d = yb[m->d];
        double ra = m->sigma * ua[mi] / m->pb, rb = m->sigma * ub[mi] / m->pb;
        double Va = mk_law_potential(P, m, d, mk_wave_factor(P, m, mk_pymod(m->xi0 - ra, 1.0)), mk_wave_factor(P, m, mk_pymod(m->xi0c + ra, 1.0)));
        double Vb = mk_law_potential(P, m, d, mk_wave_factor(P, m, mk_pymod(m->xi0 - rb, 1.0)), mk_wave_factor(P, m, mk_pymod(m->xi0c + rb, 1.0)));
        if (Va != Vb) S->parametric_work += P->n * (Vb - Va);
    }
}

/* stepper.dense_output: the states at the output times tq[k] (into the step) in (tin, tin + hi] of
 * an accepted step from y to yn, by the method's dense output (order 3, RODAS5P 4); returns the next k */
static int64_t dense_output(const MkParams *P, Work *wk, const double *y, const double *yn, double tin,
                            double hi, int64_t k, int64_t nq, const double *tq, double *yq) {
    const int N = (int)P->N;
    int formed = 0;
    while (k < nq && tq[k] <= tin + hi) {
        double *out = yq + k * N, th = (tq[k] - tin) / hi;
        if (th >= 1.0) {
            memcpy(out, yn, sizeof(double) * N);
        } else {
            if (!formed) {        /* Q_p = sum_j dpoly[p][j] u_j, once for the step */
                for (int p = 0; p < 4; p++) combine(P->dpoly[p], (int)P->stages, wk->U, N, wk->Q[p]);
                formed = 1;
            }
            double th2 = th * th, th3 = th2 * th, th4 = th3 * th;
            for (int j = 0; j < N; j++)
                out[j] = y[j] + (((wk->Q[0][j] * th + wk->Q[1][j] * th2) + wk->Q[2][j] * th3) + wk->Q[3][j] * th4);
        }
        k++;
    }
    return k;
}

/* stepper.advance: one communication step t -> t + h; the state S is changed only on MK_OK; with
 * nq > 0 also the states at the times tq (into the step, increasing, in (0, h]) into yq (nq x N) */
static int advance(const MkParams *P, MkState *S0, double t, double h, int64_t nq, const double *tq, double *yq) {
    static __thread Work wk;      /* per thread: FMU instances may step in parallel */
    MkState S1 = *S0, *S = &S1;
    const int N = (int)P->N;
    if (P->tracked) {                  /* the phase modes, held over each internal step (stepper.advance) */
        mk_phase_mode(P, S, S->y, S->pk, S->pnc);
        S->phold = 1;
    }
    double *y = S->y, sv0[13], sv1[13], svm[13];
    const int speed = (int)P->speed_drive;
    double wc_start = S->wc;
    if (speed) S->ac = (S->w_ref - wc_start) / h;
    double ac = S->ac;
    memcpy(wk.J1, S->Jf, sizeof(double) * N * N);     /* its constant rows (layout.constant_jacobian) */
    double *f0 = wk.f0, *f1 = wk.f1;
    if (S->cache_ok && S->key[0] == S->tau_L && S->key[1] == S->tau_R && S->key[2] == S->tau_c
        && (!speed || S->key[3] == ac) && S->key_s[0] == S->s[0] && S->key_s[1] == S->s[1]) {
        memcpy(f0, S->f0c, sizeof(double) * N);        /* f0 and the side values at y: the last step's */
        memcpy(sv0, S->sv0c, sizeof sv0);
    } else if (S->jac_age < 0) {                       /* no Jacobian yet */
        mk_eval(P, S, y, f0, S->Jf, sv0);
        S->n_jac++;
        S->jac_age = 0;
        S->lu_h = 0.0;
    } else {                                           /* the Jacobian depends on the state only */
        mk_eval(P, S, y, f0, NULL, sv0);
    }
    double loss0 = S->energy_loss, tin = 0.0, remaining = h, h_ctrl = S->h_next, wc_a = wc_start, phic = S->phic;
    double dloss = 0.0, hmin = 1e-13, wc_b = wc_start;
    int64_t n_here = 0, max_steps = P->max_steps, kq = 0;
    double yn[NMAX];
    while (remaining > 1e-12 * h) {
        double hi = h_ctrl < remaining ? h_ctrl : remaining;
        if (P->tracked) {
            double lim = phase_limit(P, S, y);
            if (lim < hi) hi = lim;
        }
        if (remaining - hi < 1e-9 * h) hi = remaining;
        int truncated = hi < h_ctrl, located = 0, rejected = 0, fresh = 0;
        double err;
        for (;;) {
            n_here++;
            if (n_here > max_steps) { S0->fail_t = t; S0->fail_h = hi; return MK_MAX_STEPS; }
            if (hi < hmin) { S0->fail_t = t + tin; S0->fail_h = hi; return MK_HMIN; }
            if (rejected && S->jac_age > 0) {           /* retried with a Jacobian at y */
                mk_eval(P, S, y, wk.fs, S->Jf, NULL);
                S->n_jac++;
                S->jac_age = 0;
                S->lu_h = 0.0;
            }
            if (!ros_step(P, S, y, f0, hi, &wk)) {
                S->n_rejected_steps++;
                rejected = truncated = 1;
                hi *= 0.25;
                continue;
            }
            memcpy(yn, wk.ynew, sizeof yn);
            if (P->pin) {
                if (S->s[0] == 0) yn[W1] = 0.0;
                if (S->s[1] == 0) yn[W2] = 0.0;
            }
            err = error_norm(P, wk.err, y, yn);
            if (!(err <= 1.0)) {
                S->n_rejected_steps++;
                rejected = truncated = 1;
                hi = err == err ? new_step_size(P, hi, err, 1) : hi * 0.25;
                continue;
            }
            fresh = !P->w_method || located > 0 || S->jac_age + 1 >= JAC_AGE_MAX;   /* a new Jacobian at y_new? */
            if (!fresh && (P->bl || P->contact)) {                 /* also where a contact changed */
                int64_t fl[6];
                contact_flags(P, yn, fl);
                for (int k = 0; k < 6; k++)
                    if (fl[k] != S->flags[k]) fresh = 1;
            }
            mk_eval(P, S, yn, f1, fresh ? wk.J1 : NULL, sv1);
            S->n_jac += fresh;
            midpoint(P, y, &wk);
            if (P->dissipative) {
                mk_eval(P, S, wk.ym, wk.fs, NULL, svm);
                double errE;
                if (!P->loss5) {                               /* stepper.loss_quadrature */
                    dloss = hi / 6.0 * (sv0[SV_P] + 4.0 * svm[SV_P] + sv1[SV_P]);
                    errE = fabs(dloss - 0.5 * hi * (sv0[SV_P] + sv1[SV_P])) / (P->rtol * (0.1 + dloss));
                } else {                                       /* stepper.loss_quadrature5 */
                    double sva[13], svb[13];
                    mk_eval(P, S, dense_at(P, P->dq[0], y, &wk), wk.fs, NULL, sva);
                    mk_eval(P, S, dense_at(P, P->dq[1], y, &wk), wk.fs, NULL, svb);
                    double P0 = sv0[SV_P], P1 = sv1[SV_P];
                    double s1 = hi / 6.0 * (P0 + 4.0 * svm[SV_P] + P1);
                    double s2 = hi / 12.0 * (P0 + 4.0 * sva[SV_P] + 2.0 * svm[SV_P] + 4.0 * svb[SV_P] + P1);
                    dloss = s2 + (s2 - s1) / 15.0;
                    errE = fabs(s2 - s1) / (P->rtol * (0.1 + dloss));
                }
                if (!(errE <= 1.0)) {
                    S->n_rejected_steps++;
                    rejected = truncated = 1;
                    hi = errE == errE ? new_step_size(P, hi, errE, 1) : hi * 0.25;
                    continue;
                }
                if (errE > err) err = errE;
            }
            double theta = state_events(P, S, y, wk.ym, yn);
            if (P->pin && theta >= 1.0 - 1e-6) theta = breakaway(P, S, sv0, svm, sv1, theta);
            if (P->tracked && located < 4) {      /* a loaded flank left its held phase mode */
                double thp = phase_events(P, S, y, wk.ym, yn);
                if (thp < theta && thp < 1.0 - PHASE_RTOL && thp * hi > hmin) {
                    located++;
                    S->n_rejected_steps++;
                    hi = hi * thp * (1.0 + PHASE_PAST) + 1e-15;
                    truncated = 1;
                    continue;
                }
            }
            if (theta < 1.0 - 1e-6 && located < 4 && theta * hi > hmin) {
                located++;
                S->n_rejected_steps++;
                hi = hi * theta * (1.0 + 1e-4) + 1e-14;
                truncated = 1;
                continue;
            }
            break;
        }
        /* ---- accept */
        S->n_internal_steps++;
        double h_prop = new_step_size(P, hi, err, rejected);
        if (!fresh && h_prop >= hi && h_prop <= H_KEEP * hi) h_prop = hi;
        h_ctrl = (truncated && !rejected) ? (h_ctrl > h_prop ? h_ctrl : h_prop) : h_prop;
        if (P->dissipative) S->energy_loss += dloss;
        double psiBa, th1a, th2a, psiBb, th1b, th2b;
        mk_relative_angles(S, P, y, &psiBa, &th1a, &th2a);
        mk_relative_angles(S, P, yn, &psiBb, &th1b, &th2b);
        double dpsiA = yn[PSI] - y[PSI], dpsiB = psiBb - psiBa;
        if (speed) {
            double n = (double)P->n;
            double JA = P->JA, JB = P->JB, J1n = P->J1 * n, J2n = P->J2 * n;
            wc_b = wc_start + ac * (tin + hi);
            double dphic = wc_a * hi + 0.5 * ac * hi * hi;
            S->work_in += (P->Jtot * ac * dphic
                           + JA * (yn[VA] * wc_b - y[VA] * wc_a - ac * dpsiA)
                           + JB * (yn[VB] * wc_b - y[VB] * wc_a - ac * dpsiB)
                           + J1n * (yn[W1] * wc_b - y[W1] * wc_a - ac * (th1b - th1a))
                           + J2n * (yn[W2] * wc_b - y[W2] * wc_a - ac * (th2b - th2a))
                           + S->tau_L * dpsiA + S->tau_R * dpsiB);
            phic += dphic;
            wc_a = wc_b;
        } else {
            double dphic = yn[PHIC] - y[PHIC];
            S->work_in += S->tau_c * dphic + S->tau_L * (dphic + dpsiA) + S->tau_R * (dphic + dpsiB);
            wc_b = yn[WC];
        }
        if (P->var) book_parametric_work(P, S, y, yn);
        if (kq < nq) kq = dense_output(P, &wk, y, yn, tin, hi, kq, nq, tq, yq);
        memcpy(y, yn, N * sizeof(double));
        tin += hi;
        remaining = h - tin;
        if (P->bl || P->contact) {
            int64_t fl[6];
            contact_flags(P, y, fl);
            for (int k = 0; k < 6; k++) {
                if (fl[k] != S->flags[k]) S->n_contact_transitions++;
                S->flags[k] = fl[k];
            }
        }
        int phase_switched = 0;
        if (P->tracked) {                         /* the phase modes switch where the step ended */
            double pk[6];
            int64_t pnc[6];
            mk_phase_mode(P, S, y, pk, pnc);
            for (int k = 0; k < 6; k++)
                if (pk[k] != S->pk[k] || pnc[k] != S->pnc[k]) phase_switched = 1;
            if (phase_switched) {                 /* events.phase_switches: count the loaded flanks' */
                int unilateral = P->bl || P->contact;
                for (int i = 0; i < 3; i++) {
                    double d = y[P->md[i].d];
                    int drive = unilateral ? d > 0.0 : d >= 0.0;
                    int coast = unilateral ? -(d + P->md[i].jn) > 0.0 : d < 0.0;
                    if (drive && (pk[2 * i] != S->pk[2 * i] || pnc[2 * i] != S->pnc[2 * i])) S->n_psw++;
                    if (coast && (pk[2 * i + 1] != S->pk[2 * i + 1] || pnc[2 * i + 1] != S->pnc[2 * i + 1])) S->n_psw++;
                }
                memcpy(S->pk, pk, sizeof pk);
                memcpy(S->pnc, pnc, sizeof pnc);
            }
        }
        int switched = 0;
        if (P->pin) {
            int zeroed[2], nz = 0;
            for (int i = 0; i < 2; i++)
                if (slip_speed_reached_zero(P, S, y, f1, i)) { stick_impulse(P, S, y, i, wc_b); zeroed[nz++] = i; }
            double m1[2];
            margins(P, S, sv1, m1);
            double tolc = -STICK_RTOL * (sv1[SV_CAP1] + sv1[SV_CAP2]);
            if (nz || m1[0] < tolc || m1[1] < tolc) {
                S->n_mode_switches += settle_modes(P, S, y, zeroed, nz, &wk, sv0);
                switched = 1;
            }
        }
        if (!switched) {
            double *t_ = f0; f0 = f1; f1 = t_;
            if (fresh) {
                memcpy(S->Jf, wk.J1, sizeof(double) * N * N);
                S->jac_age = 0;
                S->lu_h = 0.0;
            } else {
                S->jac_age++;
            }
            memcpy(sv0, sv1, sizeof sv0);
            if (phase_switched) {                 /* f and side values (and the fresh Jacobian) in the new modes */
                mk_eval(P, S, y, f0, fresh ? S->Jf : NULL, sv0);
                S->n_jac += fresh;
                if (P->pin) {                     /* the forces jumped: a stuck planet may break away */
                    double m0[2];
                    margins(P, S, sv0, m0);
                    double tolc = -STICK_RTOL * (sv0[SV_CAP1] + sv0[SV_CAP2]);
                    if (m0[0] < tolc || m0[1] < tolc) {
                        S->n_mode_switches += settle_modes(P, S, y, NULL, 0, &wk, sv0);
                        f0 = wk.f0; f1 = wk.f1;
                    }
                }
            }
        } else {
            f0 = wk.f0; f1 = wk.f1;   /* settle_modes evaluated f0, J and sv0 at y */
        }
    }
    S->h_next = h_ctrl;
    memcpy(S->f0c, f0, sizeof(double) * N);            /* stepper: c._f0_key, c._sv0 */
    memcpy(S->sv0c, sv0, sizeof sv0);
    S->key[0] = S->tau_L; S->key[1] = S->tau_R; S->key[2] = S->tau_c; S->key[3] = ac;
    S->key_s[0] = S->s[0]; S->key_s[1] = S->s[1];
    S->cache_ok = 1;
    if (speed) { S->wc = S->w_ref; S->phic = phic; }
    else { S->wc = y[WC]; S->phic = y[PHIC]; }
    S->t = t + h;
    S->loss_last_step = S->energy_loss - loss0;
    S->last_h = h;
    S->n_steps++;
    S->phold = 0;
    /* outputs: the speed drive reports the torque that holds the reached speed (a_c = 0) */
    if (!speed || S->ac == 0.0) {
        memcpy(S->sv, sv0, sizeof sv0);
    } else {
        double keep = S->ac;
        S->ac = 0.0;
        mk_eval(P, S, y, wk.fs, NULL, S->sv);
        S->ac = keep;
    }
    *S0 = *S;
    return MK_OK;
}

int mk_advance(const MkParams *P, MkState *S0, double t, double h) { return advance(P, S0, t, h, 0, NULL, NULL); }

/* one step t -> t + h (the whole run) with the states at the nq times tq (into the step) written to
 * yq by the dense output: an integration over the run with outputs, as solve_ivp's t_eval */
int mk_advance_dense(const MkParams *P, MkState *S0, double t, double h, int64_t nq, const double *tq, double *yq) {
    return advance(P, S0, t, h, nq, tq, yq);
}

/* the model evaluation alone (for the agreement test and solve_ivp): f, J (may be NULL), sv */
void mk_evaluate(const MkParams *P, const MkState *S, const double *y, double *f, double *J, double *sv) {
    mk_eval(P, S, y, f, J, sv);
}

/* n communication steps of size h from t0 with the inputs held, the states after each written to
 * ys (n x N): the same steps as n calls of mk_advance, without returning to the caller in between
 * (the solver benchmark's "one call"). Returns the number of steps done; S holds the last state. */
int64_t mk_run(const MkParams *P, MkState *S, double t0, double h, int64_t n, double *ys) {
    for (int64_t k = 0; k < n; k++) {
        if (mk_advance(P, S, t0 + k * h, h) != MK_OK) return k;
        memcpy(ys + k * P->N, S->y, sizeof(double) * P->N);
    }
    return n;
}
