/* SpurDifferential.fmu in a C host (FMI 2.0 co-simulation): written by `spurdiff starter --host c`
 * (docs/use-the-fmu.md), which filled in the FMU's folder, GUID and value references below.
 *
 * The load case (as the fmpy recipe): a steady left turn, the wheel ends of the half-shafts
 * turning at the rear wheels' speeds (inner 29.5455 rad/s, outer 31.8866 rad/s), the carrier
 * driven by 152.4 N m (carrierDrive = torque). INTERFACE says who owns the half-shafts:
 *   "wheel":  the FMU (shaftCoupling = wheel): every step set leftWheel.phi / .w and
 *             rightWheel.phi / .w (the angle advancing with the speed), read leftShaft.tau /
 *             rightShaft.tau. Any step up to 20 ms.
 *   "torque": this host (shaftCoupling = torque): every step read left.phi / .w and right.phi / .w,
 *             compute the shaft torques, set left.tau / right.tau (a load is negative). The suns'
 *             1,530 rad/s mode runs through the coupling: a step of at most about 0.45 ms.
 * Build and run:   cc -O2 -o host host.c -ldl && ./host [stop time, s]
 * Prints the means over the last 40 % of the run: shaft torques, locking torque, speeds. */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define FMU_DIR "@FMU_DIR@"                 /* the unzipped FMU */
#define MODEL_ID "@MODEL_ID@"
#define GUID "@GUID@"
#define INTERFACE "@INTERFACE@"             /* wheel | torque */
#define STEP @STEP@                         /* communication step, s */

#define W_INNER 29.5455                     /* rad/s, wheel end of the left (inner) half-shaft */
#define W_OUTER 31.8866                     /* rad/s, right (outer) */
#define DRIVE_TORQUE 152.4                  /* N m on the carrier */
#define SHAFT_C 8000.0                      /* N m/rad, the host's half-shafts (torque interface) */
#define SHAFT_D 10.0                        /* N m s/rad */

/* value references (from modelDescription.xml) */
enum {
    VR_carrierDrive = @VR:carrierDrive@, VR_shaftCoupling = @VR:shaftCoupling@,
    VR_carrier_w_start = @VR:carrier.w_start@, VR_differential_w_start = @VR:differential.w_start@,
    VR_carrier_tau = @VR:carrier.tau@,
    VR_left_tau = @VR:left.tau@, VR_right_tau = @VR:right.tau@,
    VR_leftWheel_phi = @VR:leftWheel.phi@, VR_leftWheel_w = @VR:leftWheel.w@,
    VR_rightWheel_phi = @VR:rightWheel.phi@, VR_rightWheel_w = @VR:rightWheel.w@,
    VR_left_phi = @VR:left.phi@, VR_left_w = @VR:left.w@, VR_right_phi = @VR:right.phi@, VR_right_w = @VR:right.w@,
    VR_leftShaft_tau = @VR:leftShaft.tau@, VR_rightShaft_tau = @VR:rightShaft.tau@,
    VR_lockingTorque = @VR:lockingTorque@, VR_carrier_w = @VR:carrier.w@,
};

typedef void *fmi2Component;
typedef unsigned int fmi2ValueReference;
typedef struct {
    void (*logger)(void *, const char *, int, const char *, const char *, ...);
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void *stepFinished;
    void *componentEnvironment;
} fmi2CallbackFunctions;

static void logger(void *env, const char *name, int status, const char *category, const char *message, ...) {
    va_list ap;
    (void)env;
    va_start(ap, message);
    fprintf(stderr, "[%s %s] ", name, category);
    vfprintf(stderr, message, ap);
    fprintf(stderr, "\n");
    va_end(ap);
    (void)status;
}

typedef fmi2Component (*instantiate_t)(const char *, int, const char *, const char *, const fmi2CallbackFunctions *,
                                       int, int);
typedef int (*setup_t)(fmi2Component, int, double, double, int, double);
typedef int (*call_t)(fmi2Component);
typedef int (*step_t)(fmi2Component, double, double, int);
typedef int (*getreal_t)(fmi2Component, const fmi2ValueReference *, size_t, double *);
typedef int (*setreal_t)(fmi2Component, const fmi2ValueReference *, size_t, const double *);
typedef int (*setstring_t)(fmi2Component, const fmi2ValueReference *, size_t, const char *const *);
typedef void (*free_t)(fmi2Component);

#define SYM(type, name) type name = (type)dlsym(lib, #name); \
    if (!name) { fprintf(stderr, "%s: no %s\n", MODEL_ID, #name); return 2; }
#define OK(call) if ((call) > 1) { fprintf(stderr, "%s failed at t = %g s\n", #call, t); return 3; }

int main(int argc, char **argv) {
    double stop = argc > 1 ? atof(argv[1]) : 0.5;
    double t = 0.0;
    int wheel = strcmp(INTERFACE, "wheel") == 0;
    void *lib = dlopen(FMU_DIR "/binaries/linux64/" MODEL_ID ".so", RTLD_NOW | RTLD_LOCAL);
    if (!lib) { fprintf(stderr, "dlopen: %s\n", dlerror()); return 2; }
    SYM(instantiate_t, fmi2Instantiate)
    SYM(setup_t, fmi2SetupExperiment)
    SYM(call_t, fmi2EnterInitializationMode)
    SYM(call_t, fmi2ExitInitializationMode)
    SYM(step_t, fmi2DoStep)
    SYM(getreal_t, fmi2GetReal)
    SYM(setreal_t, fmi2SetReal)
    SYM(setstring_t, fmi2SetString)
    SYM(call_t, fmi2Terminate)
    SYM(free_t, fmi2FreeInstance)

    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c = fmi2Instantiate("diff", 1 /* fmi2CoSimulation */, GUID, "file://" FMU_DIR "/resources", &cb, 0, 0);
    if (!c) { fprintf(stderr, "fmi2Instantiate failed (see the log above)\n"); return 2; }

    /* parameters: the carrier torque-driven at the mean wheel speed, the suns at the wheel speeds */
    const fmi2ValueReference vr_s[2] = {VR_carrierDrive, VR_shaftCoupling};
    const char *const s_val[2] = {"torque", INTERFACE};
    const double wc = 0.5 * (W_INNER + W_OUTER);
    const fmi2ValueReference vr_p[3] = {VR_carrier_w_start, VR_differential_w_start, VR_carrier_tau};
    const double p_val[3] = {wc, W_INNER - wc, DRIVE_TORQUE};
    const fmi2ValueReference vr_wheel[4] = {VR_leftWheel_phi, VR_leftWheel_w, VR_rightWheel_phi, VR_rightWheel_w};
    const fmi2ValueReference vr_sun[4] = {VR_left_phi, VR_left_w, VR_right_phi, VR_right_w};
    const fmi2ValueReference vr_flange[2] = {VR_left_tau, VR_right_tau};
    const fmi2ValueReference vr_out[4] = {VR_leftShaft_tau, VR_rightShaft_tau, VR_lockingTorque, VR_carrier_w};
    double u[4], y[4], sun[4], tau[2], sum[4] = {0, 0, 0, 0};

    OK(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0))
    OK(fmi2EnterInitializationMode(c))
    OK(fmi2SetString(c, vr_s, 2, s_val))
    OK(fmi2SetReal(c, vr_p, 3, p_val))
    long n = (long)(stop / STEP + 0.5), first = n - (long)(0.4 * n), counted = 0;
    for (long k = 0; k <= n; k++) {
        t = k * STEP;
        if (wheel) {            /* the wheel ends' angle and speed at the communication point */
            u[0] = W_INNER * t; u[1] = W_INNER; u[2] = W_OUTER * t; u[3] = W_OUTER;
            OK(fmi2SetReal(c, vr_wheel, 4, u))
        } else {                /* the host's half-shafts: torque on each sun flange from the twist */
            OK(fmi2GetReal(c, vr_sun, 4, sun))
            tau[0] = -(SHAFT_C * (sun[0] - W_INNER * t) + SHAFT_D * (sun[1] - W_INNER));
            tau[1] = -(SHAFT_C * (sun[2] - W_OUTER * t) + SHAFT_D * (sun[3] - W_OUTER));
            OK(fmi2SetReal(c, vr_flange, 2, tau))
        }
        if (k == 0) OK(fmi2ExitInitializationMode(c))
        if (k >= first) {       /* outputs at t (the end of the previous step) */
            OK(fmi2GetReal(c, vr_out, 4, y))
            for (int i = 0; i < 4; i++) sum[i] += y[i];
            counted++;
        }
        if (k < n) OK(fmi2DoStep(c, t, STEP, 1))
    }
    printf("shaftCoupling = %s, step %g s, means over the last %ld samples:\n", INTERFACE, STEP, counted);
    printf("inner (left) shaft torque  %.9f N m\n", sum[0] / counted);
    printf("outer (right) shaft torque %.9f N m\n", sum[1] / counted);
    printf("locking torque             %.9f N m\n", sum[2] / counted);
    printf("carrier speed              %.9f rad/s\n", sum[3] / counted);
    fmi2Terminate(c);
    fmi2FreeInstance(c);
    return 0;
}
