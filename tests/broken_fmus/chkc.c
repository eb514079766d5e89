/* ChkC: a small FMI 2.0 FMU in C (co-simulation and model exchange) for the compliance-kit tests.

   Model: x' = k u (x a state, start 0), y = k u (direct feedthrough); input u (start 1), fixed
   parameter k (start 2). Built by tests/broken_fmus/chk_build.py with the standard FMI 2.0 headers that
   fmpy ships; what it shares with Chk3C (chk3c.c) is in chk_common.h. Without any BREAK_* macro it follows FMI 2.0 in everything the kit checks; each BREAK_*
   macro breaks one thing that pythonfmu's own C++ layer would not let a Python script break:

   BREAK_VERSION       fmi2GetVersion returns "1.0"
   BREAK_TYPES         fmi2GetTypesPlatform returns "float32"
   BREAK_LOGGER        the logger gets a NULL componentEnvironment and a wrong instance name
   BREAK_GUID          fmi2Instantiate accepts any GUID
   BREAK_DEBUG_LOGGING fmi2SetDebugLogging refuses the declared categories
   BREAK_INIT_GET      fmi2GetReal refused in initialization mode
   BREAK_TERMINATED_GET fmi2GetReal refused after fmi2Terminate
   BREAK_STOP_TIME     a doStep past the defined stop time is accepted
   DISCARD_AT_STOP     a doStep past the stop time is refused with fmi2Discard (status calls answer)
   WARN_AT_STOP        a doStep past the stop time returns fmi2Warning (not a refusal: 2.1.6 wants fmi2Error)
   STRICT_INPUTS       not broken: the input u refused before fmi2EnterInitializationMode, as FMI 2.0 allows
                       (2.1.6: before it only variables with initial exact or approx can be set; an input has no
                       initial), like Test-FMUs 0.0.1 Feedthrough
   BREAK_STATUS        like DISCARD_AT_STOP, but fmi2GetRealStatus(fmi2LastSuccessfulTime) fails
   BREAK_FREE_STATE    fmi2FreeFMUstate leaves the pointer as it was (not NULL)
   BREAK_INTERPOLATE   fmi2SetRealInputDerivatives refused although canInterpolateInputs
   BREAK_DIRDER        fmi2GetDirectionalDerivative refused although providesDirectionalDerivative
   BREAK_JACOBIAN      fmi2GetDirectionalDerivative gives d der(x)/d x = 1 (it is 0)
   BREAK_ME            fmi2CompletedIntegratorStep refused (model exchange)
   BREAK_LATE_STEP     doSteps after t = 0.5 s are refused (fmi2Error): only a long run sees it
   BREAK_STALE_Y       y (declared to depend on u) is computed in fmi2DoStep only: after fmi2SetReal(u)
                       it keeps its old value until the next step
   BREAK_CLOCK         fmi2DoStep ignores currentCommunicationPoint and keeps its own clock: it advances
                       whole internal steps of 0.01 s only (a step of 0.006 s does nothing)
   BREAK_HISTORY       x' = k u integrated with a correction from x before the last step, which the FMU
                       state leaves out (like a multistep integrator's history): a restore continues
                       within 1e-6 of the original run, two restores agree
   BREAK_LIBM          calls exp() from libm; built without -lm, so libm is not declared (DT_NEEDED)
   BREAK_NAN_HANG      a doStep with a NaN input never returns, and a step past the stop time is accepted
                       (so no step is ever discarded: cs.status-after-discard has nothing to check)
*/
#include "fmi2Functions.h"

#ifdef BREAK_NAN_HANG
#define BREAK_STOP_TIME
#endif

#ifndef GUID
#define GUID "{c0ffee00-5b0d-4c1e-9a1e-000000000001}"
#endif

enum { VR_U = 0, VR_K = 1, VR_X = 2, VR_Y = 3, VR_DX = 4 };
enum { INSTANTIATED, INITIALIZATION, STEP, EVENT, CONTINUOUS, TERMINATED };

typedef struct {
    double u, k, x, time, stop, ystale, xprev;
    long nsteps;
    int stopDefined, state, type, logging;
    char name[64];
    fmi2CallbackFunctions cb;
} Inst;

#define CHK_STATUS fmi2Status
#define CHK_OK fmi2OK
#define CHK_ERROR fmi2Error
#define CHK_VR fmi2ValueReference
#define X(m) ((m)->x)
#if defined(DISCARD_AT_STOP) || defined(BREAK_STATUS)
#define CHK_STOP_STATUS fmi2Discard
#elif defined(WARN_AT_STOP)
#define CHK_STOP_STATUS fmi2Warning
#else
#define CHK_STOP_STATUS fmi2Error
#endif
#ifdef BREAK_LOGGER
#define CHK_LOG(m, st, cat, msg) do { if ((m)->cb.logger) (m)->cb.logger(NULL, "someoneElse", st, cat, "%s", msg); } while (0)
#else
#define CHK_LOG(m, st, cat, msg) \
    do { if ((m)->cb.logger) (m)->cb.logger((m)->cb.componentEnvironment, (m)->name, st, cat, "%s", msg); } while (0)
#endif
#include "chk_common.h"

const char *fmi2GetTypesPlatform(void) {
#ifdef BREAK_TYPES
    return "float32";
#else
    return fmi2TypesPlatform;
#endif
}

const char *fmi2GetVersion(void) {
#ifdef BREAK_VERSION
    return "1.0";
#else
    return fmi2Version;
#endif
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cats[]) {
    return debug_logging((Inst *)c, on, n, cats);
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String res,
                              const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean logging) {
    Inst *m;
    (void)res; (void)visible;
    if (!cb || !cb->logger) return NULL;
#ifndef BREAK_GUID
    if (!guid || strcmp(guid, GUID)) {
        cb->logger(cb->componentEnvironment, name, fmi2Error, "logStatusError", "wrong GUID %s", guid ? guid : "(null)");
        return NULL;
    }
#endif
    m = (Inst *)calloc(1, sizeof(Inst));
    if (!m) return NULL;
    m->cb = *cb;
    strncpy(m->name, name ? name : "", sizeof m->name - 1);
    m->type = type;
    m->logging = logging;
    m->u = 1.0; m->k = 2.0; m->x = 0.0;
    m->state = INSTANTIATED;
    return m;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDefined, fmi2Real tol, fmi2Real start,
                               fmi2Boolean stopDefined, fmi2Real stop) {
    (void)tolDefined; (void)tol;
    return start_initialization((Inst *)c, start, stopDefined, stop, "fmi2SetupExperiment");
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    return move((Inst *)c, INSTANTIATED, INITIALIZATION, "fmi2EnterInitializationMode");
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Inst *m = (Inst *)c;
    return exit_initialization(m, m->type == fmi2CoSimulation ? STEP : EVENT, "fmi2ExitInitializationMode");
}

fmi2Status fmi2Terminate(fmi2Component c) { return terminate((Inst *)c, "fmi2Terminate"); }

fmi2Status fmi2Reset(fmi2Component c) {
    Inst *m = (Inst *)c;
    m->u = 1.0; m->k = 2.0; m->x = 0.0; m->time = 0.0; m->nsteps = 0; m->xprev = 0.0;
    m->state = INSTANTIATED;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) {
    Inst *m = (Inst *)c;
    if (m->state == INSTANTIATED) return refuse(m, "fmi2GetReal");
    return get_reals(m, vr, n, v, "fmi2GetReal");
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]) {
    Inst *m = (Inst *)c;
    size_t i;
    for (i = 0; i < n; i++) {
#ifdef STRICT_INPUTS
        if (vr[i] == VR_U && m->state == INSTANTIATED) return refuse(m, "fmi2SetReal (an input before initialization)");
#endif
        if (vr[i] == VR_U) m->u = v[i];
        else if (vr[i] == VR_K && (m->state == INSTANTIATED || m->state == INITIALIZATION)) m->k = v[i];
        else if (vr[i] == VR_X && (m->state == INSTANTIATED || m->state == INITIALIZATION)) m->x = v[i];
        else return refuse(m, "fmi2SetReal");
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
    (void)vr; (void)v; return n ? refuse((Inst *)c, "fmi2GetInteger") : fmi2OK;
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) {
    (void)vr; (void)v; return n ? refuse((Inst *)c, "fmi2GetBoolean") : fmi2OK;
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) {
    (void)vr; (void)v; return n ? refuse((Inst *)c, "fmi2GetString") : fmi2OK;
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) {
    (void)vr; (void)v; return n ? refuse((Inst *)c, "fmi2SetInteger") : fmi2OK;
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) {
    (void)vr; (void)v; return n ? refuse((Inst *)c, "fmi2SetBoolean") : fmi2OK;
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) {
    (void)vr; (void)v; return n ? refuse((Inst *)c, "fmi2SetString") : fmi2OK;
}

CHK_STATE_FUNCTIONS(fmi2Component, fmi2FMUstate, fmi2Byte, fmi2GetFMUstate, fmi2SetFMUstate, fmi2FreeFMUstate,
                    fmi2SerializedFMUstateSize, fmi2SerializeFMUstate, fmi2DeSerializeFMUstate)

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference unk[], size_t nu,
                                        const fmi2ValueReference kn[], size_t nk, const fmi2Real dk[], fmi2Real du[]) {
#ifdef BREAK_DIRDER
    return refuse((Inst *)c, "fmi2GetDirectionalDerivative");
#endif
    directional_derivative((Inst *)c, unk, nu, kn, nk, dk, du);
    return fmi2OK;
}

/* ---- co-simulation */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real v[]) {
    Inst *m = (Inst *)c;
    (void)vr; (void)n; (void)order; (void)v;
#ifdef BREAK_INTERPOLATE
    return refuse(m, "fmi2SetRealInputDerivatives");
#endif
    return m->state == INSTANTIATED ? refuse(m, "fmi2SetRealInputDerivatives") : fmi2OK;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real v[]) {
    (void)vr; (void)n; (void)order; (void)v; return refuse((Inst *)c, "fmi2GetRealOutputDerivatives");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noPrior) {
    Inst *m = (Inst *)c;
    fmi2Status st;
    (void)noPrior;
    if (m->state != STEP) return refuse(m, "fmi2DoStep");
    if ((st = step_checks(m, t, h, "fmi2DoStep (late)")) != fmi2OK) return st;
    if (!isfinite(m->u)) {
#ifdef BREAK_NAN_HANG
        volatile int spin = 1;
        while (spin) {}
#endif
        return fmi2Discard;
    }
#if defined(BREAK_CLOCK)
    own_clock_step(m, h);
#elif defined(BREAK_HISTORY)
    {   /* a correction by the direction x last moved in: xprev is not in the saved FMU state, so the
           first step after a restore (xprev from a later time) is corrected the other way */
        double sign = m->x >= m->xprev ? 1.0 : -1.0;
        m->xprev = m->x;
        m->x += m->k * m->u * h * (1.0 + 1e-6 * sign);
    }
    m->time = t + h;
#elif defined(BREAK_LIBM)
    m->x += m->k * m->u * h * exp(0.0 * m->x);
    m->time = t + h;
#else
    m->x += m->k * m->u * h;
    m->time = t + h;
#endif
#ifdef BREAK_STALE_Y
    m->ystale = m->k * m->u;
#endif
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) { return refuse((Inst *)c, "fmi2CancelStep"); }

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *v) {
    (void)c; (void)s; (void)v; return fmi2Discard;
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v) {
    Inst *m = (Inst *)c;
#ifdef BREAK_STATUS
    return refuse(m, "fmi2GetRealStatus");
#endif
    if (s != fmi2LastSuccessfulTime) return fmi2Discard;
    *v = m->time;
    return fmi2OK;
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *v) {
    (void)c; (void)s; (void)v; return fmi2Discard;
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *v) {
    (void)c;
    if (s != fmi2Terminated) return fmi2Discard;
    *v = fmi2False;
    return fmi2OK;
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *v) {
    (void)c; (void)s; (void)v; return fmi2Discard;
}

/* ---- model exchange */
fmi2Status fmi2EnterEventMode(fmi2Component c) {
    Inst *m = (Inst *)c;
    if (m->state != CONTINUOUS && m->state != EVENT) return refuse(m, "fmi2EnterEventMode");
    m->state = EVENT;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *e) {
    Inst *m = (Inst *)c;
    if (m->state != EVENT) return refuse(m, "fmi2NewDiscreteStates");
    memset(e, 0, sizeof *e);
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    return move((Inst *)c, EVENT, CONTINUOUS, "fmi2EnterContinuousTimeMode");
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noPrior, fmi2Boolean *enter, fmi2Boolean *term) {
    Inst *m = (Inst *)c;
    (void)noPrior;
#ifdef BREAK_ME
    return refuse(m, "fmi2CompletedIntegratorStep");
#endif
    if (m->state != CONTINUOUS) return refuse(m, "fmi2CompletedIntegratorStep");
    *enter = fmi2False;
    *term = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) {
    Inst *m = (Inst *)c;
    m->time = t;
    return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n) {
    Inst *m = (Inst *)c;
    if (n != 1 || m->state != CONTINUOUS) return refuse(m, "fmi2SetContinuousStates");
    m->x = x[0];
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real dx[], size_t n) {
    Inst *m = (Inst *)c;
    if (n != 1) return refuse(m, "fmi2GetDerivatives");
    dx[0] = m->k * m->u;
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real z[], size_t n) {
    (void)c; (void)z; return n ? fmi2Error : fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    Inst *m = (Inst *)c;
    if (n != 1) return refuse(m, "fmi2GetContinuousStates");
    x[0] = m->x;
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    (void)c; if (n == 1) x[0] = 1.0; return fmi2OK;
}
