/* The compiled communication step of the differential owning its half-shafts with the rigid inner
 * model (spurdiff.differential.shafts.ShaftedDifferential._do_step with the sub-step solve of
 * spurdiff.differential.shaft_solver and the rigid model's step, spurdiff.differential.rigid).
 *
 * A transcription of the Python reference, which stays the specification and the fallback: the same
 * operations in the same order (compiled with -ffp-contract=off, no fused multiply-adds), so the two
 * agree bit for bit (tests/physics/test_shaft_kernel.py). The rigid level's pin-load solve is not
 * copied: it is called, rk_slip and rk_step_slip of rigid_kernel.c, through the function pointers
 * the binding passes (the rigid kernel library it loaded; this library does not link it, so either
 * can be rebuilt alone).
 *
 * Covered: the pin-load locking law (the rigid model's _exact with its compiled kernel), either
 * carrier drive, the static / dynamic split of the pin friction (the stuck path and the break-away
 * test at the static lever, constant 4; the slip path at the sliding lever, constant 53, in
 * rk_slip; the slip solve of a break-away from stuck at the static lever, as the shafted model sets
 * rigid.py's c_break), the planets' speed loads (centrifugal at the step's start speed, tangential at the
 * carrier acceleration held over the step: set_speed_loads, as RigidDifferential.do_step), the
 * stuck path (the planets' F_12 intervals, rigid_stuck_exact below: a transcription of
 * rigid_pinload.PinLoadLaw._stuck_exact/_planet_interval/_capacity, kept apart so the pin law's
 * changes are applied in one place), the slip path (rk_slip / rk_step_slip), mode switches, the
 * sub-steps, the Newton/Broyden iteration with its finite-difference Jacobian and its cache per
 * mode, the halving, the end-of-step outputs (q_end_L/R with them). Anything else (an error the Python code raises, a
 * state this layout cannot hold) returns SK_FALLBACK with the caller's arrays unchanged: the caller
 * then runs the Python reference from the same state.
 *
 * Arrays (doubles; layouts named in spurdiff/differential/shaft_kernel.py, which packs them):
 *   sc  constants of the shafts and the rigid model (SC_*), set once per initialized model;
 *   k   the rigid kernel's constants (RK_NCONST, rigid_kernel.c's layout; the speed loads 49..52 and
 *       54..57 written on success);
 *   rs  the rigid model's state (R_*), ss the shafts' state (S_*), in: the step's inputs (I_*);
 *   fp  two function pointers: rk_slip, rk_step_slip.
 *
 * Over 800 lines: it is one transcription of one Python step (shafts, solver, rigid model's mode
 * logic and stuck path), kept in one translation unit so that its order of operations can be read
 * against the reference side by side; the stuck path's 3-D journal (issue 41) added its solve here;
 * and the native steps at the end (sk_native with the half-shafts, sk_rigid_native without them)
 * call its static transcription of the rigid step: splitting would export Ctx and the R_* layout.
 */
#include <math.h>
#include <stdint.h>
#include <string.h>

#define SK_ABI 4
#define SK_OK 0
#define SK_FALLBACK 1
#define SK_NOTCONV 2
#define RK_NCONST 94

typedef int64_t (*rk_fn)(const double *k, double *io);

/* the rigid model's state: RigidDifferential's _STATE_KEYS, its inputs and _last_h */
enum {
    R_T, R_WC, R_WD, R_PHIC, R_PHID, R_AC, R_AD, R_QF, R_SD, R_F12, R_CAP,
    R_HAS_ADG, R_ADG,                                   /* _ad_guess (flag: not None) */
    R_HAS_SK, R_SK_S, R_SK_HAS_ACG, R_SK_ACG, R_SK_TAUC, R_SK_TAUL, R_SK_TAUR, R_SK_GWC, R_SK_GAC, /* _slip_key */
    R_SV_AC, R_SV_AD, R_SV_QF, R_SV_S, R_SV_F12, R_SV_CAP,                              /* _slip_val */
    R_WORK, R_LOSS, R_LOSS_LAST, R_NSW, R_NSTEPS, R_G1X, R_G1Y, R_G2X, R_G2Y, R_GWC,    /* _g, _g_wc */
    R_GT1X, R_GT1Y, R_GT2X, R_GT2Y, R_GAC,                                              /* _gt, _g_ac */
    R_WREF, R_TAUC, R_TAUL, R_TAUR, R_LASTH, RS_N
};
/* the shafts' state: ShaftedDifferential's _STATE_KEYS without jac, the wheel sides' tyre-torque
 * deviations at the end of the step (q_end_L, q_end_R: written, not read), then the Jacobian cache:
 * 8 mode slots (index: slip direction +1, -1, +0, -0, plus 4 when the mode switched inside), each a
 * flag and S_n (4) */
enum {
    S_T, S_OFFL, S_OFFR, S_THL, S_THR, S_TL, S_TR, S_TMEANL, S_TMEANR, S_TENDL, S_TENDR, S_WWHEELS,
    S_WSUNS, S_LOSS, S_PE0, S_NSTEPS, S_NSUB, S_NEVALS, S_NJAC, S_NHALV, S_DWPL, S_DWPR, S_QENDL, S_QENDR, S_JAC,
    SS_N = S_JAC + 8 * 5
};
/* constants: the shafts (c, d each side, h_max), the accepted residual, the carrier drive, the
 * planets' centrifugal constants (rigid.py's _cf) and tangential constants (_ct) */
enum {
    SC_CL, SC_DL, SC_CR, SC_DR, SC_HMAX, SC_ACCEPT, SC_SPEED, SC_CF1X, SC_CF1Y, SC_CF2X, SC_CF2Y,
    SC_CT1X, SC_CT1Y, SC_CT2X, SC_CT2Y, SC_N
};
/* inputs: time, step, wheel-side angles and speeds, the wheel surrogates (a_free inv_J dadw q_rate c_t r_t) */
enum { I_T, I_H, I_PL, I_WL, I_PR, I_WR, I_ML, I_MR = I_ML + 6, IN_N = I_MR + 6 };

int64_t sk_abi(void) { return SK_ABI; }
int64_t sk_nrs(void) { return RS_N; }
int64_t sk_nss(void) { return SS_N; }
int64_t sk_nsc(void) { return SC_N; }
int64_t sk_nin(void) { return IN_N; }

typedef struct {
    const double *sc;
    double k[RK_NCONST];
    rk_fn slip, step_slip;
    const double *mL, *mR;
    double *ss;           /* the shafts' working state */
    int break_slide;      /* 1: a break-away slips at the sliding lever (the plain rigid model's c_break) */
    const double *pp;     /* NULL: the pin-load law; else the linear capacity's constants (PP_*, rigid_paper) */
} Ctx;

/* ------------------------------------------------------------------ the rigid model (rigid.py) */

static inline double py_max(double a, double b) { return b > a ? b : a; }   /* Python's max(a, b) */
static inline double py_min(double a, double b) { return b < a ? b : a; }   /* Python's min(a, b) */

/* the rigid kernel's speed-load constants (49..52 centrifugal, 54..57 tangential) from the state */
static void speed_load_constants(Ctx *c, const double *s)
{
    c->k[49] = s[R_G1X]; c->k[50] = s[R_G1Y]; c->k[51] = s[R_G2X]; c->k[52] = s[R_G2Y];
    c->k[54] = s[R_GT1X]; c->k[55] = s[R_GT1Y]; c->k[56] = s[R_GT2X]; c->k[57] = s[R_GT2Y];
}

/* PinLoadLaw._set_speed_loads: centrifugal at the carrier speed wc, tangential at its acceleration alpha */
static void set_speed_loads(Ctx *c, double *s, double wc, double alpha)
{
    if (wc == s[R_GWC] && alpha == s[R_GAC])
        return;
    if (wc != s[R_GWC]) {
        const double w2 = wc * wc;
        const double *cf = c->sc + SC_CF1X;
        s[R_G1X] = cf[0] * w2; s[R_G1Y] = cf[1] * w2; s[R_G2X] = cf[2] * w2; s[R_G2Y] = cf[3] * w2;
        s[R_GWC] = wc;
    }
    if (alpha != s[R_GAC]) {
        const double *ct = c->sc + SC_CT1X;
        s[R_GT1X] = ct[0] * alpha; s[R_GT1Y] = ct[1] * alpha; s[R_GT2X] = ct[2] * alpha; s[R_GT2Y] = ct[3] * alpha;
        s[R_GAC] = alpha;
    }
    speed_load_constants(c, s);
}

/* PinLoadLaw._slip_exact through the compiled solve (rk_slip): (ac, ad, Q_f), F12 and cap set */
static void slip_exact(Ctx *c, double *s, int given, double ac_given, double sd, double *ac, double *ad, double *Qf)
{
    double io[12];
    io[0] = sd; io[1] = given ? 1.0 : 0.0; io[2] = given ? ac_given : 0.0; io[3] = s[R_TAUC]; io[4] = s[R_TAUL];
    io[5] = s[R_TAUR]; io[6] = s[R_HAS_ADG] != 0.0 ? s[R_ADG] : 0.0; io[7] = s[R_F12];
    c->slip(c->k, io);
    *ac = io[8];
    *ad = io[9];
    s[R_F12] = io[10];
    s[R_CAP] = io[11];
    *Qf = -sd * io[11];
}

/* ---- the stuck path: PinLoadLaw._capacity, _planet_interval, _stuck_exact (rigid_pinload.py as on
 * main: the static lever mu_pin r_d, the rigid kernel's constant 4, and the planets' centrifugal and
 * tangential forces, added in that order, in the pin force) ---- */

/* PinLoadLaw._pin_load: planet i's pin friction load |R_0| + |R_L| with its inertial forces (the
 * rigid kernel's constants: end 0 at 17 / 33, end L at 58 / 74, the shares at 90..93), and its
 * derivative by F12 */
static double stuck_pin_load(const Ctx *c, const double *s, int i, double Fs, double F12, double *d12)
{
    const double aS = fabs(Fs), a12 = fabs(F12);
    const double gx = s[R_G1X + 2 * i], gy = s[R_G1X + 2 * i + 1];
    const double hx = s[R_GT1X + 2 * i], hy = s[R_GT1X + 2 * i + 1];
    double tot = 0.0, d = 0.0;
    for (int e = 0; e < 2; e++) {
        const double *p = c->k + (e == 0 ? (i == 0 ? 17 : 33) : (i == 0 ? 58 : 74));
        const double w = c->k[90 + 2 * i + e];
        const double fx = Fs * p[0] + aS * p[2] + F12 * p[4] + a12 * p[6] + w * gx + w * hx;
        const double fy = Fs * p[1] + aS * p[3] + F12 * p[5] + a12 * p[7] + w * gy + w * hy;
        const double mag = sqrt(fx * fx + fy * fy);
        if (mag != 0.0) {
            tot = tot + mag;
            d = d + (F12 >= 0.0 ? (fx * p[12] + fy * p[13]) / mag : (fx * p[14] + fy * p[15]) / mag);
        }
    }
    *d12 = d;
    return tot;
}

static double stuck_capacity(const Ctx *c, const double *s, int i, double Fs, double F12)
{
    double d12;
    return c->k[4] * stuck_pin_load(c, s, i, Fs, F12, &d12) + c->k[5 + i];
}

/* PinLoadLaw._planet_interval_3d: a planet whose pin carries a couple (end L not zero) */
static void stuck_planet_interval_3d(const Ctx *c, const double *s, int i, double Fs, double ac, double *lo_out,
                                     double *hi_out)
{
    const double *k = c->k;
    const double rb = k[i], J = k[10 + i], M0 = k[5 + i], cl = k[4];
    const double Fstar = Fs - J * ac / rb;
    double dP;
    const double cap0 = cl * stuck_pin_load(c, s, i, Fs, Fstar, &dP) + M0;
    if (cap0 <= 0.0) {
        *lo_out = *hi_out = Fstar;
        return;
    }
    const double width = cap0 / (rb - cl);
    double ends[2];
    for (int e = 0; e < 2; e++) {
        const double sign = e == 0 ? 1.0 : -1.0;
        double lo = sign > 0.0 ? Fstar : Fstar - width, hi = sign > 0.0 ? Fstar + width : Fstar;
        double F = Fstar + sign * cap0 / rb;
        for (int it = 0; it < 100; it++) {
            const double P = stuck_pin_load(c, s, i, Fs, F, &dP);
            const double h = rb * (F - Fstar) - sign * (cl * P + M0);
            if (h == 0.0)
                break;
            if (h > 0.0)
                hi = F;
            else
                lo = F;
            const double step = h / (rb - sign * cl * dP);
            double Fn = F - step;
            if (!(lo < Fn && Fn < hi))
                Fn = 0.5 * (lo + hi);
            if (fabs(Fn - F) <= 1e-15 * (fabs(F) + fabs(Fstar)) + 1e-300) {
                F = Fn;
                break;
            }
            F = Fn;
        }
        ends[e] = F;
    }
    *lo_out = ends[1];
    *hi_out = ends[0];
}

static void stuck_planet_interval(const Ctx *c, const double *s, int i, double Fs, double ac, double *lo, double *hi)
{
    const double *k = c->k;
    int planar = k[91 + 2 * i] == 0.0;          /* PinLoadLaw._planar: end L's share and constants all 0 */
    for (int j = 0; j < 8; j++)
        planar = planar && k[(i == 0 ? 58 : 74) + j] == 0.0;
    if (!planar) {
        stuck_planet_interval_3d(c, s, i, Fs, ac, lo, hi);
        return;
    }
    const double rb = k[i], J = k[10 + i], M0 = k[5 + i];
    const double *p = k + (i == 0 ? 17 : 33);
    const double tx = p[0], ty = p[1], rx = p[2], ry = p[3], Px = p[12], Py = p[13], Nx = p[14], Ny = p[15];
    const double cl = k[4];
    const double Fstar = Fs - J * ac / rb;
    const double cap0 = stuck_capacity(c, s, i, Fs, Fstar);
    if (cap0 <= 0.0) {
        *lo = *hi = Fstar;
        return;
    }
    const double aS = fabs(Fs);
    const double gx = s[R_G1X + 2 * i], gy = s[R_G1X + 2 * i + 1];
    const double hx = s[R_GT1X + 2 * i], hy = s[R_GT1X + 2 * i + 1];
    const double ax = Fs * tx + aS * rx + gx + hx, ay = Fs * ty + aS * ry + gy + hy;
    const double c_a0 = cl * sqrt(ax * ax + ay * ay);
    double ends[2];
    for (int e = 0; e < 2; e++) {
        const double sign = e == 0 ? 1.0 : -1.0;
        const double kk = rb * Fstar + sign * M0;
        if (cl == 0.0) {
            ends[e] = kk / rb;
            continue;
        }
        double vx, vy;
        if (-rb * Fstar - sign * (c_a0 + M0) <= 0.0) {
            vx = Px; vy = Py;
        } else {
            vx = Nx; vy = Ny;
        }
        const double vv = vx * vx + vy * vy;
        const double alpha = rb * rb - cl * cl * vv;
        const double beta = rb * kk + cl * cl * (ax * vx + ay * vy);
        const double gamma = kk * kk - cl * cl * (ax * ax + ay * ay);
        const double wx = rb * ax + kk * vx, wy = rb * ay + kk * vy;
        const double cross = ax * vy - ay * vx;
        const double disc = cl * cl * (wx * wx + wy * wy - cl * cl * cross * cross);
        const double root = disc > 0.0 ? sqrt(disc) : 0.0;
        const double q = beta + copysign(root, beta);
        if (q == 0.0) {
            ends[e] = 0.0;
            continue;
        }
        const double r1 = q / alpha, r2 = gamma / q;
        ends[e] = sign > 0.0 ? py_max(r1, r2) : py_min(r1, r2);
    }
    *lo = ends[1];
    *hi = ends[0];
}

/* Can both planets hold (a_d = 0)? Sets F12 and cap to the reported stuck values. */
static int rigid_stuck_exact(const Ctx *c, double *s, double ac)
{
    const double *k = c->k;
    const double rb1 = k[0], rb2 = k[1];
    const double ad = 0.0;
    const double FA = (k[7] * (ac + ad) - s[R_TAUL]) / k[2];
    const double FB = (k[8] * (ac + k[9] * ad) - s[R_TAUR]) / k[3];
    double lo1, hi1, lo2, hi2;
    stuck_planet_interval(c, s, 0, FA, ac, &lo1, &hi1);
    stuck_planet_interval(c, s, 1, FB, ac, &lo2, &hi2);
    const double lo = py_max(lo1, lo2), hi = py_min(hi1, hi2);
    const double tol = 1e-10 * (fabs(FA) + fabs(FB) + fabs(hi) + fabs(lo)) + 1e-300;
    if (lo > hi + tol)
        return 0;
    const double F1s = FA - k[10] * ac / rb1, F2s = FB - k[11] * ac / rb2;
    double F12 = (rb1 * rb1 * F1s + rb2 * rb2 * F2s) / (rb1 * rb1 + rb2 * rb2);
    F12 = lo <= hi ? py_min(py_max(F12, lo), hi) : 0.5 * (lo + hi);
    s[R_F12] = F12;
    s[R_CAP] = k[16] * (fabs(k[12]) * stuck_capacity(c, s, 0, FA, F12) + fabs(k[13]) * stuck_capacity(c, s, 1, FB, F12));
    return 1;
}

/* ---- PinLoadLaw._accelerations_exact: (ac, ad, Q_f, slip direction) in the state s ---- */
static void accelerations(Ctx *c, double *s, int given, double ac_given, double out[4])
{
    const double *k = c->k;
    if (s[R_WD] != 0.0) {
        const double sd = copysign(1.0, s[R_WD]);
        if (s[R_HAS_SK] != 0.0 && s[R_SK_S] == sd && (s[R_SK_HAS_ACG] != 0.0) == (given != 0)
            && (!given || s[R_SK_ACG] == ac_given) && s[R_SK_TAUC] == s[R_TAUC] && s[R_SK_TAUL] == s[R_TAUL]
            && s[R_SK_TAUR] == s[R_TAUR] && s[R_SK_GWC] == s[R_GWC] && s[R_SK_GAC] == s[R_GAC]) {
            out[0] = s[R_SV_AC]; out[1] = s[R_SV_AD]; out[2] = s[R_SV_QF]; out[3] = s[R_SV_S];
            s[R_F12] = s[R_SV_F12]; s[R_CAP] = s[R_SV_CAP];
            return;
        }
        double ac, ad, Qf;
        slip_exact(c, s, given, ac_given, sd, &ac, &ad, &Qf);
        s[R_HAS_ADG] = 1.0; s[R_ADG] = ad;
        s[R_HAS_SK] = 1.0; s[R_SK_S] = sd; s[R_SK_HAS_ACG] = given ? 1.0 : 0.0; s[R_SK_ACG] = given ? ac_given : 0.0;
        s[R_SK_TAUC] = s[R_TAUC]; s[R_SK_TAUL] = s[R_TAUL]; s[R_SK_TAUR] = s[R_TAUR]; s[R_SK_GWC] = s[R_GWC];
        s[R_SK_GAC] = s[R_GAC];
        s[R_SV_AC] = ac; s[R_SV_AD] = ad; s[R_SV_QF] = Qf; s[R_SV_S] = sd; s[R_SV_F12] = s[R_F12]; s[R_SV_CAP] = s[R_CAP];
        out[0] = ac; out[1] = ad; out[2] = Qf; out[3] = sd;
        return;
    }
    const double Fd = s[R_TAUL] + k[9] * s[R_TAUR];
    const double ac = given ? ac_given : (s[R_TAUC] + s[R_TAUL] + s[R_TAUR]) / k[15];
    const double Q_req = k[14] * ac - Fd;
    const double F12_prev = s[R_F12];
    if (rigid_stuck_exact(c, s, ac)) {
        out[0] = ac; out[1] = 0.0; out[2] = Q_req; out[3] = 0.0;
        return;
    }
    const double sd = -copysign(1.0, Q_req);
    s[R_HAS_ADG] = 1.0; s[R_ADG] = 0.0;
    double ac_s, ad_s, Qf;
    /* the break-away solve at the static lever (constant 4; rigid_pinload's c_break, which the shafted
     * model sets to it): this inner step slips at it, the next ones at the sliding lever (constant 53) */
    const double c_slide = c->k[53];
    if (!c->break_slide)
        c->k[53] = c->k[4];
    slip_exact(c, s, given, ac_given, sd, &ac_s, &ad_s, &Qf);
    c->k[53] = c_slide;
    if (ad_s * sd > 0.0) {
        s[R_ADG] = ad_s;
        out[0] = ac_s; out[1] = ad_s; out[2] = Qf; out[3] = sd;
        return;
    }
    s[R_F12] = F12_prev == F12_prev ? F12_prev : s[R_F12];
    out[0] = ac; out[1] = 0.0; out[2] = copysign(s[R_CAP], Q_req); out[3] = 0.0;
}

/* RigidDifferential._advance */
static void rigid_advance(const Ctx *c, double *s, double dt, double ac, double ad, double Qf)
{
    if (dt <= 0.0)
        return;
    const double *k = c->k;
    const double wc0 = s[R_WC], wd0 = s[R_WD];
    const double wc1 = wc0 + ac * dt, wd1 = wd0 + ad * dt;
    s[R_PHIC] += 0.5 * (wc0 + wc1) * dt;
    s[R_PHID] += 0.5 * (wd0 + wd1) * dt;
    const double tau_drive = c->sc[SC_SPEED] != 0.0 ? k[15] * ac + k[14] * ad - s[R_TAUL] - s[R_TAUR] : s[R_TAUC];
    const double mean_wc = 0.5 * (wc0 + wc1), mean_wd = 0.5 * (wd0 + wd1);
    s[R_WORK] += dt * (tau_drive * mean_wc + s[R_TAUL] * (mean_wc + mean_wd) + s[R_TAUR] * (mean_wc + k[9] * mean_wd));
    s[R_LOSS] += dt * fabs(Qf * mean_wd);
    s[R_WC] = wc1;
    s[R_WD] = wd1;
}

/* ---- the linear capacity K |T_0| + T_pre (lockingLaw = paper, or no pin-load solve: rigid.py's
 * _accelerations, _slip_accelerations, _solve_slip, _T0), for the native step without half-shafts;
 * its constants pp: */
enum { PP_K, PP_KSLIDE, PP_KBREAK, PP_PRE, PP_MDD, PP_DA, PP_DB, PP_R1, PP_CA, PP_D0, PP_SHARE, PP_N };

static double paper_T0(const Ctx *c, const double *s, double ac, double ad)
{
    const double *k = c->k;
    return (k[7] * (ac + ad) - s[R_TAUL]) + (k[8] * (ac + k[9] * ad) - s[R_TAUR]);
}

static void paper_solve_slip(const Ctx *c, const double *s, int given, double ac_given, double sd, double sigma,
                             double K, double *ac, double *ad)
{
    const double *k = c->k, *pp = c->pp;
    const double kf = sd * K * sigma;
    const double Fd = s[R_TAUL] + k[9] * s[R_TAUR] - sd * pp[PP_PRE];
    const double alpha0 = -s[R_TAUL] - s[R_TAUR];
    const double alpha_c = k[7] + k[8];
    const double beta = k[7] + k[9] * k[8];
    if (given) {
        *ac = ac_given;
        *ad = (Fd - k[14] * ac_given - kf * (alpha0 + alpha_c * ac_given)) / (pp[PP_MDD] + kf * beta);
        return;
    }
    const double Qc = s[R_TAUC] + s[R_TAUL] + s[R_TAUR];
    const double a11 = k[15], a12 = k[14], b1 = Qc;
    const double a21 = k[14] + kf * alpha_c, a22 = pp[PP_MDD] + kf * beta, b2 = Fd - kf * alpha0;
    const double det = a11 * a22 - a12 * a21;
    *ac = (b1 * a22 - a12 * b2) / det;
    *ad = (a11 * b2 - a21 * b1) / det;
}

static void paper_slip(const Ctx *c, const double *s, int given, double ac_given, double sd, double K, double out[3])
{
    double ac, ad;
    for (int i = 0; i < 2; i++) {
        const double sigma = i == 0 ? 1.0 : -1.0;
        paper_solve_slip(c, s, given, ac_given, sd, sigma, K, &ac, &ad);
        const double T0 = paper_T0(c, s, ac, ad);
        if (T0 * sigma >= 0.0) {
            out[0] = ac; out[1] = ad; out[2] = -sd * (K * fabs(T0) + c->pp[PP_PRE]);
            return;
        }
    }
    paper_solve_slip(c, s, given, ac_given, sd, 0.0, K, &ac, &ad);   /* T0 changes sign: preload only */
    out[0] = ac; out[1] = ad; out[2] = -sd * c->pp[PP_PRE];
}

static void paper_accelerations(const Ctx *c, const double *s, int given, double ac_given, double out[4])
{
    const double *k = c->k, *pp = c->pp;
    double r[3];
    if (s[R_WD] != 0.0) {
        const double sd = copysign(1.0, s[R_WD]);
        paper_slip(c, s, given, ac_given, sd, pp[PP_KSLIDE], r);
        out[0] = r[0]; out[1] = r[1]; out[2] = r[2]; out[3] = sd;
        return;
    }
    const double Fd = s[R_TAUL] + k[9] * s[R_TAUR];
    const double ac = given ? ac_given : (s[R_TAUC] + s[R_TAUL] + s[R_TAUR]) / k[15];
    const double Q_req = k[14] * ac - Fd;
    const double cap = pp[PP_K] * fabs(paper_T0(c, s, ac, 0.0)) + pp[PP_PRE];
    if (fabs(Q_req) <= cap * (1.0 + 1e-12)) {
        out[0] = ac; out[1] = 0.0; out[2] = Q_req; out[3] = 0.0;
        return;
    }
    const double sd = -copysign(1.0, Q_req);
    paper_slip(c, s, given, ac_given, sd, pp[PP_KBREAK], r);
    if (r[1] * sd > 0.0) {
        out[0] = r[0]; out[1] = r[1]; out[2] = r[2]; out[3] = sd;
        return;
    }
    out[0] = ac; out[1] = 0.0; out[2] = copysign(cap, Q_req); out[3] = 0.0;   /* no consistent break-away */
}

/* RigidDifferential.do_step (with _step_compiled: rk_step_slip) */
static int rigid_step(Ctx *c, double *s, double t, double h)
{
    const int speed = c->sc[SC_SPEED] != 0.0;
    if (!(h > 0.0 && h < INFINITY))
        return SK_FALLBACK;
    if (!(isfinite(s[R_WREF]) && isfinite(s[R_TAUC]) && isfinite(s[R_TAUL]) && isfinite(s[R_TAUR])))
        return SK_FALLBACK;          /* the Python code names the input */
    /* the carrier speed at the step's start and its acceleration (speed drive: the ramp of this step;
     * torque drive: the acceleration at the end of the last step), held over the step */
    if (!c->pp)
        set_speed_loads(c, s, s[R_WC], speed ? (s[R_WREF] - s[R_WC]) / h : s[R_AC]);
    if (!c->pp && s[R_WD] != 0.0 && !speed) {
        /* _step_compiled: a new solve (key other than the cached one), slipping throughout */
        const double sd = copysign(1.0, s[R_WD]);
        const int same = s[R_HAS_SK] != 0.0 && s[R_SK_S] == sd && s[R_SK_HAS_ACG] == 0.0
                         && s[R_SK_TAUC] == s[R_TAUC] && s[R_SK_TAUL] == s[R_TAUL] && s[R_SK_TAUR] == s[R_TAUR]
                         && s[R_SK_GWC] == s[R_GWC] && s[R_SK_GAC] == s[R_GAC];
        if (!same) {
            double io[24];
            const double loss0 = s[R_LOSS];
            io[0] = sd; io[1] = s[R_TAUC]; io[2] = s[R_TAUL]; io[3] = s[R_TAUR];
            io[4] = s[R_HAS_ADG] != 0.0 ? s[R_ADG] : 0.0; io[5] = s[R_F12]; io[6] = s[R_WC]; io[7] = s[R_WD];
            io[8] = s[R_PHIC]; io[9] = s[R_PHID]; io[10] = s[R_WORK]; io[11] = loss0; io[12] = h;
            if (c->step_slip(c->k, io) == 0) {
                const double ac = io[13], ad = io[14], F12 = io[15], cap = io[16], Qf = io[17], loss = io[23];
                s[R_WC] = io[18]; s[R_WD] = io[19]; s[R_PHIC] = io[20]; s[R_PHID] = io[21]; s[R_WORK] = io[22];
                s[R_LOSS] = loss;
                s[R_F12] = F12; s[R_CAP] = cap; s[R_HAS_ADG] = 1.0; s[R_ADG] = ad;
                s[R_HAS_SK] = 1.0; s[R_SK_S] = sd; s[R_SK_HAS_ACG] = 0.0; s[R_SK_ACG] = 0.0;
                s[R_SK_TAUC] = s[R_TAUC]; s[R_SK_TAUL] = s[R_TAUL]; s[R_SK_TAUR] = s[R_TAUR]; s[R_SK_GWC] = s[R_GWC];
                s[R_SK_GAC] = s[R_GAC];
                s[R_SV_AC] = ac; s[R_SV_AD] = ad; s[R_SV_QF] = Qf; s[R_SV_S] = sd; s[R_SV_F12] = F12; s[R_SV_CAP] = cap;
                if (s[R_SD] == 0.0)
                    s[R_NSW] += 1.0;
                s[R_T] = t + h;
                s[R_LOSS_LAST] = loss - loss0;
                s[R_NSTEPS] += 1.0;
                s[R_AC] = ac; s[R_AD] = ad; s[R_QF] = Qf; s[R_SD] = sd;
                s[R_LASTH] = h;
                return SK_OK;
            }
        }
    }
    const double ac_given = speed ? (s[R_WREF] - s[R_WC]) / h : 0.0;
    double remaining = h;
    const double loss0 = s[R_LOSS];
    int i;
    for (i = 0; i < 16; i++) {
        double a[4];
        if (c->pp)
            paper_accelerations(c, s, speed, ac_given, a);
        else
            accelerations(c, s, speed, ac_given, a);
        double dt = remaining;
        int crossing = 0;
        if (s[R_WD] != 0.0 && a[1] * s[R_WD] < 0.0) {
            const double t_cross = -s[R_WD] / a[1];
            if (t_cross < remaining) {
                dt = t_cross;
                crossing = 1;
            }
        }
        rigid_advance(c, s, dt, a[0], a[1], a[2]);
        if (crossing) {
            s[R_WD] = 0.0;
            s[R_NSW] += 1.0;
        } else if (a[3] != 0.0 && s[R_SD] == 0.0) {
            s[R_NSW] += 1.0;
        }
        s[R_SD] = !crossing ? a[3] : 0.0;
        remaining -= dt;
        if (remaining <= 1e-15 * h)
            break;
    }
    if (i == 16)
        return SK_FALLBACK;          /* more than 16 mode switches: the Python code raises */
    if (speed)
        s[R_WC] = s[R_WREF];
    s[R_T] = t + h;
    s[R_LOSS_LAST] = s[R_LOSS] - loss0;
    s[R_NSTEPS] += 1.0;
    double a[4];
    if (c->pp)
        paper_accelerations(c, s, speed, 0.0, a);
    else
        accelerations(c, s, speed, 0.0, a);
    s[R_AC] = a[0]; s[R_AD] = a[1]; s[R_QF] = a[2]; s[R_SD] = a[3];
    s[R_LASTH] = h;
    return SK_OK;
}

/* ------------------------------------------------------------------ the shafts (shafts.py, shaft_solver.py) */

static inline double phi_L(const double *s) { return s[R_PHIC] + s[R_PHID]; }
static inline double phi_R(const Ctx *c, const double *s) { return s[R_PHIC] + c->k[9] * s[R_PHID]; }

/* WheelSurrogate.midpoint: (dw_0, dw_tau, q_0, q_tau) */
static void midpoint(const double *m, double hs, const double x0[2], double out[4])
{
    const double a_free = m[0], inv_J = m[1], dadw = m[2], q_rate = m[3], c_t = m[4], r_t = m[5];
    const double a = 0.5 * hs;
    const double m11 = 1.0 - a * dadw, m12 = a * inv_J, m21 = -a * c_t, m22 = 1.0 + a * r_t;
    const double w0 = x0[0], q0 = x0[1];
    const double rhs1 = w0 + a * (dadw * w0 - inv_J * q0) + hs * a_free;
    const double rhs2 = q0 + a * (c_t * w0 - r_t * q0) + hs * q_rate;
    const double det = m11 * m22 - m12 * m21;
    out[0] = (m22 * rhs1 - m12 * rhs2) / det;
    out[1] = m22 * hs * inv_J / det;
    out[2] = (m11 * rhs2 - m21 * rhs1) / det;
    out[3] = -m21 * hs * inv_J / det;
}

/* inner.set_state(snap): the state and the rigid kernel's speed-load constants, centrifugal and
 * tangential (rigid.py's set_state) */
static void restore_state(Ctx *c, double *cur, const double *snap)
{
    memcpy(cur, snap, RS_N * sizeof(double));
    speed_load_constants(c, cur);
}

/* ShaftSolver._eval: residuals and twist changes r[4] for (TL, TR) held over the sub-step from snap */
static int shaft_eval(Ctx *c, const double *snap, double *cur, int restore, double t, double hs, double TL,
                      double TR, const double *args, double r[4])
{
    const double *sc = c->sc;
    double *ss = c->ss;
    if (restore)
        restore_state(c, cur, snap);
    cur[R_TAUL] = TL;
    cur[R_TAUR] = TR;
    int rc = rigid_step(c, cur, t, hs);
    if (rc)
        return rc;
    ss[S_NEVALS] += 1.0;
    const double dthL = phi_L(cur) - args[0] - (args[2] - args[4] * TL);
    const double dthR = phi_R(c, cur) - args[1] - (args[3] - args[5] * TR);
    r[0] = TL + sc[SC_CL] * (ss[S_THL] + dthL) + sc[SC_DL] * dthL / hs;
    r[1] = TR + sc[SC_CR] * (ss[S_THR] + dthR) + sc[SC_DR] * dthR / hs;
    r[2] = dthL;
    r[3] = dthR;
    return SK_OK;
}

/* ShaftSolver._mode as a slot of the Jacobian cache, -1 for a key this layout has no slot for */
static int shaft_mode(const double *cur, const double *snap)
{
    const double sd = cur[R_SD];
    int m;
    if (sd == 1.0)
        m = 0;
    else if (sd == -1.0)
        m = 1;
    else if (sd == 0.0)
        m = signbit(sd) ? 3 : 2;
    else
        return -1;
    return cur[R_NSW] != snap[R_NSW] ? m + 4 : m;
}

/* ShaftSolver._jacobian */
static int shaft_jacobian(Ctx *c, const double *snap, double *cur, double t, double hs, double TL, double TR,
                          const double r[4], const double *args, int mode, double J[4])
{
    double cols[2][2];
    const double base = 1e-3 * (1.0 + fabs(TL) + fabs(TR));
    const double dts[6] = {base, -base, 1e-2 * base, -1e-2 * base, 1e-4 * base, -1e-4 * base};
    for (int j = 0; j < 2; j++) {
        double e[4], dT = 0.0;
        for (int q = 0; q < 6; q++) {
            dT = dts[q];
            int rc = shaft_eval(c, snap, cur, 1, t, hs, TL + (j == 0 ? dT : 0.0), TR + (j == 1 ? dT : 0.0), args, e);
            if (rc)
                return rc;
            int m = shaft_mode(cur, snap);
            if (m < 0)
                return SK_FALLBACK;
            if (m == mode)
                break;
        }
        cols[j][0] = (e[0] - r[0]) / dT;
        cols[j][1] = (e[1] - r[1]) / dT;
    }
    c->ss[S_NJAC] += 1.0;
    J[0] = cols[0][0]; J[1] = cols[1][0]; J[2] = cols[0][1]; J[3] = cols[1][1];
    return SK_OK;
}

/* ShaftSolver._substep: one sub-step from the state snap (cur holds it on entry) */
static int shaft_substep(Ctx *c, double t, double hs, double wL, double wR, double xL[2], double xR[2],
                         const double *snap, double *cur, double *TLo, double *TRo)
{
    const double *sc = c->sc;
    double *ss = c->ss;
    const double phiL0 = phi_L(cur), phiR0 = phi_R(c, cur);
    double pL[4], pR[4];
    midpoint(c->mL, hs, xL, pL);
    midpoint(c->mR, hs, xR, pR);
    const double a = 0.5 * hs;
    const double args[6] = {phiL0, phiR0, hs * wL + a * (xL[0] + pL[0]), hs * wR + a * (xR[0] + pR[0]), a * pL[1],
                            a * pR[1]};
    const double kL = sc[SC_CL] + sc[SC_DL] / hs, kR = sc[SC_CR] + sc[SC_DR] / hs;
    const double sL = args[4], sR = args[5], h2 = hs * hs;
    double *cache = ss + S_JAC;
    double TL = ss[S_TL], TR = ss[S_TR];
    double r[4], rn[4], J[4];
    int rc = shaft_eval(c, snap, cur, 0, t, hs, TL, TR, args, r);
    if (rc)
        return rc;
    int mode = shaft_mode(cur, snap);
    if (mode < 0)
        return SK_FALLBACK;
    int hasJ = 0;
#define J_OF(Sn)                                                                   \
    do {                                                                           \
        J[0] = 1.0 + kL * ((Sn)[0] * h2 + sL); J[1] = kL * (Sn)[1] * h2;           \
        J[2] = kR * (Sn)[2] * h2; J[3] = 1.0 + kR * ((Sn)[3] * h2 + sR);           \
        hasJ = 1;                                                                  \
    } while (0)
    if (cache[5 * mode] != 0.0)
        J_OF(cache + 5 * mode + 1);
    double scale = 1e-10 * (1.0 + fabs(TL) + fabs(TR));
    int fresh = 0, switched = 0, updated = 0, it, converged = 0;
    for (it = 0; it < 40; it++) {
        if (fabs(r[0]) + fabs(r[1]) <= scale) {
            converged = 1;
            break;
        }
        if (!hasJ || (it >= 2 && !fresh)) {
            rc = shaft_jacobian(c, snap, cur, t, hs, TL, TR, r, args, mode, J);
            if (rc)
                return rc;
            hasJ = 1;
            fresh = 1;
            updated = 0;
        }
        const double det = J[0] * J[3] - J[1] * J[2];
        if (!(det != 0.0 && isfinite(det))) {
            if (fresh && !updated)
                return SK_FALLBACK;     /* the Python code raises: the sun-torque Jacobian is singular */
            hasJ = 0;
            continue;
        }
        double dTL = -(J[3] * r[0] - J[1] * r[1]) / det;
        double dTR = -(J[0] * r[1] - J[2] * r[0]) / det;
        if (it >= 8) {
            dTL *= 0.5;
            dTR *= 0.5;
        }
        TL = TL + dTL;
        TR = TR + dTR;
        rc = shaft_eval(c, snap, cur, 1, t, hs, TL, TR, args, rn);
        if (rc)
            return rc;
        const int mode_new = shaft_mode(cur, snap);
        if (mode_new < 0)
            return SK_FALLBACK;
        if (mode_new != mode && cache[5 * mode_new] != 0.0 && !switched) {
            J_OF(cache + 5 * mode_new + 1);
            switched = 1;
        } else {
            const double n2 = dTL * dTL + dTR * dTR;
            if (n2 > 0.0) {
                const double yL = rn[0] - r[0] - (J[0] * dTL + J[1] * dTR);
                const double yR = rn[1] - r[1] - (J[2] * dTL + J[3] * dTR);
                J[0] = J[0] + yL * dTL / n2; J[1] = J[1] + yL * dTR / n2;
                J[2] = J[2] + yR * dTL / n2; J[3] = J[3] + yR * dTR / n2;
                updated = 1;
            }
        }
        mode = mode_new;
        memcpy(r, rn, sizeof r);
        scale = 1e-10 * (1.0 + fabs(TL) + fabs(TR));
    }
#undef J_OF
    if (!converged && !(fabs(r[0]) + fabs(r[1]) <= sc[SC_ACCEPT] * (1.0 + fabs(TL) + fabs(TR))))
        return SK_NOTCONV;
    if (hasJ) {
        double *Sn = cache + 5 * mode;
        Sn[0] = 1.0;
        Sn[1] = ((J[0] - 1.0) / kL - sL) / h2;
        Sn[2] = J[1] / kL / h2;
        Sn[3] = J[2] / kR / h2;
        Sn[4] = ((J[3] - 1.0) / kR - sR) / h2;
    }
    const double dthL = r[2], dthR = r[3];
    ss[S_WSUNS] += TL * (phi_L(cur) - phiL0) + TR * (phi_R(c, cur) - phiR0);
    ss[S_WWHEELS] += TL * (args[2] - args[4] * TL) + TR * (args[3] - args[5] * TR);
    xL[0] = pL[0] - pL[1] * TL; xL[1] = pL[2] - pL[3] * TL;
    xR[0] = pR[0] - pR[1] * TR; xR[1] = pR[2] - pR[3] * TR;
    ss[S_LOSS] += (0.5 * sc[SC_CL] * dthL * dthL + sc[SC_DL] * dthL * dthL / hs
                   + 0.5 * sc[SC_CR] * dthR * dthR + sc[SC_DR] * dthR * dthR / hs);
    ss[S_THL] += dthL;
    ss[S_THR] += dthR;
    ss[S_TL] = TL;
    ss[S_TR] = TR;
    *TLo = TL;
    *TRo = TR;
    return SK_OK;
}

/* ShaftSolver._advance: a sub-step, or two halves where its Newton does not converge (down to 1/64) */
static int shaft_advance(Ctx *c, double t, double hs, double wL, double wR, double xL[2], double xR[2],
                         double acc[2], int depth, double *cur)
{
    double snap[RS_N], jac[8 * 5];
    double TL, TR;
    memcpy(snap, cur, sizeof snap);
    memcpy(jac, c->ss + S_JAC, sizeof jac);
    int rc = shaft_substep(c, t, hs, wL, wR, xL, xR, snap, cur, &TL, &TR);
    if (rc == SK_NOTCONV) {
        if (depth >= 6)
            return SK_FALLBACK;     /* the Python code raises */
        restore_state(c, cur, snap);
        memcpy(c->ss + S_JAC, jac, sizeof jac);
        c->ss[S_NHALV] += 1.0;
        rc = shaft_advance(c, t, 0.5 * hs, wL, wR, xL, xR, acc, depth + 1, cur);
        if (rc)
            return rc;
        return shaft_advance(c, t + 0.5 * hs, 0.5 * hs, wL, wR, xL, xR, acc, depth + 1, cur);
    }
    if (rc)
        return rc;
    acc[0] += TL * hs;
    acc[1] += TR * hs;
    c->ss[S_NSUB] += 1.0;
    return SK_OK;
}

/* ShaftedDifferential._do_step. Returns SK_OK with rs, ss (and k's 49..52, 54..57) updated, or SK_FALLBACK
 * with nothing changed (the caller runs the Python reference). */
int64_t sk_step(const double *sc, double *k, double *rs, double *ss, const double *in, void **fp)
{
    Ctx c;
    double cur[RS_N], S[SS_N];
    c.sc = sc;
    memcpy(c.k, k, sizeof c.k);
    c.slip = (rk_fn)fp[0];
    c.step_slip = (rk_fn)fp[1];
    c.mL = in + I_ML;
    c.mR = in + I_MR;
    c.break_slide = 0;
    c.pp = NULL;
    memcpy(cur, rs, sizeof cur);
    memcpy(S, ss, sizeof S);
    c.ss = S;
    for (int m = 0; m < 8; m++)          /* a slot flag is 0 or 1 */
        if (S[S_JAC + 5 * m] != 0.0 && S[S_JAC + 5 * m] != 1.0)
            return SK_FALLBACK;
    const double t = in[I_T], h = in[I_H], pL = in[I_PL], wL = in[I_WL], pR = in[I_PR], wR = in[I_WR];
    const double cL = sc[SC_CL], cR = sc[SC_CR];
    const double thL = phi_L(cur) - pL - S[S_OFFL];
    const double thR = phi_R(&c, cur) - pR - S[S_OFFR];
    S[S_WWHEELS] += (0.5 * cL * (thL * thL - S[S_THL] * S[S_THL]) + 0.5 * cR * (thR * thR - S[S_THR] * S[S_THR]));
    S[S_THL] = thL;
    S[S_THR] = thR;
    const double nd = ceil(h / sc[SC_HMAX] - 1e-9);
    if (!(nd <= 1e6))
        return SK_FALLBACK;
    const int64_t n = nd < 1.0 ? 1 : (int64_t)nd;
    const double hs = h / (double)n;
    double xL[2] = {0.0, 0.0}, xR[2] = {0.0, 0.0}, acc[2] = {0.0, 0.0};
    for (int64_t i = 0; i < n; i++) {
        int rc = shaft_advance(&c, t + (double)i * hs, hs, wL, wR, xL, xR, acc, 0, cur);
        if (rc)
            return SK_FALLBACK;
    }
    S[S_DWPL] = xL[0];
    S[S_DWPR] = xR[0];
    S[S_QENDL] = xL[1];
    S[S_QENDR] = xR[1];
    S[S_TMEANL] = -acc[0] / h;
    S[S_TMEANR] = -acc[1] / h;
    S[S_TENDL] = -S[S_TL];
    S[S_TENDR] = -S[S_TR];
    S[S_T] = t + h;
    S[S_NSTEPS] += 1.0;
    const double wLo = cur[R_WC] + cur[R_WD], wRo = cur[R_WC] + c.k[9] * cur[R_WD];
    if (!(isfinite(S[S_THL]) && isfinite(S[S_THR]) && isfinite(S[S_TL]) && isfinite(S[S_TR]) && isfinite(wLo)
          && isfinite(wRo)))
        return SK_FALLBACK;         /* the Python code raises */
    memcpy(rs, cur, sizeof cur);
    memcpy(ss, S, sizeof S);
    k[49] = c.k[49]; k[50] = c.k[50]; k[51] = c.k[51]; k[52] = c.k[52];
    k[54] = c.k[54]; k[55] = c.k[55]; k[56] = c.k[56]; k[57] = c.k[57];
    return SK_OK;
}

/* ------------------------------------------------------------------ the native step
 * The differential's whole communication step on its value array v (spurdiff.differential.shaft_kernel.
 * DiffNative, spurdiff.native_step): WatchedShaftedDifferential.do_step with sk_step, its input checks
 * (ShaftedDifferential._wheel_inputs, WheelSurrogate.checked), the load-capacity watch
 * (gears.capacity.StressWatch.update) and the overspeed watch, and the outputs the FMU reads (rigid.py's
 * and shafts.py's properties), in the same operations. A step whose watch would log (the first excess
 * of the static strength, the first overspeed) is not taken, so the Python step logs it.
 * v (SKV_N doubles): 0 w_ref, 1 tau_c, 2 tau_L, 3 tau_R (not used with the shafts), 4..7 the wheel sides'
 * angles and speeds, 8..13 and 14..19 the wheel surrogates (a_free inv_J dadw q_rate c_t r_t);
 * 20..52 the Real outputs (SKV_OUT order: tau_mean_L/R, dw_pred_L/R, tau_end_L/R, theta_L/R, wc, phic,
 * w_L, phi_L, w_R, phi_R, tau_drive, tau_mesh_L/R, F_A1, F_B2, F_12, locking torque and capacity,
 * power loss, energy loss, work in, kinetic energy, stuck, potential energy, parametric work,
 * overspeed, sigma_H_max, sigma_F_max, exceeded); 53 loaded flanks, 54 mode switches, 55 internal
 * steps, 56 contact transitions (Integer outputs); 57..59 the largest |force| booked per mesh, 60 the
 * overspeed warned; 61..80 the inputs the last step took.
 * Returns 0 (done), 1 (sk_step did not take it), 4 (an input the model refuses, h not positive and
 * finite), 5 (a watch would log, or an output is not finite: the Python step logs or refuses); on
 * failure nothing in v or the state arrays changed. */
typedef struct {
    const double *sc;
    double *k;
    double *rs, *ss;
    void *fp[2];
    const double *oc;
} SkNative;
enum {
    OC_JA, OC_JB, OC_LAM, OC_MCC, OC_MCD, OC_MDD, OC_NRA, OC_NRB, OC_SPEED, OC_CL, OC_CR, OC_LIMIT,
    OC_AH, OC_AF = OC_AH + 3, OC_HG = OC_AF + 3, OC_FG, OC_P2, OC_N
};
#define SKV_OUT 20
#define SKV_N 81

int64_t sk_noc(void) { return OC_N; }
int64_t sk_nv(void) { return SKV_N; }

/* a native step's outputs once it is taken (either coupling): 20..52 the Real outputs out, 53 the loaded
 * flanks (the sign of the sun torques' sum T0), 54 mode switches, 55 internal steps, 57..59 the largest
 * |force| per mesh, 61..80 the inputs the step took */
static void native_outputs(double *v, const double *out, double T0, double nsw, double nsteps, const double *Fm)
{
    memcpy(v + SKV_OUT, out, 33 * sizeof *out);
    v[53] = T0 > 0.0 ? 1.0 : (T0 < 0.0 ? -1.0 : 0.0);
    v[54] = nsw;
    v[55] = nsteps;
    v[57] = Fm[0]; v[58] = Fm[1]; v[59] = Fm[2];
    for (int i = 0; i < 20; i++)
        v[61 + i] = v[i];
}

static int surrogate_ok(const double *m)
{
    return isfinite(m[0] + m[1] + m[2] + m[3] + m[4] + m[5]) && m[1] >= 0.0 && m[4] >= 0.0 && m[5] >= 0.0
           && m[2] <= 0.0;
}

static double max3(double a, double b, double c)   /* Python's max(a, b, c) */
{
    double m = a;
    if (b > m) m = b;
    if (c > m) m = c;
    return m;
}

/* The load-capacity watch (gears.capacity.StressWatch.update) on the step's mesh forces: the largest
 * |force| per mesh (Fm) and the run's largest stresses updated; 1 when it would log (the first excess
 * of the static strength while `exceeded` is 0: the Python step logs it), else 0. */
static int capacity_watch(const double *oc, double FA, double FB, double F12, double *sHmax, double *sFmax,
                          double Fm[3], double exceeded)
{
    const double a1 = FA >= 0.0 ? FA : -FA, a2 = FB >= 0.0 ? FB : -FB, a3 = F12 >= 0.0 ? F12 : -F12;
    if (a1 <= Fm[0] && a2 <= Fm[1] && a3 <= Fm[2])
        return 0;
    Fm[0] = a1 > Fm[0] ? a1 : Fm[0];
    Fm[1] = a2 > Fm[1] ? a2 : Fm[1];
    Fm[2] = a3 > Fm[2] ? a3 : Fm[2];
    const double sH = max3(oc[OC_AH] * sqrt(a1), oc[OC_AH + 1] * sqrt(a2), oc[OC_AH + 2] * sqrt(a3));
    const double sF = max3(oc[OC_AF] * a1, oc[OC_AF + 1] * a2, oc[OC_AF + 2] * a3);
    if (sH > *sHmax) *sHmax = sH;
    if (sF > *sFmax) *sFmax = sF;
    return exceeded == 0.0 && (sH > oc[OC_HG] || sF > oc[OC_FG]);
}

int64_t sk_native(const SkNative *x, double *v, double t, double h)
{
    const double *oc = x->oc;
    const double pL = v[4], wL = v[5], pR = v[6], wR = v[7];
    if (!(h > 0.0 && h < INFINITY) || !isfinite(pL + wL + pR + wR) || !surrogate_ok(v + 8) || !surrogate_ok(v + 14))
        return 4;
    double *rs = x->rs, *ss = x->ss;
    const double keep_wref = rs[R_WREF], keep_tauc = rs[R_TAUC];
    double in[IN_N] = {t, h, pL, wL, pR, wR};
    for (int i = 0; i < 12; i++)
        in[I_ML + i] = v[8 + i];
    double bk_rs[RS_N], bk_ss[SS_N], bk_k[8];
    memcpy(bk_rs, rs, sizeof bk_rs);
    memcpy(bk_ss, ss, sizeof bk_ss);
    for (int i = 0; i < 4; i++) {
        bk_k[i] = x->k[49 + i];
        bk_k[4 + i] = x->k[54 + i];
    }
    rs[R_WREF] = v[0];
    rs[R_TAUC] = v[1];
    if (sk_step(x->sc, x->k, rs, ss, in, (void **)x->fp) != SK_OK) {
        rs[R_WREF] = keep_wref;
        rs[R_TAUC] = keep_tauc;
        return 1;
    }
    const double wc = rs[R_WC], wd = rs[R_WD], phic = rs[R_PHIC], phid = rs[R_PHID], ac = rs[R_AC], ad = rs[R_AD];
    const double tauL = rs[R_TAUL], tauR = rs[R_TAUR], lam = oc[OC_LAM];
    const double FA = (oc[OC_JA] * (ac + ad) - tauL) / oc[OC_NRA];
    const double FB = (oc[OC_JB] * (ac + lam * ad) - tauR) / oc[OC_NRB];
    const double F12 = rs[R_F12];
    /* the load-capacity watch (StressWatch.update) */
    double sHmax = v[SKV_OUT + 30], sFmax = v[SKV_OUT + 31], Fm[3] = {v[57], v[58], v[59]};
    int log = capacity_watch(oc, FA, FB, F12, &sHmax, &sFmax, Fm, v[SKV_OUT + 32]);
    /* the overspeed watch */
    const double awd = fabs(wd);
    const int over = awd > oc[OC_LIMIT];
    if (over && v[60] == 0.0)
        log = 1;
    const double tmL = oc[OC_JA] * (ac + ad) - tauL, tmR = oc[OC_JB] * (ac + lam * ad) - tauR;
    const double p2 = oc[OC_P2], lasth = rs[R_LASTH];
    double o[33];
    o[0] = ss[S_TMEANL]; o[1] = ss[S_TMEANR]; o[2] = ss[S_DWPL]; o[3] = ss[S_DWPR];
    o[4] = ss[S_TENDL]; o[5] = ss[S_TENDR]; o[6] = ss[S_THL]; o[7] = ss[S_THR];
    o[8] = wc; o[9] = phic; o[10] = wc + wd; o[11] = phic + phid; o[12] = wc + lam * wd; o[13] = phic + lam * phid;
    o[14] = oc[OC_SPEED] != 0.0 ? oc[OC_MCC] * ac + oc[OC_MCD] * ad - tauL - tauR : rs[R_TAUC];
    o[15] = tmL; o[16] = tmR; o[17] = FA; o[18] = FB; o[19] = F12;
    o[20] = rs[R_QF]; o[21] = rs[R_CAP];
    o[22] = lasth > 0.0 ? rs[R_LOSS_LAST] / lasth : fabs(rs[R_QF] * wd);
    o[23] = rs[R_LOSS] + ss[S_LOSS];
    o[24] = rs[R_WORK] - ss[S_WSUNS] + ss[S_WWHEELS];
    o[25] = 0.5 * (oc[OC_MCC] * pow(wc, p2) + 2.0 * oc[OC_MCD] * wc * wd + oc[OC_MDD] * pow(wd, p2));
    o[26] = (wd == 0.0 && ad == 0.0) ? 1.0 : 0.0;
    o[27] = 0.0 + 0.5 * (oc[OC_CL] * pow(ss[S_THL], p2) + oc[OC_CR] * pow(ss[S_THR], p2));
    o[28] = v[SKV_OUT + 28];          /* parametric work: constant (the rigid level has none) */
    o[29] = over ? 1.0 : 0.0;
    o[30] = sHmax; o[31] = sFmax;
    o[32] = v[SKV_OUT + 32];          /* exceeded: unchanged (a change is logged by the Python step) */
    for (int i = 0; i < 33; i++)      /* the adapter refuses a step with an output not finite */
        if (!isfinite(o[i]))
            log = 1;
    if (log) {   /* the Python step takes it (and logs, or refuses): the state as before */
        memcpy(rs, bk_rs, sizeof bk_rs);
        memcpy(ss, bk_ss, sizeof bk_ss);
        for (int i = 0; i < 4; i++) {
            x->k[49 + i] = bk_k[i];
            x->k[54 + i] = bk_k[4 + i];
        }
        return 5;
    }
    native_outputs(v, o, tmL + tmR, rs[R_NSW], ss[S_NSTEPS], Fm);
    return 0;
}

/* ------------------------------------------------------------------ the native step without half-shafts
 * The plain rigid model's whole communication step (shaftCoupling = torque; spurdiff.differential.
 * rigid_native.RigidNative): WatchedRigidDifferential.do_step, i.e. RigidDifferential.do_step (rigid_step
 * above, the pin-load law with its compiled solve: the same locking-law functions the step with the
 * half-shafts calls), the two watches as in sk_native, and the outputs the FMU reads.
 * v: sk_native's layout (SKV_N doubles), so that a host sets the same inputs with either coupling:
 * 0 w_ref, 1 tau_c, 2 tau_L, 3 tau_R; 4..19 the wheel-side inputs (not used here: carried); 20..52 the
 * Real outputs (SKV_OUT order); 53..56 the Integer outputs; 57..59 the largest |force| booked per
 * mesh, 60 the overspeed warned; 61..80 the inputs the last step took. Returns as sk_native: 0 done,
 * 1 rigid_step did not take it, 4 an input the model refuses
 * or h not positive and finite, 5 a watch would log or an output is not finite; on failure nothing in
 * v, rs or k changed. */
typedef struct {
    const double *sc;     /* SC_N: the carrier drive and the speed-load constants are read */
    double *k;            /* the rigid kernel's constants (speed loads written on success) */
    double *rs;           /* the rigid model's state (R_*) */
    void *fp[2];
    const double *oc;     /* sk_native's output constants (OC_CL, OC_CR unused) */
    const double *pp;     /* NULL: the pin-load law; else the linear capacity's constants (PP_*) */
} SkRigidNative;
int64_t sk_rigid_nv(void) { return SKV_N; }

int64_t sk_rigid_native(const SkRigidNative *x, double *v, double t, double h)
{
    const double *oc = x->oc;
    if (!(h > 0.0 && h < INFINITY) || !(isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]) && isfinite(v[3])))
        return 4;
    Ctx c;
    double s[RS_N];
    c.sc = x->sc;
    memcpy(c.k, x->k, sizeof c.k);
    c.slip = (rk_fn)x->fp[0];
    c.step_slip = (rk_fn)x->fp[1];
    c.mL = c.mR = NULL;
    c.ss = NULL;
    c.break_slide = 1;
    c.pp = x->pp;
    memcpy(s, x->rs, sizeof s);
    s[R_WREF] = v[0];
    s[R_TAUC] = v[1];
    s[R_TAUL] = v[2];
    s[R_TAUR] = v[3];
    if (rigid_step(&c, s, t, h) != SK_OK)
        return 1;
    const double wc = s[R_WC], wd = s[R_WD], phic = s[R_PHIC], phid = s[R_PHID], ac = s[R_AC], ad = s[R_AD];
    const double tauL = s[R_TAUL], tauR = s[R_TAUR], lam = oc[OC_LAM];
    const double tmL = oc[OC_JA] * (ac + ad) - tauL, tmR = oc[OC_JB] * (ac + lam * ad) - tauR;
    const double *pp = x->pp;
    double FA, FB, F12, cap;
    if (!pp) {          /* rigid_pinload's _sun_forces, F12 and cap of the solve */
        FA = (oc[OC_JA] * (ac + ad) - tauL) / oc[OC_NRA];
        FB = (oc[OC_JB] * (ac + lam * ad) - tauR) / oc[OC_NRB];
        F12 = s[R_F12];
        cap = s[R_CAP];
    } else {            /* statics.mesh_forces_for, rigid.py's locking_capacity */
        FA = tmL / pp[PP_DA];
        FB = tmR / pp[PP_DB];
        F12 = tmL == tmR ? FA * pp[PP_R1] * pp[PP_CA] / pp[PP_D0] : FA - pp[PP_SHARE] * (FA - FB);
        cap = (s[R_SD] != 0.0 ? pp[PP_KSLIDE] : pp[PP_K]) * fabs(tmL + tmR) + pp[PP_PRE];
    }
    double *o = v + SKV_OUT;
    /* the load-capacity watch (StressWatch.update), as sk_native */
    double sHmax = o[30], sFmax = o[31], Fm[3] = {v[57], v[58], v[59]};
    int log = capacity_watch(oc, FA, FB, F12, &sHmax, &sFmax, Fm, o[32]);
    const int over = fabs(wd) > oc[OC_LIMIT];
    if (over && v[60] == 0.0)
        log = 1;
    const double p2 = oc[OC_P2], lasth = s[R_LASTH];
    double r[33];
    r[0] = -tauL; r[1] = -tauR; r[2] = 0.0; r[3] = 0.0; r[4] = -tauL; r[5] = -tauR; r[6] = 0.0; r[7] = 0.0;
    r[8] = wc; r[9] = phic; r[10] = wc + wd; r[11] = phic + phid; r[12] = wc + lam * wd; r[13] = phic + lam * phid;
    r[14] = oc[OC_SPEED] != 0.0 ? oc[OC_MCC] * ac + oc[OC_MCD] * ad - tauL - tauR : s[R_TAUC];
    r[15] = tmL; r[16] = tmR; r[17] = FA; r[18] = FB; r[19] = F12;
    r[20] = s[R_QF]; r[21] = cap;
    r[22] = lasth > 0.0 ? s[R_LOSS_LAST] / lasth : fabs(s[R_QF] * wd);
    r[23] = s[R_LOSS];
    r[24] = s[R_WORK];
    r[25] = 0.5 * (oc[OC_MCC] * pow(wc, p2) + 2.0 * oc[OC_MCD] * wc * wd + oc[OC_MDD] * pow(wd, p2));
    r[26] = (wd == 0.0 && ad == 0.0) ? 1.0 : 0.0;
    r[27] = o[27];                    /* potential energy: none at rigid */
    r[28] = o[28];                    /* parametric work: none at rigid */
    r[29] = over ? 1.0 : 0.0;
    r[30] = sHmax; r[31] = sFmax;
    r[32] = o[32];                    /* exceeded: unchanged (a change is logged by the Python step) */
    for (int i = 0; i < 33; i++)
        if (!isfinite(r[i]))
            log = 1;
    if (log)
        return 5;
    memcpy(x->rs, s, sizeof s);
    for (int i = 0; i < 4; i++) {
        x->k[49 + i] = c.k[49 + i];
        x->k[54 + i] = c.k[54 + i];
    }
    native_outputs(v, r, tmL + tmR, s[R_NSW], s[R_NSTEPS], Fm);
    return 0;
}
