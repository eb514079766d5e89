/* A shim around a Reference FMU's FMI 3.0 binary that breaks one thing (issue 28 item 4: each FMI 3.0 rule
 * of the compliance kit catches a broken FMU of its own).
 *
 * tests/broken_fmus/chk3_build.py renames the Reference FMU's <id>.so (and its SONAME) to ORIG_LIB and
 * builds this file as <id>.so with ORIG_LIB as a needed library: every fmi3* function this file does not
 * define is found in ORIG_LIB (dlsym searches the shim's dependencies); the functions below wrap the
 * original, which they find with dlopen(ORIG_LIB next to this file) + dlsym. Exactly one BREAK_x is defined:
 *
 *   BREAK_BASIC           fmi3DoStep always returns fmi3Error                          -> cs3.basic
 *   BREAK_VERSION         fmi3GetVersion returns "2.0"                                 -> cs3.version
 *   BREAK_TOKEN           fmi3Instantiate* pass the right token whatever they get      -> *.instantiation-token
 *   BREAK_INIT_GET        fmi3GetFloat64 returns fmi3Error in Initialization Mode       -> cs3.initial-unknowns
 *   BREAK_STOP_TIME       the stop time is not passed on (stopTimeDefined = false)      -> cs3.stop-time
 *   BREAK_TERMINATED_GET  fmi3GetFloat64 returns fmi3Error after fmi3Terminate          -> cs3.get-after-terminate
 *   BREAK_RESET           fmi3Reset returns fmi3OK and resets nothing                   -> cs3.reset
 *   BREAK_STATE_NOOP      fmi3SetFMUState returns fmi3OK and restores nothing           -> cs3.get-set-state
 *   BREAK_EARLY_STEP      fmi3DoStep before initialization returns fmi3OK               -> cs3.step-before-init
 *   BREAK_ZERO_STEP       fmi3DoStep with step size <= 0 returns fmi3Discard            -> cs3.zero-step-size
 *   BREAK_LATE_STEP       fmi3DoStep refused (fmi3Error) from t >= LATE_T on            -> cs3.default-experiment
 *   BREAK_ME              fmi3CompletedIntegratorStep returns fmi3Error                 -> me3.basic
 *   BREAK_DERIV_ORDER     fmi3GetOutputDerivatives gives 0 for order 1, fmi3Discard for    -> cs3.output-derivative-orders
 *                         the orders it must refuse with fmi3Error (0, > 1)
 *   BREAK_DERIV_NAN       fmi3GetOutputDerivatives gives NaN for order 1 (fmi3Error else)  -> cs3.output-derivatives
 *                         (both with maxOutputDerivativeOrder="1" in modelDescription.xml: chk3_build)
 *   BREAK_EARLY_ANYWAY    fmi3InstantiateCoSimulation passes earlyReturnAllowed = true      -> cs3.early-return-not-allowed
 *   BREAK_EARLY_TIME      an early return reports lastSuccessfulTime = t + 2 h              -> cs3.early-return-time
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

typedef void *inst_t;

static void *orig(const char *name) {
    static void *lib = NULL;
    if (!lib) {
        Dl_info info;
        char path[4096];
        dladdr((void *)&orig, &info);
        snprintf(path, sizeof path, "%s", info.dli_fname);
        char *slash = strrchr(path, '/');
        snprintf(slash ? slash + 1 : path, sizeof path - (size_t)(slash ? slash + 1 - path : 0), "%s", ORIG_LIB);
        lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    }
    return lib ? dlsym(lib, name) : NULL;
}

#define ORIG(type, name) ((type)orig(name))

static int in_init = 0, terminated = 0, initialized = 0;

typedef inst_t (*inst_cs_t)(const char *, const char *, const char *, bool, bool, bool, bool, const uint32_t *,
                            size_t, void *, void *, void *);
typedef inst_t (*inst_me_t)(const char *, const char *, const char *, bool, bool, void *, void *);
typedef int (*enter_init_t)(inst_t, bool, double, double, bool, double);
typedef int (*one_t)(inst_t);
typedef int (*get_f64_t)(inst_t, const uint32_t *, size_t, double *, size_t);
typedef int (*do_step_t)(inst_t, double, double, bool, bool *, bool *, bool *, double *);
typedef int (*set_state_t)(inst_t, void *);
typedef int (*completed_t)(inst_t, bool, bool *, bool *);

inst_t fmi3InstantiateCoSimulation(const char *name, const char *token, const char *res, bool visible, bool logging,
                                   bool eventMode, bool earlyReturn, const uint32_t *req, size_t nreq, void *env,
                                   void *log, void *update) {
    in_init = terminated = initialized = 0;
#ifdef BREAK_TOKEN
    token = TOKEN;
#endif
#ifdef BREAK_EARLY_ANYWAY
    earlyReturn = true;
#endif
    return ORIG(inst_cs_t, "fmi3InstantiateCoSimulation")(name, token, res, visible, logging, eventMode, earlyReturn,
                                                          req, nreq, env, log, update);
}

inst_t fmi3InstantiateModelExchange(const char *name, const char *token, const char *res, bool visible, bool logging,
                                    void *env, void *log) {
    in_init = terminated = initialized = 0;
#ifdef BREAK_TOKEN
    token = TOKEN;
#endif
    return ORIG(inst_me_t, "fmi3InstantiateModelExchange")(name, token, res, visible, logging, env, log);
}

const char *fmi3GetVersion(void) {
#ifdef BREAK_VERSION
    return "2.0";
#else
    return ((const char *(*)(void))orig("fmi3GetVersion"))();
#endif
}

int fmi3EnterInitializationMode(inst_t c, bool tolDefined, double tol, double start, bool stopDefined, double stop) {
    in_init = 1;
#ifdef BREAK_STOP_TIME
    stopDefined = false;
#endif
    return ORIG(enter_init_t, "fmi3EnterInitializationMode")(c, tolDefined, tol, start, stopDefined, stop);
}

int fmi3ExitInitializationMode(inst_t c) {
    in_init = 0;
    initialized = 1;
    return ORIG(one_t, "fmi3ExitInitializationMode")(c);
}

int fmi3Terminate(inst_t c) {
    terminated = 1;
    return ORIG(one_t, "fmi3Terminate")(c);
}

int fmi3Reset(inst_t c) {
    in_init = terminated = initialized = 0;
#ifdef BREAK_RESET
    (void)c;
    return 0;
#else
    return ORIG(one_t, "fmi3Reset")(c);
#endif
}

int fmi3GetFloat64(inst_t c, const uint32_t *vr, size_t nvr, double *values, size_t nValues) {
#ifdef BREAK_INIT_GET
    if (in_init) return 3;
#endif
#ifdef BREAK_TERMINATED_GET
    if (terminated) return 3;
#endif
    return ORIG(get_f64_t, "fmi3GetFloat64")(c, vr, nvr, values, nValues);
}

int fmi3DoStep(inst_t c, double t, double h, bool noSet, bool *event, bool *terminate, bool *early, double *last) {
#ifdef BREAK_BASIC
    return 3;
#endif
#ifdef BREAK_EARLY_STEP
    if (!initialized) { *event = *terminate = *early = false; *last = t + h; return 0; }
#endif
#ifdef BREAK_ZERO_STEP
    if (h <= 0) return 2;
#endif
#ifdef BREAK_LATE_STEP
    if (t >= LATE_T) return 3;
#endif
#ifdef BREAK_EARLY_TIME
    int st = ORIG(do_step_t, "fmi3DoStep")(c, t, h, noSet, event, terminate, early, last);
    if (*early) *last = t + 2 * h;
    return st;
#endif
    return ORIG(do_step_t, "fmi3DoStep")(c, t, h, noSet, event, terminate, early, last);
}

#if defined(BREAK_DERIV_ORDER) || defined(BREAK_DERIV_NAN)
int fmi3GetOutputDerivatives(inst_t c, const uint32_t *vr, size_t nvr, const int32_t *orders, double *values,
                             size_t nValues) {
    (void)c; (void)vr; (void)nValues;
    for (size_t i = 0; i < nvr; i++) {
        if (orders[i] != 1) {
#ifdef BREAK_DERIV_ORDER
            return 2;
#else
            return 3;
#endif
        }
#ifdef BREAK_DERIV_ORDER
        values[i] = 0.0;
#else
        values[i] = 0.0 / 0.0;
#endif
    }
    return 0;
}
#endif

int fmi3SetFMUState(inst_t c, void *state) {
#ifdef BREAK_STATE_NOOP
    (void)c; (void)state;
    return 0;
#else
    return ORIG(set_state_t, "fmi3SetFMUState")(c, state);
#endif
}

int fmi3CompletedIntegratorStep(inst_t c, bool noSet, bool *enterEventMode, bool *terminate) {
#ifdef BREAK_ME
    (void)c; (void)noSet; (void)enterEventMode; (void)terminate;
    return 3;
#else
    return ORIG(completed_t, "fmi3CompletedIntegratorStep")(c, noSet, enterEventMode, terminate);
#endif
}
