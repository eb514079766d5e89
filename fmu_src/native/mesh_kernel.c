/*
 * Compiled kernel of the mesh levels (compliant, contact) of SpurDifferential: the model
 * evaluation (right-hand side, Jacobian, side values), the ROS34PW2 step with its error control,
 * and the whole internal stepping loop over one communication step (events, loss quadrature,
 * stick-slip, work accounting), so Python is entered once per communication step.
 *
 * A line-by-line transcription of the pure-Python reference, which stays the specification and the
 * fallback: fmu_src/spurdiff/mesh/{forces,events,stickslip,stepper,integrator}.py (the comments
 * name the Python function each C function mirrors). Called through ctypes
 * (fmu_src/spurdiff/mesh/kernel.py); the structs below are mirrored there field by field (doubles
 * and 64-bit integers only, so there is no padding). Depends on libm only.
 *
 * Agreement with the reference: the same operations in the same order (sums in the order the
 * reference sums, no contraction into fused multiply-adds: build with -ffp-contract=off), the same
 * libm, and the LU of the same LAPACK the reference calls (dgetrf/dgetrs pointers from scipy, handed
 * over by kernel.py; without them an own partial-pivoting LU, equal to rounding): the states agree
 * bit for bit where the reference's LAPACK is used (tests/test_mesh_kernel.py).
 */
#include <math.h>
#include <stdint.h>
#include <string.h>

#define MK_ABI 1
#define NMAX 10
enum { PSI, DA, DB, D12, VA, VB, W1, W2, WC, PHIC };
enum { LAW_BILATERAL = 0, LAW_ELASTO = 1, LAW_IMPACT = 2 };
enum { MK_OK = 0, MK_MAX_STEPS = 1, MK_HMIN = 2 };

typedef struct {
    double sigma, rb1, rb2, k, c, K, jn, eps, pb, l1min, galpha, L, xi0, xi0c, xip, a1, a2;
    int64_t d, g1, g2;
} MkMesh;

typedef struct {
    int64_t N, speed_drive, law, wave, tracked, flank, pin, bl, contact, dissipative, var, max_steps, n;
    double rbA, rb1, rbB, rb2, JA, JB, J1, J2, Jc, Jtot, lam;
    double e, C, dmax;                       /* IMPACT */
    double mu_s, mu_d, v_s, v_d;             /* flank friction */
    double c_pin, M01, M02;
    double pin_flat[2][8];                   /* spurdiff.locking.PinLayout._flat */
    double Minv[5][5];                       /* torque drive: inverse mass matrix (w_c, v_A, v_B, w_1, w_2) */
    double atol[NMAX], rtol, w_stick;
    double gamma, a[4][4], cc[4][4], m[4], ew[4], dmid[4];   /* transformed tableau */
    MkMesh md[3];
    int64_t getrf, getrs;    /* LAPACK dgetrf / dgetrs (Fortran ABI) of the reference (scipy), or 0: own LU */
} MkParams;

typedef struct {
    double y[NMAX];
    double w_ref, tau_c, tau_L, tau_R;
    double ac, wc, phic, t, h_next, work_in, energy_loss, parametric_work, loss_last_step, last_h;
    double dA0, dB0, d120;
    double sv[13];            /* side values of the outputs at the end (spurdiff.mesh.forces.SideValues) */
    int64_t s[2], flags[6], n_flags;
    int64_t n_internal_steps, n_rejected_steps, n_mode_switches, n_contact_transitions, n_steps;
    double fail_t, fail_h;    /* where a step failed */
} MkState;

typedef struct { double F, dF_dd, dF_dv, Fc, xi; } Force;
typedef struct { double M1, M2, dM1F, dM2F, d11, d12, d22, P; } Moments;
enum { SV_FA, SV_FB, SV_F12, SV_QA, SV_QB, SV_Q1, SV_Q2, SV_M1, SV_M2, SV_CAP1, SV_CAP2, SV_P, SV_AC };

int mk_abi(void) { return MK_ABI; }
int64_t mk_sizeof_params(void) { return (int64_t)sizeof(MkParams); }
int64_t mk_sizeof_state(void) { return (int64_t)sizeof(MkState); }

/* Python's float % (result has the sign of the divisor) */
static double pymod(double x, double w) {
    double r = fmod(x, w);
    if (r != 0.0) {
        if ((w < 0.0) != (r < 0.0)) r += w;
    } else {
        r = copysign(0.0, w);
    }
    return r;
}

/* ------------------------------------------------------------ laws (spurdiff.mesh.laws) */
static void impact(double p, double v, double K, double e, double C, double dmax, double *out) {
    if (p <= 0.0) { out[0] = out[1] = out[2] = out[3] = 0.0; return; }
    double pe1 = pow(p, e - 1.0);
    double Fc = K * pe1 * p, cs, dcs;
    if (p >= dmax) { cs = C; dcs = 0.0; }
    else {
        double s = p / dmax;
        cs = C * s * s * (3.0 - 2.0 * s);
        dcs = C * 6.0 * s * (1.0 - s) / dmax;
    }
    double F = Fc + cs * v;
    if (F <= 0.0) { out[0] = out[1] = out[2] = 0.0; out[3] = Fc; return; }
    out[0] = F; out[1] = e * K * pe1 + dcs * v; out[2] = cs; out[3] = Fc;
}

static double impact_potential(double p, double K, double e) {
    return p > 0.0 ? K * pow(p, e + 1.0) / (e + 1.0) : 0.0;
}

static void elasto_backlash(double p, double v, double k, double c, double *out) {
    if (p <= 0.0) { out[0] = out[1] = out[2] = out[3] = 0.0; return; }
    double Fc = k * p, Fd = c * v;
    if (Fc + Fd <= 0.0) { out[0] = out[1] = out[2] = 0.0; out[3] = Fc; return; }
    if (Fd < Fc) { out[0] = Fc + Fd; out[1] = k; out[2] = c; out[3] = Fc; return; }
    out[0] = 2.0 * Fc; out[1] = 2.0 * k; out[2] = 0.0; out[3] = Fc;
}

static void step_d(double x, double x0, double h0, double x1, double h1, double *v, double *dv) {
    if (x <= x0) { *v = h0; *dv = 0.0; return; }
    if (x >= x1) { *v = h1; *dv = 0.0; return; }
    double w = x1 - x0, s = (x - x0) / w;
    *v = h0 + (h1 - h0) * s * s * (3.0 - 2.0 * s);
    *dv = (h1 - h0) * 6.0 * s * (1.0 - s) / w;
}

static void friction_coefficient(double v, double mu_s, double mu_d, double v_s, double v_d, double *mu, double *dmu) {
    double a = v >= 0.0 ? v : -v;
    if (a <= v_s) { step_d(v, -v_s, -mu_s, v_s, mu_s, mu, dmu); return; }
    if (a < v_d) {
        double m, dm;
        step_d(a, v_s, mu_s, v_d, mu_d, &m, &dm);
        *mu = v > 0.0 ? m : -m; *dmu = dm; return;
    }
    *mu = v > 0.0 ? mu_d : -mu_d; *dmu = 0.0;
}

/* ------------------------------------------------------------ effects (spurdiff.mesh.forces) */
static double wave_factor(const MkParams *P, const MkMesh *m, double xi) {   /* MeshPhase.factor */
    if (!P->wave) return 1.0;
    return (xi < m->eps - 1.0 ? 2.0 : 1.0) / m->eps;
}

static void phase(const MkParams *P, const MkMesh *m, double u, double *xp, double *xn, double *kp, double *kn) {
    if (!P->tracked) { *xp = m->xi0; *xn = m->xi0c; *kp = *kn = 1.0; return; }
    double r = m->sigma * u / m->pb;
    *xp = pymod(m->xi0 - r, 1.0);
    *xn = pymod(m->xi0c + r, 1.0);
    if (P->wave) {
        double e1 = m->eps - 1.0;
        *kp = (*xp < e1 ? 2.0 : 1.0) / m->eps;
        *kn = (*xn < e1 ? 2.0 : 1.0) / m->eps;
    } else {
        *kp = *kn = 1.0;
    }
}

static void flank_law(const MkParams *P, const MkMesh *m, double p, double v, double kf, double *out) {
    if (P->law == LAW_IMPACT) impact(p, v, m->K * kf, P->e, P->C, P->dmax, out);
    else elasto_backlash(p, v, m->k * kf, m->c, out);
}

static Force mesh_force(const MkParams *P, const MkMesh *m, double d, double dd, double u) {
    double xp, xn, kp, kn, o[4];
    Force f;
    phase(P, m, u, &xp, &xn, &kp, &kn);
    if (P->law == LAW_BILATERAL) {
        double kk = d >= 0.0 ? m->k * kp : m->k * kn;
        f.F = kk * d + m->c * dd; f.dF_dd = kk; f.dF_dv = m->c; f.Fc = kk * d; f.xi = d >= 0.0 ? xp : xn;
        return f;
    }
    if (d > 0.0) {
        flank_law(P, m, d, dd, kp, o);
        f.F = o[0]; f.dF_dd = o[1]; f.dF_dv = o[2]; f.Fc = o[3]; f.xi = xp;
        return f;
    }
    double pen = -(d + m->jn);
    if (pen > 0.0) {
        flank_law(P, m, pen, -dd, kn, o);
        f.F = -o[0]; f.dF_dd = o[1]; f.dF_dv = o[2]; f.Fc = -o[3]; f.xi = xn;
        return f;
    }
    f.F = f.dF_dd = f.dF_dv = f.Fc = 0.0; f.xi = xp;
    return f;
}

static double law_potential(const MkParams *P, const MkMesh *m, double d, double kp, double kn) {
    if (P->law == LAW_IMPACT) {
        if (d > 0.0) return impact_potential(d, m->K * kp, P->e);
        return impact_potential(-(d + m->jn), m->K * kn, P->e);
    }
    if (P->law == LAW_BILATERAL) return 0.5 * m->k * (d >= 0.0 ? kp : kn) * d * d;
    if (d > 0.0) return 0.5 * m->k * kp * d * d;
    double pen = -(d + m->jn);
    return pen > 0.0 ? 0.5 * m->k * kn * pen * pen : 0.0;
}

static Moments flank_moments(const MkParams *P, const MkMesh *m, double F, double xi, double W1_, double W2_) {
    Moments r = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    if (F == 0.0) return r;
    double x0 = xi * m->pb;
    int nc = x0 + m->pb <= m->galpha ? 2 : 1;
    double aF = fabs(F), sF = F > 0.0 ? 1.0 : -1.0, share = aF / nc, x = x0;
    for (int j = 0; j < nc; j++) {
        double l1 = m->l1min + x, l2 = m->L - l1, v = W1_ * l1 + W2_ * l2, mu, dmu;
        friction_coefficient(v, P->mu_s, P->mu_d, P->v_s, P->v_d, &mu, &dmu);
        r.M1 -= mu * share * l1;
        r.M2 -= mu * share * l2;
        r.dM1F -= mu * sF / nc * l1;
        r.dM2F -= mu * sF / nc * l2;
        double g = dmu * share;
        r.d11 -= g * l1 * l1;
        r.d12 -= g * l1 * l2;
        r.d22 -= g * l2 * l2;
        r.P += mu * share * v;
        x += m->pb;
    }
    return r;
}

static void pin_force(const MkParams *P, int i, double Fs, double F12, double *mag, double *dS, double *d12) {
    const double *q = P->pin_flat[i];   /* tx, ty, rx, ry, ux, uy, qx, qy */
    double aS = fabs(Fs), a12 = fabs(F12);
    double fx = Fs * q[0] + aS * q[2] + F12 * q[4] + a12 * q[6];
    double fy = Fs * q[1] + aS * q[3] + F12 * q[5] + a12 * q[7];
    double mg = sqrt(fx * fx + fy * fy);
    if (mg == 0.0) { *mag = *dS = *d12 = 0.0; return; }
    double sgS = Fs >= 0.0 ? 1.0 : -1.0, sg12 = F12 >= 0.0 ? 1.0 : -1.0;
    *mag = mg;
    *dS = (fx * (q[0] + sgS * q[2]) + fy * (q[1] + sgS * q[3])) / mg;
    *d12 = (fx * (q[4] + sg12 * q[6]) + fy * (q[5] + sg12 * q[7])) / mg;
}

static void relative_angles(const MkState *S, const MkParams *P, const double *y, double *psiB, double *th1, double *th2) {
    double t1 = (S->dA0 - y[DA] - P->rbA * y[PSI]) / P->rb1;
    double t2 = (y[D12] - S->d120 - P->rb1 * t1) / P->rb2;
    *psiB = (S->dB0 - y[DB] - P->rb2 * t2) / P->rbB;
    *th1 = t1;
    *th2 = t2;
}

/* forces.evaluate: f = y'(y); J rows 4.. (and WC) if J != NULL (row-major NxN); side values sv */
static void evaluate(const MkParams *P, const MkState *S, const double *y, double *f, double *J, double *sv) {
    const int N = (int)P->N;
    const int n = (int)P->n;
    const double W[4] = {y[VA], y[VB], y[W1], y[W2]};
    double us[3] = {0.0, 0.0, 0.0};
    if (P->tracked) {
        double psiB, th1, th2;
        relative_angles(S, P, y, &psiB, &th1, &th2);
        us[0] = P->rbA * y[PSI]; us[1] = P->rbB * psiB; us[2] = P->rb1 * th1;
    }
    double dds[3];
    Force mf[3];
    for (int i = 0; i < 3; i++) {
        const MkMesh *m = &P->md[i];
        dds[i] = m->a1 * W[m->g1] + m->a2 * W[m->g2];
        mf[i] = mesh_force(P, m, y[m->d], dds[i], us[i]);
    }
    double FA = mf[0].F, FB = mf[1].F, F12 = mf[2].F;
    double Pw = n * ((FA - mf[0].Fc) * dds[0] + (FB - mf[1].Fc) * dds[1] + (F12 - mf[2].Fc) * dds[2]);
    const double rbA = P->rbA, rb1 = P->rb1, rbB = P->rbB, rb2 = P->rb2;
    double Q[4] = {rbA * FA, rbB * FB, rb1 * (FA - F12), rb2 * (FB - F12)};
    double C[4][3] = {{rbA, 0.0, 0.0}, {0.0, rbB, 0.0}, {rb1, 0.0, -rb1}, {0.0, rb2, -rb2}};
    double G[4][4];
    memset(G, 0, sizeof G);
    if (P->flank) {
        double Pf = 0.0;
        for (int i = 0; i < 3; i++) {
            const MkMesh *m = &P->md[i];
            int g1 = (int)m->g1, g2 = (int)m->g2;
            Moments fm = flank_moments(P, m, mf[i].F, mf[i].xi, W[g1], W[g2]);
            Q[g1] += fm.M1;
            Q[g2] += fm.M2;
            C[g1][i] += fm.dM1F;
            C[g2][i] += fm.dM2F;
            G[g1][g1] += fm.d11;
            G[g1][g2] += fm.d12;
            G[g2][g1] += fm.d12;
            G[g2][g2] += fm.d22;
            Pf = i ? Pf + fm.P : fm.P;
        }
        Pw += n * Pf;
    }
    double QA = n * Q[0], QB = n * Q[1], Q1 = Q[2], Q2 = Q[3];
    int s1 = (int)S->s[0], s2 = (int)S->s[1];
    double cap1 = 0.0, cap2 = 0.0, cp = P->c_pin, dp1S = 0.0, dp112 = 0.0, dp2S = 0.0, dp212 = 0.0;
    int stuck1 = 0, stuck2 = 0;
    if (P->pin) {
        double Fp1, Fp2;
        pin_force(P, 0, FA, F12, &Fp1, &dp1S, &dp112);
        pin_force(P, 1, FB, F12, &Fp2, &dp2S, &dp212);
        cap1 = cp * Fp1 + P->M01;
        cap2 = cp * Fp2 + P->M02;
        stuck1 = s1 == 0;
        stuck2 = s2 == 0;
    }
    double Q1nf = Q1, Q2nf = Q2, M1 = 0.0, M2 = 0.0;
    if (P->pin) {
        if (!stuck1) {
            M1 = -s1 * cap1;
            Q1 += M1;
            C[2][0] -= s1 * cp * dp1S;
            C[2][2] -= s1 * cp * dp112;
            Pw += n * fabs(M1 * W[2]);
        }
        if (!stuck2) {
            M2 = -s2 * cap2;
            Q2 += M2;
            C[3][1] -= s2 * cp * dp2S;
            C[3][2] -= s2 * cp * dp212;
            Pw += n * fabs(M2 * W[3]);
        }
    }
    double ac, Jeff = 0.0;
    if (P->speed_drive) {
        ac = S->ac;
    } else {
        Jeff = P->Jc;
        double Qs = QA + QB;
        if (stuck1) Jeff += n * P->J1; else Qs += n * Q1;
        if (stuck2) Jeff += n * P->J2; else Qs += n * Q2;
        ac = (S->tau_c - Qs) / Jeff;
    }
    if (stuck1) { M1 = P->J1 * ac - Q1nf; Q1 = P->J1 * ac; }
    if (stuck2) { M2 = P->J2 * ac - Q2nf; Q2 = P->J2 * ac; }
    f[0] = W[0];
    f[1] = dds[0];
    f[2] = dds[1];
    f[3] = dds[2];
    f[4] = (S->tau_L + QA) / P->JA - ac;
    f[5] = (S->tau_R + QB) / P->JB - ac;
    f[6] = stuck1 ? 0.0 : Q1 / P->J1 - ac;
    f[7] = stuck2 ? 0.0 : Q2 / P->J2 - ac;
    if (!P->speed_drive) { f[8] = ac; f[9] = y[WC]; }
    if (sv) {
        sv[SV_FA] = FA; sv[SV_FB] = FB; sv[SV_F12] = F12; sv[SV_QA] = QA; sv[SV_QB] = QB; sv[SV_Q1] = Q1;
        sv[SV_Q2] = Q2; sv[SV_M1] = M1; sv[SV_M2] = M2; sv[SV_CAP1] = cap1; sv[SV_CAP2] = cap2; sv[SV_P] = Pw;
        sv[SV_AC] = ac;
    }
    if (!J) return;
    double rows[4][7];
    for (int g = 0; g < 4; g++) {
        double sc = g < 2 ? (double)n : 1.0;
        double *r = rows[g];
        for (int k = 0; k < 7; k++) r[k] = 0.0;
        for (int i = 0; i < 3; i++) {
            const MkMesh *m = &P->md[i];
            if (m->g1 != g && m->g2 != g) continue;
            double coef = C[g][i], dv = mf[i].dF_dv;
            r[m->d - 1] = sc * coef * mf[i].dF_dd;
            r[m->g1 + 3] += coef * (dv * m->a1);
            r[m->g2 + 3] += coef * (dv * m->a2);
        }
        for (int k = 3; k < 7; k++) r[k] = P->flank ? sc * (r[k] + G[g][k - 3]) : sc * r[k];
    }
    double gac[7] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    if (!P->speed_drive) {
        for (int k = 0; k < 7; k++) {
            double a = rows[0][k] + rows[1][k];
            if (!stuck1) a += n * rows[2][k];
            if (!stuck2) a += n * rows[3][k];
            gac[k] = -a / Jeff;
            J[WC * N + 1 + k] = gac[k];
        }
    }
    double iA = 1.0 / P->JA, iB = 1.0 / P->JB, i1 = 1.0 / P->J1, i2 = 1.0 / P->J2;
    for (int k = 0; k < 7; k++) {
        J[VA * N + 1 + k] = rows[0][k] * iA - gac[k];
        J[VB * N + 1 + k] = rows[1][k] * iB - gac[k];
        J[W1 * N + 1 + k] = stuck1 ? 0.0 : rows[2][k] * i1 - gac[k];
        J[W2 * N + 1 + k] = stuck2 ? 0.0 : rows[3][k] * i2 - gac[k];
    }
}

/* ------------------------------------------------------------ the method (spurdiff.mesh.integrator) */
typedef void (*getrf_t)(int *, int *, double *, int *, int *, int *);
typedef void (*getrs_t)(char *, int *, int *, double *, int *, int *, double *, int *, int *);

typedef struct {
    double J[NMAX * NMAX], J1[NMAX * NMAX], W[NMAX * NMAX];
    int piv[NMAX];
    double U[4][NMAX], ynew[NMAX], err[NMAX], ym[NMAX], Ys[NMAX], F[NMAX], rhs[NMAX];
    double f0[NMAX], f1[NMAX], fs[NMAX];
} Work;

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

/* RosenbrockW.step: with f0 = f(y) and wk->J = J(y); fills ynew, err, U. 0: singular / not finite */
/* the factorization of W and the solves with it: the reference's LAPACK (column-major) or own */
static int factor(const MkParams *P, Work *wk, int N) {
    if (P->getrf) {
        double cm[NMAX * NMAX];
        for (int i = 0; i < N; i++)
            for (int j = 0; j < N; j++) cm[j * N + i] = wk->W[i * N + j];
        memcpy(wk->W, cm, sizeof(double) * N * N);
        int n = N, info = 0;
        ((getrf_t)(intptr_t)P->getrf)(&n, &n, wk->W, &n, wk->piv, &info);
        return info == 0;
    }
    return lu(wk->W, N, wk->piv);
}

static int solve(const MkParams *P, Work *wk, int N, const double *b, double *x) {
    if (P->getrs) {
        for (int i = 0; i < N; i++) x[i] = b[i];
        char tr = 'N';
        int n = N, one = 1, info = 0;
        ((getrs_t)(intptr_t)P->getrs)(&tr, &n, &one, wk->W, &n, wk->piv, x, &n, &info);
        return info == 0;
    }
    lu_solve(wk->W, N, wk->piv, b, x);
    return 1;
}

/* out = sum_k c[k] U[k] in the order of k (integrator._combine) */
static void combine(const double *c, int nk, double U[4][NMAX], int N, double *out) {
    for (int j = 0; j < N; j++) {
        double s = U[0][j] * c[0];
        for (int k = 1; k < nk; k++) s += U[k][j] * c[k];
        out[j] = s;
    }
}

static int ros_step(const MkParams *P, const MkState *S, const double *y, const double *f0, double h, Work *wk) {
    const int N = (int)P->N;
    double d = 1.0 / (P->gamma * h);
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++) wk->W[i * N + j] = (i == j ? d : 0.0) - wk->J[i * N + j];
    if (!factor(P, wk, N)) return 0;
    if (!solve(P, wk, N, f0, wk->U[0])) return 0;
    double ih = 1.0 / h;
    for (int i = 1; i < 4; i++) {
        combine(P->a[i], i, wk->U, N, wk->Ys);
        for (int j = 0; j < N; j++) wk->Ys[j] += y[j];
        evaluate(P, S, wk->Ys, wk->F, NULL, NULL);
        combine(P->cc[i], i, wk->U, N, wk->rhs);
        for (int j = 0; j < N; j++) wk->rhs[j] = wk->rhs[j] * ih + wk->F[j];
        if (!solve(P, wk, N, wk->rhs, wk->U[i])) return 0;
    }
    int finite = 1;
    combine(P->m, 4, wk->U, N, wk->ynew);
    combine(P->ew, 4, wk->U, N, wk->err);
    for (int j = 0; j < N; j++) {
        wk->ynew[j] += y[j];
        if (!isfinite(wk->ynew[j])) finite = 0;
    }
    return finite;
}

static void midpoint(const MkParams *P, const double *y, Work *wk) {
    combine(P->dmid, 4, wk->U, (int)P->N, wk->ym);
    for (int j = 0; j < (int)P->N; j++) wk->ym[j] += y[j];
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

static double new_step_size(double h, double err, int rejected) {
    double fac = err <= 0.0 ? 5.0 : 0.9 * pow(err, -1.0 / 3.0);
    double hi = rejected ? 1.0 : 5.0;
    if (fac < 0.2) fac = 0.2;
    if (fac > hi) fac = hi;
    return h * fac;
}

/* ------------------------------------------------------------ events (spurdiff.mesh.events) */
#define STICK_RTOL 1e-9

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
            relative_angles(S, P, y, &psiB, &th1, &th2);
            us[0] = P->rbA * y[PSI]; us[1] = P->rbB * psiB; us[2] = P->rb1 * th1;
            have_us = 1;
        }
        double xi = pymod((sgn < 0.0 ? m->xi0 : m->xi0c) + sgn * m->sigma * us[mi] / m->pb, 1.0);
        double ar = fabs(rate);
        double bounds[3] = {0.0, m->eps - 1.0, m->xip};
        int nb = P->flank ? 3 : 2;
        for (int j = 0; j < nb; j++) {
            double dist = rate > 0.0 ? pymod(bounds[j] - xi, 1.0) : pymod(xi - bounds[j], 1.0);
            if (dist == 0.0) dist = 1.0;
            double dt = dist / ar;
            dt += 1e-7 * dt + 1e-12;
            if (j == 2) {
                double grad = fabs(om[mi][0] - om[mi][1]) * ar * m->pb;
                if (grad > 0.0) dt += 1.5 * P->v_s / grad;
            }
            if (dt < best) best = dt;
        }
    }
    return best;
}

/* ------------------------------------------------------------ stick-slip (spurdiff.mesh.stickslip) */
static int64_t settle_modes(const MkParams *P, MkState *S, const double *y, const int *zeroed, int nz, Work *wk, double *sv) {
    int64_t before[2] = {S->s[0], S->s[1]};
    for (int k = 0; k < nz; k++) S->s[zeroed[k]] = 0;
    for (int it = 0; it < 4; it++) {
        evaluate(P, S, y, wk->f0, wk->J, sv);
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

/* ------------------------------------------------------------ the driver (spurdiff.mesh.stepper) */
static void book_parametric_work(const MkParams *P, MkState *S, const double *ya, const double *yb) {
    double psiBa, th1a, th2a, psiBb, th1b, th2b;
    relative_angles(S, P, ya, &psiBa, &th1a, &th2a);
    relative_angles(S, P, yb, &psiBb, &th1b, &th2b);
    double ua[3] = {P->rbA * ya[PSI], P->rbB * psiBa, P->rb1 * th1a};
    double ub[3] = {P->rbA * yb[PSI], P->rbB * psiBb, P->rb1 * th1b};
    for (int mi = 0; mi < 3; mi++) {
        const MkMesh *m = &P->md[mi];
        double d = yb[m->d];
        double ra = m->sigma * ua[mi] / m->pb, rb = m->sigma * ub[mi] / m->pb;
        double Va = law_potential(P, m, d, wave_factor(P, m, pymod(m->xi0 - ra, 1.0)), wave_factor(P, m, pymod(m->xi0c + ra, 1.0)));
        double Vb = law_potential(P, m, d, wave_factor(P, m, pymod(m->xi0 - rb, 1.0)), wave_factor(P, m, pymod(m->xi0c + rb, 1.0)));
        if (Va != Vb) S->parametric_work += P->n * (Vb - Va);
    }
}

/* stepper.advance: one communication step t -> t + h; the state S is changed only on MK_OK */
int mk_advance(const MkParams *P, MkState *S0, double t, double h) {
    static __thread Work wk;      /* per thread: FMU instances may step in parallel */
    MkState S1 = *S0, *S = &S1;
    const int N = (int)P->N;
    double *y = S->y, sv0[13], sv1[13], svm[13];
    const int speed = (int)P->speed_drive;
    double wc_start = S->wc;
    if (speed) S->ac = (S->w_ref - wc_start) / h;
    double ac = S->ac;
    /* the constant rows of the Jacobian (layout.constant_jacobian) */
    memset(wk.J, 0, sizeof wk.J);
    wk.J[PSI * N + VA] = 1.0;
    wk.J[DA * N + VA] = -P->rbA; wk.J[DA * N + W1] = -P->rb1;
    wk.J[DB * N + VB] = -P->rbB; wk.J[DB * N + W2] = -P->rb2;
    wk.J[D12 * N + W1] = P->rb1; wk.J[D12 * N + W2] = P->rb2;
    if (!speed) wk.J[PHIC * N + WC] = 1.0;
    memcpy(wk.J1, wk.J, sizeof wk.J);
    double *f0 = wk.f0, *f1 = wk.f1;
    evaluate(P, S, y, f0, wk.J, sv0);
    double loss0 = S->energy_loss, tin = 0.0, remaining = h, h_ctrl = S->h_next, wc_a = wc_start, phic = S->phic;
    double dloss = 0.0, hmin = 1e-13, wc_b = wc_start;
    int64_t n_here = 0, max_steps = P->max_steps;
    double yn[NMAX];
    while (remaining > 1e-12 * h) {
        double hi = h_ctrl < remaining ? h_ctrl : remaining;
        if (P->tracked) {
            double lim = phase_limit(P, S, y);
            if (lim < hi) hi = lim;
        }
        if (remaining - hi < 1e-9 * h) hi = remaining;
        int truncated = hi < h_ctrl, located = 0, rejected = 0;
        double err;
        for (;;) {
            n_here++;
            if (n_here > max_steps) { S0->fail_t = t; S0->fail_h = hi; return MK_MAX_STEPS; }
            if (hi < hmin) { S0->fail_t = t + tin; S0->fail_h = hi; return MK_HMIN; }
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
                hi = err == err ? new_step_size(hi, err, 1) : hi * 0.25;
                continue;
            }
            evaluate(P, S, yn, f1, wk.J1, sv1);
            midpoint(P, y, &wk);
            if (P->dissipative) {
                evaluate(P, S, wk.ym, wk.fs, NULL, svm);
                dloss = hi / 6.0 * (sv0[SV_P] + 4.0 * svm[SV_P] + sv1[SV_P]);
                double errE = fabs(dloss - 0.5 * hi * (sv0[SV_P] + sv1[SV_P])) / (P->rtol * (0.1 + dloss));
                if (!(errE <= 1.0)) {
                    S->n_rejected_steps++;
                    rejected = truncated = 1;
                    hi = errE == errE ? new_step_size(hi, errE, 1) : hi * 0.25;
                    continue;
                }
                if (errE > err) err = errE;
            }
            double theta = state_events(P, S, y, wk.ym, yn);
            if (P->pin && theta >= 1.0 - 1e-6) theta = breakaway(P, S, sv0, svm, sv1, theta);
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
        double h_prop = new_step_size(hi, err, rejected);
        h_ctrl = (truncated && !rejected) ? (h_ctrl > h_prop ? h_ctrl : h_prop) : h_prop;
        if (P->dissipative) S->energy_loss += dloss;
        double psiBa, th1a, th2a, psiBb, th1b, th2b;
        relative_angles(S, P, y, &psiBa, &th1a, &th2a);
        relative_angles(S, P, yn, &psiBb, &th1b, &th2b);
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
            double Jt[NMAX * NMAX];
            memcpy(Jt, wk.J, sizeof Jt); memcpy(wk.J, wk.J1, sizeof Jt); memcpy(wk.J1, Jt, sizeof Jt);
            memcpy(sv0, sv1, sizeof sv0);
        } else {
            f0 = wk.f0; f1 = wk.f1;   /* settle_modes evaluated f0, J and sv0 at y */
        }
    }
    S->h_next = h_ctrl;
    if (speed) { S->wc = S->w_ref; S->phic = phic; }
    else { S->wc = y[WC]; S->phic = y[PHIC]; }
    S->t = t + h;
    S->loss_last_step = S->energy_loss - loss0;
    S->last_h = h;
    S->n_steps++;
    /* outputs: the speed drive reports the torque that holds the reached speed (a_c = 0) */
    if (!speed || S->ac == 0.0) {
        memcpy(S->sv, sv0, sizeof sv0);
    } else {
        double keep = S->ac;
        S->ac = 0.0;
        evaluate(P, S, y, wk.fs, NULL, S->sv);
        S->ac = keep;
    }
    *S0 = *S;
    return MK_OK;
}

/* the model evaluation alone (for the agreement test and solve_ivp): f, J (may be NULL), sv */
void mk_evaluate(const MkParams *P, const MkState *S, const double *y, double *f, double *J, double *sv) {
    evaluate(P, S, y, f, J, sv);
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
