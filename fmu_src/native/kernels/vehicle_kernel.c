/* The compiled steps of the vehicle models: the car's RK4 step (spurdiff.vehicle.car.Vehicle.do_step
 * with the rate function of spurdiff.vehicle.car_rates.make_rates) and the wheel's implicit-midpoint
 * sub-steps with its outputs (spurdiff.vehicle.wheel.WheelLoad._substeps, _update_outputs,
 * _update_surrogate).
 *
 * A transcription of the Python reference, which stays the specification and the fallback: the
 * same operations in the same order (compiled with -ffp-contract=off, no fused multiply-adds), the
 * same libm functions (sin, cos, atan, tanh, sqrt, pow), so the two agree bit for bit
 * (tests/physics/test_vehicle_kernel.py). Python's x ** 2 is libm's pow(x, 2.0): the exponent
 * comes from the constants so the compiler cannot turn it into x * x. The car's speed output is
 * sqrt(vx * vx + vy * vy) in both (not math.hypot, which CPython computes its own way).
 *
 * Car constants (vk_car_nconst() doubles, set once per initialized model; spurdiff/vehicle/kernel.py):
 *   0 m, 1 L, 2 l_f, 3 l_r (L - l_f), 4 h_cg, 5 B, 6 C, 7 E, 8 -f_rr, 9 v_rr, 10 k_aero
 *   (-0.5 rho CdA), 11 trackRear, 12 Iz, 13 Kp, 14 Ki, 15 driveTorqueMax, 16 driveTorqueMin,
 *   17 1/sigma, 18 1/tau_load, 19 delta_max, 20 angle mode (1: steering.mode = angle), 21 K_r,
 *   22 K_ri, 23 h_max, 24 sigma, 25 alpha_max, 26 rollStiffnessShareRear, 27 G, 28 2.0 (pow).
 * Car io (vk_car_nio() doubles): in 0..11 the state (vx vy r psi x y alpha_f alpha_r axs_f ay_f
 *   I_v I_r), 12 h, 13 Fx_L, 14 Fx_R, 15 speedTarget, 16 steering command, 17 mu,
 *   18 speedTargetRate, 19 pathRadiusRate, 20 pathRadius, 21 kappa (1/R or 0), 22 atan(L kappa),
 *   23 sin(grade), 24 cos(grade), 25..28 the last outputs rearLeft_vx, rearRight_vx,
 *   rearLeft_Fz, rearRight_Fz;
 *   out 29..40 the state at the end, 41..58 the outputs in the order of car._OUTPUT_KEYS (the
 *   speed 47 among them), 59 the number of sub-steps.
 * Returns 0, or 1 when the result is not finite (io's outputs then meaningless).
 *
 * Wheel constants (vk_wheel_nconst()): 0 J, 1 R, 2 B, 3 C, 4 E, 5 k_max, 6 f_rr, 7 1/w_eps,
 *   8 sigma, 9 w_eps, 10 halfShaft.c, 11 halfShaft.d.
 * Wheel io (vk_wheel_nio()): in 0 hs, 1 n, 2 w_in, 3 dw_in, 4 v (start), 5 Fz (start), 6 mu,
 *   7 c, 8 d, 9 tau0, 10 dFz, 11 dv, 12 torque_in (1: tau0 given, shaftCoupling = wheel),
 *   13 theta, 14 w, 15 k, 16 phi, 17 work_flange, 18 loss_damping, 19 work_road, 20 loss_slip,
 *   21 loss_rolling, then for the outputs: 22 the flange (wheel mode: anchor) speed at the end,
 *   23 v at the end, 24 Fz at the end, 25 shaftIn.tau, 26 interface stiffness (0 or 1),
 *   27 wheel mode (1: shaftCoupling = wheel);
 *   out 28..36 theta, w, k, phi, work_flange, loss_damping, work_road, loss_slip, loss_rolling,
 *   37 shaft_tau, 38 flange_tau, 39 Fx, 40 shaft_power, 41 sur_a, 42 sur_invJ, 43 sur_dadw,
 *   44 sur_qrate, 45 sur_ct, 46 sur_rt, 47 the slope g' when it was not positive.
 * Returns 0, 1 (Newton's slope not positive, 47 holds it) or 2 (Newton did not converge).
 */
#include <math.h>
#include <stdint.h>

#define VK_ABI 2
#define CAR_NCONST 29
#define CAR_NIO 60
#define CAR_NV 119
#define WHEEL_NCONST 12
#define WHEEL_NIO 48
#define WHEEL_NV 103

int64_t vk_abi(void) { return VK_ABI; }
int64_t vk_car_nconst(void) { return CAR_NCONST; }
int64_t vk_car_nio(void) { return CAR_NIO; }
int64_t vk_car_nv(void) { return CAR_NV; }
int64_t vk_wheel_nconst(void) { return WHEEL_NCONST; }
int64_t vk_wheel_nio(void) { return WHEEL_NIO; }
int64_t vk_wheel_nv(void) { return WHEEL_NV; }

/* The terms make_rates binds once per step (the inputs held or ramping over it). */
typedef struct {
    const double *k;
    double mu, Wn, Wn_lr_L, Fxr, Fxr2, F_grade, Mz_x, G_sin, vref, delta_cmd, kappa, delta_ff,
        dvref, dR, R0;
    int ramp, angle_mode;
} Rates;

/* rates(vx, vy, r, psi, af, ar, axf, ayf, Iv, Ir, tau, full=True): d[12], ex[10] =
 * (delta, Fz_f, Fz_r, ax, ay, axs, Fxr, Fyf, Fyr, u) */
static void car_rates(const Rates *q, const double *s, double tau, double *d, double *ex)
{
    const double *k = q->k;
    const double m = k[0], L = k[1], lf = k[2], lr = k[3], h_cg = k[4], B = k[5], C = k[6], E = k[7];
    const double nfrr = k[8], v_rr = k[9], k_aero = k[10], Iz = k[12], Kp = k[13], Ki = k[14];
    const double umax = k[15], umin = k[16], inv_sig = k[17], inv_tau = k[18], dmax = k[19];
    const double K_r = k[21], K_ri = k[22];
    const double vx = s[0], vy = s[1], r = s[2], psi = s[3], af = s[6], ar = s[7], axf = s[8], ayf = s[9];
    const double Iv = s[10], Ir = s[11];
    double vr, kap, dff, dIr, delta;
    if (q->ramp) {
        vr = q->vref + q->dvref * tau;
        if (q->dR != 0.0) {
            const double R = q->R0 + q->dR * tau;
            kap = (R == 0.0 || R == INFINITY || R == -INFINITY) ? 0.0 : 1.0 / R;
            dff = atan(L * kap);
        } else {
            kap = q->kappa;
            dff = q->delta_ff;
        }
    } else {
        vr = q->vref;
        kap = q->kappa;
        dff = q->delta_ff;
    }
    if (q->angle_mode) {
        dIr = 0.0;
        delta = q->delta_cmd;
    } else {
        const double e = (vx * kap - r) * tanh(vx);
        const double raw = dff + K_r * e + Ir;
        if ((raw >= dmax && e > 0.0) || (raw <= -dmax && e < 0.0))
            dIr = 0.0;
        else
            dIr = K_ri * e;
        delta = raw > dmax ? dmax : (raw < -dmax ? -dmax : raw);
    }
    double Fz_f = q->Wn_lr_L - m * axf * h_cg / L;
    Fz_f = Fz_f < 0.0 ? 0.0 : (Fz_f > q->Wn ? q->Wn : Fz_f);
    const double Fz_r = q->Wn - Fz_f;
    const double cd = cos(delta), sd = sin(delta);
    const double vfy = vy + lf * r;
    const double vwx_f = vx * cd + vfy * sd;
    const double vwy_f = -vx * sd + vfy * cd;
    double x = B * af;
    const double Fyf = q->mu * Fz_f * sin(C * atan(x - E * (x - atan(x))));
    const double Fxf = nfrr * Fz_f * tanh(vwx_f / v_rr);
    const double D2 = pow(q->mu * Fz_r, k[28]) - q->Fxr2;
    x = B * ar;
    const double Fyr = (D2 > 0.0 ? sqrt(D2) : 0.0) * sin(C * atan(x - E * (x - atan(x))));
    const double Fyf_b = Fxf * sd + Fyf * cd;
    const double FX = Fxf * cd - Fyf * sd + q->Fxr + k_aero * vx * fabs(vx) + q->F_grade;
    const double ax = FX / m;
    const double ay = (Fyf_b + Fyr) / m;
    const double eu = vr - vx;
    const double u = Kp * eu + Iv;
    const double cpsi = cos(psi), spsi = sin(psi);
    d[0] = ax + vy * r;
    d[1] = ay - vx * r;
    d[2] = (lf * Fyf_b - lr * Fyr + q->Mz_x) / Iz;
    d[3] = r;
    d[4] = vx * cpsi - vy * spsi;
    d[5] = vx * spsi + vy * cpsi;
    d[6] = (-vwy_f - fabs(vwx_f) * af) * inv_sig;
    d[7] = (-(vy - lr * r) - fabs(vx) * ar) * inv_sig;
    d[8] = (ax + q->G_sin - axf) * inv_tau;
    d[9] = (ay - ayf) * inv_tau;
    d[10] = ((u >= umax && eu > 0.0) || (u <= umin && eu < 0.0)) ? 0.0 : Ki * eu;
    d[11] = dIr;
    if (ex) {
        ex[0] = delta; ex[1] = Fz_f; ex[2] = Fz_r; ex[3] = ax; ex[4] = ay; ex[5] = ax + q->G_sin;
        ex[6] = q->Fxr; ex[7] = Fyf; ex[8] = Fyr; ex[9] = u;
    }
}

int64_t vk_car_step(const double *k, double *io)
{
    Rates q;
    const double m = k[0], G = k[27], dmax = k[19];
    const double sin_g = io[23], cos_g = io[24];
    const double FxL = io[13], FxR = io[14];
    q.k = k;
    q.mu = io[17];
    q.Wn = m * G * cos_g;
    q.Wn_lr_L = q.Wn * k[3] / k[1];
    q.Fxr = FxL + FxR;
    q.Fxr2 = q.Fxr * q.Fxr;
    q.F_grade = -m * G * sin_g;
    q.Mz_x = 0.5 * k[11] * (FxR - FxL);
    q.G_sin = G * sin_g;
    q.vref = io[15];
    q.angle_mode = k[20] != 0.0;
    {
        const double dcmd = io[16];
        q.delta_cmd = dcmd > dmax ? dmax : (dcmd < -dmax ? -dmax : dcmd);
    }
    q.kappa = io[21];
    q.delta_ff = io[22];
    q.dvref = io[18];
    q.dR = q.kappa != 0.0 ? io[19] : 0.0;
    q.R0 = io[20];
    q.ramp = q.dvref != 0.0 || q.dR != 0.0;

    const double h = io[12];
    double h_lim = k[23];
    const double vabs = fabs(io[0]);
    if (vabs * h_lim > k[24])
        h_lim = k[24] / vabs;
    double n = ceil(h / h_lim - 1e-9);
    if (n < 1.0)
        n = 1.0;
    const double hs = h / n;
    const double hh = 0.5 * hs;
    const double h6 = hs / 6.0;
    const double amax = k[25];
    double s[12], k1[12], k2[12], k3[12], k4[12], t[12];
    for (int i = 0; i < 12; i++)
        s[i] = io[i];
    const long nn = (long)n;
    for (long j = 0; j < nn; j++) {
        const double tj = (double)j * hs;
        car_rates(&q, s, tj, k1, 0);
        for (int i = 0; i < 12; i++)
            t[i] = s[i] + hh * k1[i];
        car_rates(&q, t, tj + hh, k2, 0);
        for (int i = 0; i < 12; i++)
            t[i] = s[i] + hh * k2[i];
        car_rates(&q, t, tj + hh, k3, 0);
        for (int i = 0; i < 12; i++)
            t[i] = s[i] + hs * k3[i];
        car_rates(&q, t, tj + hs, k4, 0);
        for (int i = 0; i < 12; i++)
            s[i] = s[i] + h6 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
        s[6] = s[6] > amax ? amax : (s[6] < -amax ? -amax : s[6]);
        s[7] = s[7] > amax ? amax : (s[7] < -amax ? -amax : s[7]);
    }
    /* the outputs (car._outputs with tau = h) */
    double d[12], ex[10];
    car_rates(&q, s, h, d, ex);
    const double trackRear = k[11], h_cg = k[4];
    const double vx = s[0], r = s[2];
    const double half_t = 0.5 * trackRear;
    double dFz = k[26] * m * s[9] * h_cg / trackRear;
    const double half = 0.5 * ex[2];
    dFz = dFz > half ? half : (dFz < -half ? -half : dFz);
    double *o = io + 41;
    const double u = ex[9];
    const double um = k[16] > u ? k[16] : u;            /* max(u, driveTorqueMin) */
    o[0] = vx - r * half_t;
    o[1] = vx + r * half_t;
    o[2] = half - dFz;
    o[3] = half + dFz;
    o[4] = ex[1];
    o[5] = ex[2];
    o[6] = sqrt(vx * vx + s[1] * s[1]);                 /* speed (car._outputs) */
    o[7] = r;
    o[8] = ex[3];
    o[9] = ex[4];
    o[10] = k[15] < um ? k[15] : um;                    /* min(., driveTorqueMax) */
    o[11] = ex[0];
    o[12] = ex[7];
    o[13] = ex[8];
    o[14] = d[0] - d[2] * half_t;
    o[15] = d[0] + d[2] * half_t;
    int ok = 1;
    for (int i = 0; i < 12; i++)
        ok &= isfinite(s[i]) != 0;
    for (int i = 0; i < 16; i++)
        ok &= isfinite(o[i]) != 0;   /* (the speed among them) */
    if (!ok)
        return 1;
    /* the rates of the wheel-side outputs: their mean over the step */
    o[14] = (o[0] - io[25]) / h;
    o[15] = (o[1] - io[26]) / h;
    o[16] = (o[2] - io[27]) / h;
    o[17] = (o[3] - io[28]) / h;
    for (int i = 0; i < 12; i++)
        io[29 + i] = s[i];
    io[59] = n;
    return 0;
}

int64_t vk_wheel_step(const double *kc, double *io)
{
    const double J = kc[0], R = kc[1], B = kc[2], C = kc[3], E = kc[4], kmax = kc[5], f_rr = kc[6];
    const double inv_weps = kc[7], sigma = kc[8], w_eps = kc[9];
    const double hs = io[0], w_in = io[2], dw_in = io[3], mu = io[6], c = io[7], d = io[8], tau0 = io[9];
    const double dFz = io[10], dv = io[11];
    const int torque_in = io[12] != 0.0;
    const long n = (long)io[1];
    double v = io[4], Fz = io[5];
    double D = mu * Fz;
    double Mrr0 = f_rr * Fz * R;
    const double a = 0.5 * hs;
    const double b = a / sigma;
    double q = 1.0 + b * fabs(v);
    double dk_dw = b * R / q;
    const double gs = J + a * (c * a + d);
    double bv = b * v;
    double th0 = io[13], w0 = io[14], k0 = io[15], phi_w = io[16];
    double work_flange = io[17], loss_damping = io[18], work_road = io[19], loss_slip = io[20];
    double loss_rolling = io[21];
    double wa = w_in;
    const int ramp = dFz != 0.0 || dv != 0.0;
    const double v0 = v, Fz0 = Fz;
    for (long i = 0; i < n; i++) {
        if (torque_in)
            wa = w_in + dw_in * ((double)i + 0.5) / (double)n;
        if (ramp) {
            const double tm = ((double)i + 0.5) * hs;
            v = v0 + dv * tm;
            Fz = Fz0 + dFz * tm;
            Fz = Fz > 0.0 ? Fz : 0.0;
            D = mu * Fz;
            Mrr0 = f_rr * Fz * R;
            q = 1.0 + b * fabs(v);
            dk_dw = b * R / q;
            bv = b * v;
        }
        const double th_c = th0 + a * wa;
        const double k_c = (k0 - bv) / q;
        double wm = w0;
        int it;
        for (it = 0; it < 30; it++) {
            const double kk = k_c + dk_dw * wm;
            const double x = B * kk;
            const double phi = x - E * (x - atan(x));
            const double cat = C * atan(phi);
            const double F = D * sin(cat);
            const double dF = D * cos(cat) * C / (1.0 + phi * phi) * B * (1.0 - E + E / (1.0 + x * x));
            const double tnh = tanh(wm * inv_weps);
            const double tau = tau0 + c * (th_c - a * wm) + d * (wa - wm);
            const double g = J * (wm - w0) - a * (tau - R * F - Mrr0 * tnh);
            const double dg = gs + a * (R * dF * dk_dw + Mrr0 * (1.0 - tnh * tnh) * inv_weps);
            if (!(dg > 0.0)) {
                io[47] = dg;
                return 1;
            }
            const double dw = g / dg;
            wm -= dw;
            if (fabs(dw) <= 1e-13 * (1.0 + fabs(wm)))
                break;
        }
        if (it == 30)
            return 2;
        const double th = th_c - a * wm;
        const double kk = k_c + dk_dw * wm;
        const double x = B * kk;
        const double F = D * sin(C * atan(x - E * (x - atan(x))));
        const double M = Mrr0 * tanh(wm * inv_weps);
        const double tau = tau0 + c * th + d * (wa - wm);
        if (torque_in) {
            work_flange += hs * tau * wm;
            phi_w += hs * wm;
        } else {
            work_flange += hs * tau * wa;
            loss_damping += hs * d * (wa - wm) * (wa - wm);
        }
        work_road += hs * F * v;
        loss_slip += hs * F * (R * wm - v);
        loss_rolling += hs * M * wm;
        th0 = 2.0 * th - th0;
        w0 = 2.0 * wm - w0;
        const double k1 = 2.0 * kk - k0;
        k0 = k1 > kmax ? kmax : (k1 < -kmax ? -kmax : k1);
    }
    io[28] = th0; io[29] = w0; io[30] = k0; io[31] = phi_w; io[32] = work_flange; io[33] = loss_damping;
    io[34] = work_road; io[35] = loss_slip; io[36] = loss_rolling;
    /* the outputs (wheel._update_outputs, _update_surrogate) */
    const double w_o = io[22], v1 = io[23], Fz1 = io[24];
    const double cs = kc[10], ds = kc[11];
    double shaft_tau, flange_tau;
    if (io[27] != 0.0) {
        shaft_tau = io[25] + io[26] * (cs * th0 + ds * (w_o - w0));
        flange_tau = 0.0;
    } else {
        shaft_tau = cs * th0 + ds * (w_o - w0);
        flange_tau = -shaft_tau;
    }
    const double x = B * k0;
    const double phi = x - E * (x - atan(x));
    const double cat = C * atan(phi);
    const double Fx = mu * Fz1 * sin(cat);
    io[37] = shaft_tau; io[38] = flange_tau; io[39] = Fx; io[40] = shaft_tau * w_o;
    const double D1 = mu * Fz1;
    const double dF = D1 * cos(cat) * C / (1.0 + phi * phi) * B * (1.0 - E + E / (1.0 + x * x));
    const double M0 = f_rr * Fz1 * R;
    const double tnh = tanh(w0 / w_eps);
    double kdot = (R * w0 - v1 - fabs(v1) * k0) / sigma;
    if (fabs(k0) >= kmax && kdot * k0 > 0.0)
        kdot = 0.0;
    io[41] = -(R * Fx + M0 * tnh) / J;
    io[42] = 1.0 / J;
    io[43] = -M0 * (1.0 - tnh * tnh) / w_eps / J;
    io[44] = R * dF * kdot;
    io[45] = dF > 0.0 ? R * R * dF / sigma : 0.0;
    io[46] = fabs(v1) / sigma;
    return 0;
}

/* The car's whole communication step on its value array v (spurdiff.vehicle.kernel.CarNative, the
 * native step a host calls without Python: Vehicle._load_inputs, _step_compiled and the outputs the
 * FMU reads, in the same operations). v (CAR_NV doubles):
 *   0..8 the inputs rearLeft_Fx, rearRight_Fx, speedTarget, pathRadius, speedTargetRate,
 *   pathRadiusRate, steering_angle_cmd, grade, mu;
 *   9..26 the outputs of car._OUTPUT_KEYS, 27..31 vx, vy, x, y, psi, 32 kinetic_energy;
 *   33..44 the state s, 45 the model's time, 46 n_steps, 47 n_substeps;
 *   48..107 the io array of vk_car_step (scratch); 108, 109 the grade's allowed range;
 *   110..118 the inputs the last step took (the model's input attributes after it).
 * Returns 0 (done), 1 (a non-finite result) or 2 (an input the model refuses, h not positive
 * and finite); on 1 and 2 nothing in v but the scratch changed: the caller runs the Python step,
 * which takes the same step or says what is wrong. */
int64_t vk_car_native(const double *k, double *v, double t, double h)
{
    const double FxL = v[0], FxR = v[1], vref = v[2], R = v[3], dvref = v[4], dR = v[5], dcmd = v[6];
    const double gr = v[7], mu = v[8];
    if (!(isfinite(FxL + FxR + vref + dcmd + gr + mu) && R == R && mu >= 0.0 && v[108] <= gr && gr <= v[109]
          && isfinite(dvref + dR) && h > 0.0 && h < INFINITY))
        return 2;
    double *io = v + 48;
    for (int i = 0; i < 12; i++)
        io[i] = v[33 + i];
    const double kappa = (R == 0.0 || isinf(R)) ? 0.0 : 1.0 / R;
    io[12] = h; io[13] = FxL; io[14] = FxR; io[15] = vref; io[16] = dcmd; io[17] = mu; io[18] = dvref;
    io[19] = dR; io[20] = R; io[21] = kappa; io[22] = atan(k[1] * kappa); io[23] = sin(gr); io[24] = cos(gr);
    io[25] = v[9]; io[26] = v[10]; io[27] = v[11]; io[28] = v[12];
    if (vk_car_step(k, io))
        return 1;
    for (int i = 0; i < 18; i++)
        v[9 + i] = io[41 + i];
    for (int i = 0; i < 12; i++)
        v[33 + i] = io[29 + i];
    const double *s = v + 33;
    v[27] = s[0]; v[28] = s[1]; v[29] = s[4]; v[30] = s[5]; v[31] = s[3];
    v[32] = 0.5 * k[0] * (s[0] * s[0] + s[1] * s[1]) + 0.5 * k[12] * s[2] * s[2];
    v[45] = t + h;
    v[46] += 1.0;
    v[47] += io[59];
    for (int i = 0; i < 9; i++)
        v[110 + i] = v[i];
    return 0;
}

/* The wheel's whole communication step on its value array v (spurdiff.vehicle.kernel.WheelNative:
 * WheelLoad.do_step with its compiled sub-steps, both couplings, and the outputs the FMU reads, in
 * the same operations). v (WHEEL_NV doubles):
 *   0..8 the inputs flange_phi, flange_w, Fz, mu, tau_in, dw_in, vx, dFz, dvx;
 *   9..31 the outputs flange_tau, Fx, wheel_w, phi, sur_a, sur_invJ, sur_dadw, sur_qrate, sur_ct,
 *   sur_rt, slip, shaft_tau, shaft_power, theta, work_flange, work_road, loss_damping, loss_slip,
 *   loss_rolling, energy_dissipated, kinetic_energy, potential_energy, energy_residual;
 *   32..40 the state w, k, phi_ref, w_anchor, t, n_steps, n_substeps, KE0, PE0;
 *   41..45 the configuration: wheel mode (shaftCoupling = wheel), interfaceStiffness, rampAnchor =
 *   end, followFlangeAngle, h_max; 46..93 the io array of vk_wheel_step (scratch); 94..102 the
 *   inputs the last step took (the model's input attributes after it).
 * Returns 0 (done), 1 or 2 (vk_wheel_step's failures), 3 (a non-finite result), 4 (an input the
 * model refuses, h not positive and finite); on failure nothing in v but the scratch changed. */
int64_t vk_wheel_native(const double *kc, double *v, double t, double h)
{
    const double phi_in = v[0], w_in = v[1], mu = v[3], tau_in = v[4], dw_in = v[5];
    double Fz = v[2], vx = v[6];
    const double dFz = v[7], dv = v[8];
    const int wheel_mode = v[41] != 0.0;
    if (!(isfinite(phi_in + w_in + Fz + mu + vx) && mu >= 0.0 && h > 0.0 && h < INFINITY && isfinite(dFz + dv)))
        return 4;
    if (wheel_mode && !isfinite(tau_in + dw_in))
        return 4;
    Fz = Fz > 0.0 ? Fz : 0.0;
    double Fz0 = Fz, v0 = vx;          /* WheelLoad._ramp */
    if (!(dFz == 0.0 && dv == 0.0)) {
        if (v[43] != 0.0) {
            Fz0 = Fz - dFz * h;
            v0 = vx - dv * h;
        } else {
            const double Fz1 = Fz + dFz * h;
            Fz = Fz1 > 0.0 ? Fz1 : 0.0;
            vx = vx + dv * h;
        }
    }
    const double c = kc[10], d = kc[11], J = kc[0];
    double n = ceil(h / v[45] - 1e-9);
    if (n < 1.0)
        n = 1.0;
    double *io = v + 46;
    double theta = v[22], work_flange = v[23];
    if (wheel_mode) {
        const double k_if = v[42] != 0.0 ? 1.0 : 0.0, w0 = v[32];
        const double in[28] = {h / n, n, w0, dw_in, v0, Fz0, mu, k_if * c, k_if * d, tau_in, dFz, dv, 1.0,
                               0.0, w0, v[33], v[12], work_flange, v[25], v[24], v[26], v[27],
                               w0 + dw_in, vx, Fz, tau_in, k_if, 1.0};
        for (int i = 0; i < 28; i++)
            io[i] = in[i];
    } else {
        if (v[44] != 0.0 && v[37] > 0.0) {   /* followFlangeAngle: the twist follows the flange angle */
            const double dphi = phi_in - v[34];
            if (dphi != 0.0) {
                const double th0 = theta;
                theta = th0 + dphi;
                work_flange += 0.5 * c * (theta * theta - th0 * th0);
            }
        }
        const double in[28] = {h / n, n, w_in, 0.0, v0, Fz0, mu, c, d, 0.0, dFz, dv, 0.0,
                               theta, v[32], v[33], v[12], work_flange, v[25], v[24], v[26], v[27],
                               w_in, vx, Fz, 0.0, 0.0, 0.0};
        for (int i = 0; i < 28; i++)
            io[i] = in[i];
    }
    const int64_t rc = vk_wheel_step(kc, io);
    if (rc)
        return rc;
    const double *o = io + 28;   /* theta w k phi work_flange loss_damping work_road loss_slip loss_rolling,
                                    shaft_tau flange_tau Fx shaft_power, sur_a .. sur_rt */
    if (wheel_mode && !(isfinite(o[1] + o[2] + o[3] + o[9] + o[11])))
        return 3;
    const double w = o[1], ke = 0.5 * J * w * w;
    const double pe = wheel_mode ? 0.0 : 0.5 * c * o[0] * o[0];
    const double diss = o[5] + o[7] + o[8];
    const double resid = o[4] - o[6] - (ke - v[39]) - (pe - v[40]) - diss;
    const double out[23] = {o[10], o[11], w, o[3], o[13], o[14], o[15], o[16], o[17], o[18], o[2], o[9], o[12],
                            o[0], o[4], o[6], o[5], o[7], o[8], diss, ke, pe, resid};
    int ok = 1;
    for (int i = 0; i < 23; i++)
        ok &= isfinite(out[i]) != 0;
    if (!ok)
        return 3;
    if (wheel_mode)
        v[35] = v[32];                  /* w_anchor: the speed at the step's start */
    else
        v[34] = phi_in + w_in * h;      /* phi_ref */
    for (int i = 0; i < 23; i++)
        v[9 + i] = out[i];
    v[32] = w;
    v[33] = o[2];
    v[36] = t + h;
    v[37] += 1.0;
    v[38] += n;
    for (int i = 0; i < 9; i++)
        v[94 + i] = v[i];
    return 0;
}
