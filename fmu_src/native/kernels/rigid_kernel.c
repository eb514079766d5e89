/* The compiled pin-load solve of the rigid level (spurdiff.differential.rigid.RigidDifferential._slip_exact).
 *
 * Slipping in direction s with the pin-load locking law: Newton on the planets' moment balances for
 * (a_d, F_12). A transcription of the Python reference, which stays the specification and the
 * fallback: the same operations in the same order (compiled with -ffp-contract=off, no fused
 * multiply-adds), so the two agree bit for bit (tests/test_rigid_kernel.py).
 *
 * Constants (rk_nconst() doubles, set once per initialized model; see spurdiff/differential/rigid_kernel.py):
 *   0 rb1, 1 rb2, 2 n rbA, 3 n rbB, 4 c (the static pin-friction lever mu_pin r_d: stuck and at break-away;
 *   not used by these two functions, which solve the slipping motion), 5 M01, 6 M02, 7 J_A, 8 J_B, 9 lam,
 *   10 J_1, 11 J_2, 12 rho1, 13 rho2, 14 Mcd, 15 Mcc, 16 n, 17..32 planet 1's pin constants,
 *   33..48 planet 2's (tx ty rx ry ux uy qx qy, then the sums and differences, as _pin_constants),
 *   49..52 the planets' centrifugal forces (g1x g1y g2x g2y, N: m_i a_i w_c^2 e_r,i at the carrier
 *   speed of the step's start, added to the pin force vectors; written per step by the binding),
 *   53 c_slide (the dynamic pin-friction lever mu_pinDynamic r_d: the friction while slipping, used here),
 *   54..57 the planets' tangential forces (h1x h1y h2x h2y, N: -m_i a_i alpha_c e_t,i at the carrier
 *   acceleration held over the step, added to the pin force vectors after 49..52; written per step),
 *   58..73 planet 1's and 74..89 planet 2's constants of the far end of the journal (end L; 17..48 are
 *   end 0), 90..93 the shares of the inertial forces (w0_1, wL_1, w0_2, wL_2): the pin friction load is
 *   |R_0| + |R_L| (spurdiff.gears.layout.PinLayout.ends; a planar planet: end 0 the whole force with
 *   share 1, end L zero, so the sum is the planar |F_pin| bit for bit).
 * io (rk_nio() doubles): in 0 s, 1 given (1: carrier acceleration given), 2 ac_given, 3 tau_c,
 *   4 tau_L, 5 tau_R, 6 a_d start, 7 F_12 start (NaN: from the sun forces);
 *   out 8 ac, 9 ad, 10 F12, 11 cap (n sum_i |rho_i| M_i,max).
 */
#include <math.h>
#include <stdint.h>

#define RK_ABI 5
#define RK_NCONST 94
#define RK_NIO 12

int64_t rk_abi(void) { return RK_ABI; }
int64_t rk_nconst(void) { return RK_NCONST; }
int64_t rk_nio(void) { return RK_NIO; }
int64_t rk_nio_step(void) { return 24; }

/* Slipping: the friction of each pin at its sliding limit with the dynamic lever (constant 53).
 * Returns the number of Newton iterations (51: the iteration limit was reached). */
int64_t rk_slip(const double *k, double *io);

/* One communication step of a carrier torque-driven model slipping in direction s (w_d != 0) when
 * it stays in that mode over the whole step (RigidDifferential.do_step's path then: one solve, one
 * exact advance, the end-of-step accelerations those of the solve).
 * io: in 0 s, 1 tau_c, 2 tau_L, 3 tau_R, 4 a_d start, 5 F_12 start, 6 wc, 7 wd, 8 phic, 9 phid,
 *   10 work_in, 11 energy_loss, 12 h; out 13 ac, 14 ad, 15 F12, 16 cap, 17 Q_f, 18 wc, 19 wd,
 *   20 phic, 21 phid, 22 work_in, 23 energy_loss.
 * Returns 0, or 1 when the step is not of that kind (w_d reaches 0 within it): io's outputs are
 * then meaningless and the caller runs the Python reference from its unchanged state. */
int64_t rk_step_slip(const double *k, double *io)
{
    double sv[RK_NIO];
    const double s = io[0], tau_c = io[1], tau_L = io[2], tau_R = io[3], wc0 = io[6], wd0 = io[7], dt = io[12];
    const double lam = k[9];
    sv[0] = s; sv[1] = 0.0; sv[2] = 0.0; sv[3] = tau_c; sv[4] = tau_L; sv[5] = tau_R; sv[6] = io[4];
    sv[7] = io[5];
    rk_slip(k, sv);
    const double ac = sv[8], ad = sv[9], cap = sv[11];
    const double Qf = -s * cap;
    if (wd0 != 0.0 && ad * wd0 < 0.0) {
        const double t_cross = -wd0 / ad;
        if (t_cross < dt)
            return 1;
    }
    if (!(dt > 0.0))
        return 1;
    const double wc1 = wc0 + ac * dt, wd1 = wd0 + ad * dt;
    if (wd1 == 0.0 || copysign(1.0, wd1) != s)
        return 1;
    io[13] = ac; io[14] = ad; io[15] = sv[10]; io[16] = cap; io[17] = Qf;
    io[20] = io[8] + 0.5 * (wc0 + wc1) * dt;
    io[21] = io[9] + 0.5 * (wd0 + wd1) * dt;
    const double tau_drive = tau_c;
    const double mean_wc = 0.5 * (wc0 + wc1), mean_wd = 0.5 * (wd0 + wd1);
    io[22] = io[10] + dt * (tau_drive * mean_wc + tau_L * (mean_wc + mean_wd) + tau_R * (mean_wc + lam * mean_wd));
    io[23] = io[11] + dt * fabs(Qf * mean_wd);
    io[18] = wc1;
    io[19] = wd1;
    return 0;
}

/* The accelerations, the sun mesh forces and the two pins' force vectors at the iterate (ad, F12):
 * evaluated in the Newton loop and once more at convergence (the same operations as the Python
 * reference, spurdiff/differential/rigid_pinload.py, whose loop makes a last pass for the latter). */
#define PIN_FORCES()                                                     \
    do {                                                                 \
        ac = given ? ac_given : (Qc - Mcd * ad) / Mcc;                   \
        FA = (J_A * (ac + ad) - tau_L) / nrbA;                           \
        FB = (J_B * (ac + lam * ad) - tau_R) / nrbB;                     \
        aA = fabs(FA); aB = fabs(FB); a12 = fabs(F12);                   \
        f1x = FA * t1x + aA * r1x + F12 * u1x + a12 * q1x + g1x + h1x;   \
        f1y = FA * t1y + aA * r1y + F12 * u1y + a12 * q1y + g1y + h1y;   \
        f2x = FB * t2x + aB * r2x + F12 * u2x + a12 * q2x + g2x + h2x;   \
        f2y = FB * t2y + aB * r2y + F12 * u2y + a12 * q2y + g2y + h2y;   \
        e1x = FA * T1x + aA * R1x + F12 * U1x + a12 * Q1x + G1x + H1x;   \
        e1y = FA * T1y + aA * R1y + F12 * U1y + a12 * Q1y + G1y + H1y;   \
        e2x = FB * T2x + aB * R2x + F12 * U2x + a12 * Q2x + G2x + H2x;   \
        e2y = FB * T2y + aB * R2y + F12 * U2y + a12 * Q2y + G2y + H2y;   \
    } while (0)

int64_t rk_slip(const double *k, double *io)
{
    const double rb1 = k[0], rb2 = k[1], nrbA = k[2], nrbB = k[3], cpin = k[53], M01 = k[5], M02 = k[6];
    const double J_A = k[7], J_B = k[8], lam = k[9], J1 = k[10], J2 = k[11], rho1 = k[12], rho2 = k[13];
    const double Mcd = k[14], Mcc = k[15], n = k[16];
    const double w01 = k[90], wL1 = k[91], w02 = k[92], wL2 = k[93];
    /* the far ends' shares of the inertial forces, then end 0's (planar: times 1, unchanged) */
    const double G1x = wL1 * k[49], G1y = wL1 * k[50], G2x = wL2 * k[51], G2y = wL2 * k[52];
    const double H1x = wL1 * k[54], H1y = wL1 * k[55], H2x = wL2 * k[56], H2y = wL2 * k[57];
    const double g1x = w01 * k[49], g1y = w01 * k[50], g2x = w02 * k[51], g2y = w02 * k[52];
    const double h1x = w01 * k[54], h1y = w01 * k[55], h2x = w02 * k[56], h2y = w02 * k[57];
    const double *L1 = k + 58, *L2 = k + 74;
    const double T1x = L1[0], T1y = L1[1], R1x = L1[2], R1y = L1[3], U1x = L1[4], U1y = L1[5], Q1x = L1[6],
                 Q1y = L1[7], pL1x = L1[8], pL1y = L1[9], mL1x = L1[10], mL1y = L1[11], PL1x = L1[12],
                 PL1y = L1[13], NL1x = L1[14], NL1y = L1[15];
    const double T2x = L2[0], T2y = L2[1], R2x = L2[2], R2y = L2[3], U2x = L2[4], U2y = L2[5], Q2x = L2[6],
                 Q2y = L2[7], pL2x = L2[8], pL2y = L2[9], mL2x = L2[10], mL2y = L2[11], PL2x = L2[12],
                 PL2y = L2[13], NL2x = L2[14], NL2y = L2[15];
    const double *p1 = k + 17, *p2 = k + 33;
    const double t1x = p1[0], t1y = p1[1], r1x = p1[2], r1y = p1[3], u1x = p1[4], u1y = p1[5], q1x = p1[6],
                 q1y = p1[7], p1x = p1[8], p1y = p1[9], m1x = p1[10], m1y = p1[11], P1x = p1[12], P1y = p1[13],
                 N1x = p1[14], N1y = p1[15];
    const double t2x = p2[0], t2y = p2[1], r2x = p2[2], r2y = p2[3], u2x = p2[4], u2y = p2[5], q2x = p2[6],
                 q2y = p2[7], p2x = p2[8], p2y = p2[9], m2x = p2[10], m2y = p2[11], P2x = p2[12], P2y = p2[13],
                 N2x = p2[14], N2y = p2[15];
    const double s = io[0];
    const int given = io[1] != 0.0;
    const double ac_given = io[2], tau_c = io[3], tau_L = io[4], tau_R = io[5];
    const double sg1 = copysign(1.0, rho1) * s;
    const double sg2 = copysign(1.0, rho2) * s;
    const double Qc = tau_c + tau_L + tau_R;
    const double g = given ? 0.0 : -Mcd / Mcc;
    double ad = io[6], F12 = io[7], ac, FA, FB, aA, aB, a12, f1x, f1y, f2x, f2y, mag1, mag2, c1 = 0.0, c2 = 0.0;
    double e1x, e1y, e2x, e2y, mL1, mL2;
    int64_t it;

    if (isnan(F12)) {
        ac = given ? ac_given : (Qc - Mcd * ad) / Mcc;
        F12 = 0.5 * ((J_A * (ac + ad) - tau_L) / nrbA + (J_B * (ac + lam * ad) - tau_R) / nrbB);
    }
    const double dFA = J_A * (g + 1.0) / nrbA;
    const double dFB = J_B * (g + lam) / nrbB;
    const double a11_0 = J1 * (g + rho1);
    const double a21_0 = J2 * (g + rho2);
    for (it = 1; it <= 50; it++) {
        PIN_FORCES();
        mag1 = sqrt(f1x * f1x + f1y * f1y);
        mag2 = sqrt(f2x * f2x + f2y * f2y);
        mL1 = sqrt(e1x * e1x + e1y * e1y);
        mL2 = sqrt(e2x * e2x + e2y * e2y);
        c1 = cpin * (mag1 + mL1) + M01;
        c2 = cpin * (mag2 + mL2) + M02;
        const double r1 = rb1 * (FA - F12) - sg1 * c1 - J1 * (ac + rho1 * ad);
        const double r2 = rb2 * (FB - F12) - sg2 * c2 - J2 * (ac + rho2 * ad);
        if (fabs(r1) + fabs(r2) <= 1e-14 * (rb1 * (aA + a12) + rb2 * (aB + a12)) + 1e-300)
            break;
        double c1S, c112, c2S, c212;
        if (mag1 == 0.0) {
            c1S = c112 = 0.0;
        } else {
            c1S = cpin * (FA >= 0.0 ? (f1x * p1x + f1y * p1y) / mag1 : (f1x * m1x + f1y * m1y) / mag1);
            c112 = cpin * (F12 >= 0.0 ? (f1x * P1x + f1y * P1y) / mag1 : (f1x * N1x + f1y * N1y) / mag1);
        }
        if (mag2 == 0.0) {
            c2S = c212 = 0.0;
        } else {
            c2S = cpin * (FB >= 0.0 ? (f2x * p2x + f2y * p2y) / mag2 : (f2x * m2x + f2y * m2y) / mag2);
            c212 = cpin * (F12 >= 0.0 ? (f2x * P2x + f2y * P2y) / mag2 : (f2x * N2x + f2y * N2y) / mag2);
        }
        if (mL1 != 0.0) {   /* the far end of planet 1's journal */
            c1S += cpin * (FA >= 0.0 ? (e1x * pL1x + e1y * pL1y) / mL1 : (e1x * mL1x + e1y * mL1y) / mL1);
            c112 += cpin * (F12 >= 0.0 ? (e1x * PL1x + e1y * PL1y) / mL1 : (e1x * NL1x + e1y * NL1y) / mL1);
        }
        if (mL2 != 0.0) {
            c2S += cpin * (FB >= 0.0 ? (e2x * pL2x + e2y * pL2y) / mL2 : (e2x * mL2x + e2y * mL2y) / mL2);
            c212 += cpin * (F12 >= 0.0 ? (e2x * PL2x + e2y * PL2y) / mL2 : (e2x * NL2x + e2y * NL2y) / mL2);
        }
        const double a11 = (rb1 - sg1 * c1S) * dFA - a11_0;
        const double a12_ = -rb1 - sg1 * c112;
        const double a21 = (rb2 - sg2 * c2S) * dFB - a21_0;
        const double a22 = -rb2 - sg2 * c212;
        const double det = a11 * a22 - a12_ * a21;
        const double d_ad = (r1 * a22 - a12_ * r2) / det;
        const double d_F = (a11 * r2 - a21 * r1) / det;
        ad -= d_ad;
        F12 -= d_F;
        const double scale = aA + aB + fabs(F12) + 1e-300;
        if (fabs(d_F) <= 1e-15 * scale && fabs(d_ad) * (fabs(dFA) + fabs(dFB)) <= 1e-15 * scale) {
            PIN_FORCES();
            c1 = cpin * (sqrt(f1x * f1x + f1y * f1y) + sqrt(e1x * e1x + e1y * e1y)) + M01;
            c2 = cpin * (sqrt(f2x * f2x + f2y * f2y) + sqrt(e2x * e2x + e2y * e2y)) + M02;
            break;
        }
    }
    io[8] = ac;
    io[9] = ad;
    io[10] = F12;
    io[11] = n * (fabs(rho1) * c1 + fabs(rho2) * c2);
    return it;
}
