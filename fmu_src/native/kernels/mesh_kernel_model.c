/*
 * The model evaluation of the compiled mesh kernel: force and friction laws, the effects (mesh
 * phase and stiffness wave, flank friction, pin friction) and the right-hand side with its Jacobian
 * and side values, a transcription of fmu_src/spurdiff/differential/mesh/{laws,forces}.py (see mesh_kernel.c).
 */
#include "mesh_kernel.h"

/* Python's float % (result has the sign of the divisor) */
MK_HIDDEN double mk_pymod(double x, double w) {
    double r = fmod(x, w);
    if (r != 0.0) {
        if ((w < 0.0) != (r < 0.0)) r += w;
    } else {
        r = copysign(0.0, w);
    }
    return r;
}

/* ------------------------------------------------------------ laws (spurdiff.differential.mesh.laws) */
static inline __attribute__((always_inline)) void impact(double p, double v, double K, double e, double C, double dmax,
                                                          double *out) {
    if (p <= 0.0) { out[0] = out[1] = out[2] = out[3] = 0.0; return; }
    double pe1 = e == 1.5 ? sqrt(p) : pow(p, e - 1.0);
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

static inline __attribute__((always_inline)) void elasto_backlash(double p, double v, double k, double c, double *out) {
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

/* ------------------------------------------------------------ effects (spurdiff.differential.mesh.forces) */
MK_HIDDEN double mk_wave_factor(const MkParams *P, const MkMesh *m, double xi) {   /* MeshPhase.factor */
    if (!P->wave) return 1.0;
    return (xi < m->eps - 1.0 ? 2.0 : 1.0) / m->eps;
}

/* MeshPhase.phase: phases, stiffness factors and pairs in contact of mesh i's drive and coast flanks at roll u,
 * in the held phase modes (S->phold) or in the modes at u */
static void phase(const MkParams *P, const MkState *S, int i, const MkMesh *m, double u, double *xp, double *xn,
                  double *kp, double *kn, int64_t *np, int64_t *nn) {
    if (!P->tracked) { *xp = m->xi0; *xn = m->xi0c; *kp = *kn = 1.0; *np = *nn = 1; return; }
    double r = m->sigma * u / m->pb;
    double zp = m->xi0 - r, zn = m->xi0c + r;
    if (S->phold) {
        *np = S->pnc[2 * i];
        *nn = S->pnc[2 * i + 1];
        *xp = zp - S->pk[2 * i];
        *xn = zn - S->pk[2 * i + 1];
    } else {
        double e1 = m->eps - 1.0;
        *xp = zp - floor(zp);
        *xn = zn - floor(zn);
        *np = *xp < e1 ? 2 : 1;
        *nn = *xn < e1 ? 2 : 1;
    }
    if (P->wave) {
        *kp = (*np == 2 ? 2.0 : 1.0) / m->eps;
        *kn = (*nn == 2 ? 2.0 : 1.0) / m->eps;
    } else {
        *kp = *kn = 1.0;
    }
}

/* MeshPhase.mode of every mesh at y (events.phase_mode) */
MK_HIDDEN void mk_phase_mode(const MkParams *P, const MkState *S, const double *y, double *pk, int64_t *pnc) {
    double psiB, th1, th2;
    mk_relative_angles(S, P, y, &psiB, &th1, &th2);
    double us[3] = {P->rbA * y[PSI], P->rbB * psiB, P->rb1 * th1};
    for (int i = 0; i < 3; i++) {
        const MkMesh *m = &P->md[i];
        double r = m->sigma * us[i] / m->pb;
        double zp = m->xi0 - r, zn = m->xi0c + r, e1 = m->eps - 1.0;
        double kp = floor(zp), kn = floor(zn);
        pk[2 * i] = kp;
        pnc[2 * i] = zp - kp < e1 ? 2 : 1;
        pk[2 * i + 1] = kn;
        pnc[2 * i + 1] = zn - kn < e1 ? 2 : 1;
    }
}

static inline __attribute__((always_inline)) void flank_law(const MkParams *P, const MkMesh *m, double p, double v, double kf, double *out) {
    if (P->law == LAW_IMPACT) impact(p, v, m->K * kf, P->e, P->C, P->dmax, out);
    else elasto_backlash(p, v, m->k * kf, m->c, out);
}

static inline __attribute__((always_inline)) Force mesh_force(const MkParams *P, const MkState *S, int i, const MkMesh *m, double d, double dd, double u) {
    double xp, xn, kp, kn, o[4];
    int64_t np, nn;
    Force f;
    phase(P, S, i, m, u, &xp, &xn, &kp, &kn, &np, &nn);
    if (P->law == LAW_BILATERAL) {
        double kk = d >= 0.0 ? m->k * kp : m->k * kn;
        f.F = kk * d + m->c * dd; f.dF_dd = kk; f.dF_dv = m->c; f.Fc = kk * d;
        if (d >= 0.0) { f.xi = xp; f.nc = np; f.sx = -m->sigma; }
        else { f.xi = xn; f.nc = nn; f.sx = m->sigma; }
        return f;
    }
    if (d > 0.0) {
        flank_law(P, m, d, dd, kp, o);
        f.F = o[0]; f.dF_dd = o[1]; f.dF_dv = o[2]; f.Fc = o[3]; f.xi = xp; f.nc = np; f.sx = -m->sigma;
        return f;
    }
    double pen = -(d + m->jn);
    if (pen > 0.0) {
        flank_law(P, m, pen, -dd, kn, o);
        f.F = -o[0]; f.dF_dd = o[1]; f.dF_dv = o[2]; f.Fc = -o[3]; f.xi = xn; f.nc = nn; f.sx = m->sigma;
        return f;
    }
    f.F = f.dF_dd = f.dF_dv = f.Fc = 0.0; f.xi = xp; f.nc = np; f.sx = -m->sigma;
    return f;
}

MK_HIDDEN double mk_law_potential(const MkParams *P, const MkMesh *m, double d, double kp, double kn) {
    if (P->law == LAW_IMPACT) {
        if (d > 0.0) return impact_potential(d, m->K * kp, P->e);
        return impact_potential(-(d + m->jn), m->K * kn, P->e);
    }
    if (P->law == LAW_BILATERAL) return 0.5 * m->k * (d >= 0.0 ? kp : kn) * d * d;
    if (d > 0.0) return 0.5 * m->k * kp * d * d;
    double pen = -(d + m->jn);
    return pen > 0.0 ? 0.5 * m->k * kn * pen * pen : 0.0;
}

/* FlankFriction.moments with nc pairs in contact (the lever arms' derivatives by the contact position too) */
static Moments flank_moments(const MkParams *P, const MkMesh *m, double F, double xi, double W1_, double W2_,
                             int64_t ncp) {
    Moments r = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    if (F == 0.0) return r;
    double x0 = xi * m->pb;
    int nc = (int)ncp;
    double aF = fabs(F), sF = F > 0.0 ? 1.0 : -1.0, share = aF / nc, x = x0, dW = W1_ - W2_;
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
        double gx = g * dW;
        r.dM1x -= gx * l1 + mu * share;
        r.dM2x -= gx * l2 - mu * share;
        x += m->pb;
    }
    return r;
}

/* MeshDifferential._pin_force: the pin friction load |R_0| + |R_L| (planar: |F_pin|, end L skipped)
 * and its derivatives by Fs and F12 */
static void pin_force(const MkParams *P, const double *g, int i, double Fs, double F12, double *mag, double *dS,
                      double *d12) {
    const double *q = P->pin_ends[i];   /* end 0: tx, ty, rx, ry, ux, uy, qx, qy, w0; end L (9..17) */
    double aS = fabs(Fs), a12 = fabs(F12);
    double gx = g[2 * i], gy = g[2 * i + 1];
    double fx = Fs * q[0] + aS * q[2] + F12 * q[4] + a12 * q[6] + q[8] * gx;
    double fy = Fs * q[1] + aS * q[3] + F12 * q[5] + a12 * q[7] + q[8] * gy;
    double mg = sqrt(fx * fx + fy * fy);
    double sgS = Fs >= 0.0 ? 1.0 : -1.0, sg12 = F12 >= 0.0 ? 1.0 : -1.0;
    double tot, dtS, dt12;
    if (mg == 0.0) {
        tot = dtS = dt12 = 0.0;
    } else {
        tot = mg;
        dtS = (fx * (q[0] + sgS * q[2]) + fy * (q[1] + sgS * q[3])) / mg;
        dt12 = (fx * (q[4] + sg12 * q[6]) + fy * (q[5] + sg12 * q[7])) / mg;
    }
    if (P->pin3d[i]) {
        const double *r = q + 9;
        fx = Fs * r[0] + aS * r[2] + F12 * r[4] + a12 * r[6] + r[8] * gx;
        fy = Fs * r[1] + aS * r[3] + F12 * r[5] + a12 * r[7] + r[8] * gy;
        mg = sqrt(fx * fx + fy * fy);
        if (mg != 0.0) {
            tot += mg;
            dtS += (fx * (r[0] + sgS * r[2]) + fy * (r[1] + sgS * r[3])) / mg;
            dt12 += (fx * (r[4] + sg12 * r[6]) + fy * (r[5] + sg12 * r[7])) / mg;
        }
    }
    *mag = tot;
    *dS = dtS;
    *d12 = dt12;
}

/* forces._slipping_pin: a slipping planet's pin friction moment -s cap; its derivatives by the sun
 * mesh's force (column sun of the planet's row Cp) and the planet mesh's (column 2) added to that row,
 * at the sliding lever cd */
static inline double slipping_pin(double *Cp, int sun, int s, double cap, double cd, double dpS, double dp12) {
    Cp[sun] -= s * cd * dpS;
    Cp[2] -= s * cd * dp12;
    return -s * cap;
}

MK_HIDDEN void mk_relative_angles(const MkState *S, const MkParams *P, const double *y, double *psiB, double *th1, double *th2) {
    double t1 = (S->dA0 - y[DA] - P->rbA * y[PSI]) / P->rb1;
    double t2 = (y[D12] - S->d120 - P->rb1 * t1) / P->rb2;
    *psiB = (S->dB0 - y[DB] - P->rb2 * t2) / P->rbB;
    *th1 = t1;
    *th2 = t2;
}

/* forces.evaluate: f = y'(y); J rows 4.. (and WC) if J != NULL (row-major NxN); side values sv */
MK_HIDDEN void mk_eval(const MkParams *P, const MkState *S, const double *y, double *f, double *J, double *sv) {
    const int N = (int)P->N;
    const int n = (int)P->n;
    const double W[4] = {y[VA], y[VB], y[W1], y[W2]};
    double us[3] = {0.0, 0.0, 0.0};
    if (P->tracked) {
        double psiB, th1, th2;
        mk_relative_angles(S, P, y, &psiB, &th1, &th2);
        us[0] = P->rbA * y[PSI]; us[1] = P->rbB * psiB; us[2] = P->rb1 * th1;
    }
    double dds[3];
    Force mf[3];
    for (int i = 0; i < 3; i++) {
        const MkMesh *m = &P->md[i];
        dds[i] = m->a1 * W[m->g1] + m->a2 * W[m->g2];
        mf[i] = mesh_force(P, S, i, m, y[m->d], dds[i], us[i]);
    }
    double FA = mf[0].F, FB = mf[1].F, F12 = mf[2].F;
    double Pw = n * ((FA - mf[0].Fc) * dds[0] + (FB - mf[1].Fc) * dds[1] + (F12 - mf[2].Fc) * dds[2]);
    const double rbA = P->rbA, rb1 = P->rb1, rbB = P->rbB, rb2 = P->rb2;
    double Q[4] = {rbA * FA, rbB * FB, rb1 * (FA - F12), rb2 * (FB - F12)};
    double C[4][3] = {{rbA, 0.0, 0.0}, {0.0, rbB, 0.0}, {rb1, 0.0, -rb1}, {0.0, rb2, -rb2}};
    double G[4][4], Lx[4][4];   /* flank friction: velocity coefficients; lever arms on (psi_A, d_A1, d_B2, d_12) */
    if (P->flank) {             /* (G and Lx are read only with flank friction) */
        memset(G, 0, sizeof G);
        memset(Lx, 0, sizeof Lx);
        double Pf = 0.0;
        /* layout.roll_gradients: d(u_A1, u_B2, u_12)/d(psi_A, d_A1, d_B2, d_12) */
        const double du[3][4] = {{rbA, 0.0, 0.0, 0.0}, {-rbA, -1.0, -1.0, -1.0}, {-rbA, -1.0, 0.0, 0.0}};
        for (int i = 0; i < 3; i++) {
            const MkMesh *m = &P->md[i];
            int g1 = (int)m->g1, g2 = (int)m->g2;
            Moments fm = flank_moments(P, m, mf[i].F, mf[i].xi, W[g1], W[g2], mf[i].nc);
            double a1 = fm.dM1x * mf[i].sx, a2 = fm.dM2x * mf[i].sx;
            for (int k = 0; k < 4; k++) {
                Lx[g1][k] += a1 * du[i][k];
                Lx[g2][k] += a2 * du[i][k];
            }
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
    double cap1 = 0.0, cap2 = 0.0, cp = P->c_pin, cd = P->c_pind, dp1S = 0.0, dp112 = 0.0, dp2S = 0.0, dp212 = 0.0;
    int stuck1 = 0, stuck2 = 0;
    if (P->pin) {
        double Fp1, Fp2;
        pin_force(P, S->gpin, 0, FA, F12, &Fp1, &dp1S, &dp112);
        pin_force(P, S->gpin, 1, FB, F12, &Fp2, &dp2S, &dp212);
        stuck1 = s1 == 0;
        stuck2 = s2 == 0;
        /* the limit of each pin's friction in its mode: static (c_pin) stuck, sliding (c_pind) slipping */
        cap1 = (stuck1 ? cp : cd) * Fp1 + P->M01;
        cap2 = (stuck2 ? cp : cd) * Fp2 + P->M02;
    }
    double Q1nf = Q1, Q2nf = Q2, M1 = 0.0, M2 = 0.0;
    if (P->pin) {
        if (!stuck1) {
            M1 = slipping_pin(C[2], 0, s1, cap1, cd, dp1S, dp112);
            Q1 += M1;
            Pw += n * fabs(M1 * W[2]);
        }
        if (!stuck2) {
            M2 = slipping_pin(C[3], 1, s2, cap2, cd, dp2S, dp212);
            Q2 += M2;
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
    double rows[4][7], rpsi[4] = {0.0, 0.0, 0.0, 0.0};
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
        if (P->flank) {
            r[0] += sc * Lx[g][1];
            r[1] += sc * Lx[g][2];
            r[2] += sc * Lx[g][3];
            rpsi[g] = sc * Lx[g][0];
        }
    }
    double gacp = 0.0;
    double gac[7] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    if (!P->speed_drive) {
        for (int k = 0; k < 7; k++) {
            double a = rows[0][k] + rows[1][k];
            if (!stuck1) a += n * rows[2][k];
            if (!stuck2) a += n * rows[3][k];
            gac[k] = -a / Jeff;
            J[WC * N + 1 + k] = gac[k];
        }
        if (P->flank) {
            double a = rpsi[0] + rpsi[1];
            if (!stuck1) a += n * rpsi[2];
            if (!stuck2) a += n * rpsi[3];
            gacp = -a / Jeff;
            J[WC * N] = gacp;
        }
    }
    double iA = 1.0 / P->JA, iB = 1.0 / P->JB, i1 = 1.0 / P->J1, i2 = 1.0 / P->J2;
    for (int k = 0; k < 7; k++) {
        J[VA * N + 1 + k] = rows[0][k] * iA - gac[k];
        J[VB * N + 1 + k] = rows[1][k] * iB - gac[k];
        J[W1 * N + 1 + k] = stuck1 ? 0.0 : rows[2][k] * i1 - gac[k];
        J[W2 * N + 1 + k] = stuck2 ? 0.0 : rows[3][k] * i2 - gac[k];
    }
    if (P->flank) {           /* the column of psi_A (only the lever arms depend on it) */
        J[VA * N] = rpsi[0] * iA - gacp;
        J[VB * N] = rpsi[1] * iB - gacp;
        J[W1 * N] = stuck1 ? 0.0 : rpsi[2] * i1 - gacp;
        J[W2 * N] = stuck2 ? 0.0 : rpsi[3] * i2 - gacp;
    }
}
