/*
 * Shared declarations of the compiled mesh kernel (mesh_kernel_model.c: the model evaluation;
 * mesh_kernel.c: the method, events, stick-slip, the driver and the exported functions). The
 * structures are mirrored by fmu_src/spurdiff/differential/mesh/kernel.py field by field (doubles and 64-bit
 * integers only, so there is no padding).
 */
#ifndef MESH_KERNEL_H
#define MESH_KERNEL_H
#include <math.h>
#include <stdint.h>
#include <string.h>

#define MK_ABI 9
#define NMAX 10
#define MSPLIT 4      /* the velocities of the split (layout.split) */
#define SMAX 8        /* the most stages of a method (spurdiff.differential.mesh.integrator.SMAX) */
enum { PSI, DA, DB, D12, VA, VB, W1, W2, WC, PHIC };
enum { LAW_BILATERAL = 0, LAW_ELASTO = 1, LAW_IMPACT = 2 };
enum { MK_OK = 0, MK_MAX_STEPS = 1, MK_HMIN = 2 };

typedef struct {
    double sigma, rb1, rb2, k, c, K, jn, eps, pb, l1min, galpha, L, xi0, xi0c, xip, a1, a2;
    int64_t d, g1, g2;
} MkMesh;

typedef struct {
    int64_t N, speed_drive, law, wave, tracked, flank, pin, bl, contact, dissipative, var, max_steps, n;
    int64_t stages, w_method, loss5;        /* the method: stages, a W-method?, five-point loss quadrature? */
    double rbA, rb1, rbB, rb2, JA, JB, J1, J2, Jc, Jtot, lam;
    double e, C, dmax;                       /* IMPACT */
    double mu_s, mu_d, v_s, v_d;             /* flank friction */
    double c_pin, M01, M02;
    double pin_flat[2][8];                   /* spurdiff.gears.layout.PinLayout._flat */
    double Minv[5][5];                       /* torque drive: inverse mass matrix (w_c, v_A, v_B, w_1, w_2) */
    double atol[NMAX], rtol, w_stick;
    double gamma, err_exp, a[SMAX][SMAX], cc[SMAX][SMAX], m[SMAX], ew[SMAX], dmid[SMAX];   /* transformed tableau */
    double dq[2][SMAX];                      /* dense output at theta = 1/4, 3/4 (loss5) */
    MkMesh md[3];
    double dpoly[4][SMAX];                   /* dense output: d_j(theta) = sum_p dpoly[p][j] theta^(p+1) */
    double c_pind;                           /* the pins' sliding lever (mu_pinDynamic); c_pin: stuck, break-away */
    double pin_ends[2][18];                  /* PinLayout.ends: end 0's 8 constants, its share w0, end L's 8, wL */
    int64_t pin3d[2];                        /* the journal's end L counts (not planar) */
} MkParams;

typedef struct {
    double y[NMAX];
    double w_ref, tau_c, tau_L, tau_R;
    double ac, wc, phic, t, h_next, work_in, energy_loss, parametric_work, loss_last_step, last_h;
    double dA0, dB0, d120;
    double sv[13];            /* side values of the outputs at the end (spurdiff.differential.mesh.forces.SideValues) */
    int64_t s[2], flags[6], n_flags;
    int64_t n_internal_steps, n_rejected_steps, n_mode_switches, n_contact_transitions, n_steps;
    double fail_t, fail_h;    /* where a step failed */
    /* the integrator's memory between communication steps (spurdiff.differential.mesh.stepper, .integrator) */
    double Jf[NMAX * NMAX];   /* the Jacobian the steps use (c._integ.J), row-major N x N */
    double LU[NMAX * NMAX];   /* W = I/(gamma lu_h) - Jf factored: N = 8 integrator.split_factor's S^-1, J_vp, B
                                 (4 x 4 each, row-major, at 0, 16, 32); N = 10 L and U in one (row-major) */
    double f0c[NMAX], sv0c[13], key[4];   /* f and side values at y for the inputs in key, key_s */
    double lu_h;              /* step size of LU; 0: none */
    int32_t piv[NMAX];
    int64_t key_s[2], cache_ok, jac_age;  /* jac_age: accepted steps since Jf was evaluated, -1: none */
    int64_t n_jac, n_lu;      /* Jacobian evaluations and factorizations of W (diagnostics) */
    double gpin[4];           /* the planets' inertial forces (g1x g1y g2x g2y, N): centrifugal at the step's start
                                 speed plus tangential at the carrier acceleration held over the step */
    /* the phase modes held over an internal step (forces.MeshPhase.mode; model._mode): per mesh the drive
     * and coast flanks' tooth count k and pairs in contact n_c; phold = 0: from the state at each evaluation */
    double pk[6];
    int64_t pnc[6], phold;
    int64_t n_psw;            /* loaded flanks' phase-mode switches (diagnostics, as n_jac) */
} MkState;

typedef struct { double F, dF_dd, dF_dv, Fc, xi, sx; int64_t nc; } Force;
typedef struct { double M1, M2, dM1F, dM2F, d11, d12, d22, P, dM1x, dM2x; } Moments;
enum { SV_FA, SV_FB, SV_F12, SV_QA, SV_QB, SV_Q1, SV_Q2, SV_M1, SV_M2, SV_CAP1, SV_CAP2, SV_P, SV_AC };

#define MK_HIDDEN __attribute__((visibility("hidden")))
MK_HIDDEN double mk_pymod(double x, double w);
MK_HIDDEN double mk_wave_factor(const MkParams *P, const MkMesh *m, double xi);
MK_HIDDEN double mk_law_potential(const MkParams *P, const MkMesh *m, double d, double kp, double kn);
MK_HIDDEN void mk_relative_angles(const MkState *S, const MkParams *P, const double *y, double *psiB, double *th1,
                                  double *th2);
MK_HIDDEN void mk_phase_mode(const MkParams *P, const MkState *S, const double *y, double *pk, int64_t *pnc);
MK_HIDDEN void mk_eval(const MkParams *P, const MkState *S, const double *y, double *f, double *J, double *sv);

#endif
