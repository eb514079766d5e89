/* ChkC: a small FMI 2.0 FMU in C (co-simulation and model exchange) for the compliance-kit tests.

   Model: x' = k u (x a state, start 0), y = k u (direct feedthrough); input u (start 1), fixed
   parameter k (start 2). Built by tests/check_fmus.py with the standard FMI 2.0 headers that fmpy
   ships. Without any BREAK_* macro it follows FMI 2.0 in everything the kit checks; each BREAK_*
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
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

typedef struct { double u, k, x, time; int state; } Saved;

static void logmsg(Inst *m, fmi2Status st, const char *cat, const char *fmt, ...) {
    char buf[256];
    va_list ap;
    if (!m->cb.logger) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
#ifdef BREAK_LOGGER
    m->cb.logger(NULL, "someoneElse", st, cat, "%s", buf);
#else
    m->cb.logger(m->cb.componentEnvironment, m->name, st, cat, "%s", buf);
#endif
}

static fmi2Status refuse(Inst *m, const char *fn) {
    logmsg(m, fmi2Error, "logStatusError", "%s: illegal call in this state", fn);
    return fmi2Error;
}

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
    Inst *m = (Inst *)c;
    size_t i;
    for (i = 0; i < n; i++) {
#ifdef BREAK_DEBUG_LOGGING
        return fmi2Error;
#endif
        if (strcmp(cats[i], "logStatusError") && strcmp(cats[i], "logEvents")) {
            logmsg(m, fmi2Error, "logStatusError", "unknown log category %s", cats[i]);
            return fmi2Error;
        }
    }
    m->logging = on;
    return fmi2OK;
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
    Inst *m = (Inst *)c;
    (void)tolDefined; (void)tol;
    if (m->state != INSTANTIATED) return refuse(m, "fmi2SetupExperiment");
    m->time = start;
    m->stopDefined = stopDefined;
    m->stop = stop;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    Inst *m = (Inst *)c;
    if (m->state != INSTANTIATED) return refuse(m, "fmi2EnterInitializationMode");
    m->state = INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Inst *m = (Inst *)c;
    if (m->state != INITIALIZATION) return refuse(m, "fmi2ExitInitializationMode");
    m->ystale = m->k * m->u;
    m->state = m->type == fmi2CoSimulation ? STEP : EVENT;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    Inst *m = (Inst *)c;
    if (m->state == INSTANTIATED || m->state == INITIALIZATION || m->state == TERMINATED)
        return refuse(m, "fmi2Terminate");
    m->state = TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    Inst *m = (Inst *)c;
    m->u = 1.0; m->k = 2.0; m->x = 0.0; m->time = 0.0; m->nsteps = 0; m->xprev = 0.0;
    m->state = INSTANTIATED;
    return fmi2OK;
}

static double value(Inst *m, fmi2ValueReference vr, int *ok) {
    *ok = 1;
    switch (vr) {
    case VR_U: return m->u;
    case VR_K: return m->k;
    case VR_X: return m->x;
#ifdef BREAK_STALE_Y
    case VR_Y: return m->ystale;
#else
    case VR_Y: return m->k * m->u;
#endif
    case VR_DX: return m->k * m->u;
    }
    *ok = 0;
    return 0.0;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) {
    Inst *m = (Inst *)c;
    size_t i;
    int ok;
    if (m->state == INSTANTIATED) return refuse(m, "fmi2GetReal");
#ifdef BREAK_INIT_GET
    if (m->state == INITIALIZATION) return refuse(m, "fmi2GetReal");
#endif
#ifdef BREAK_TERMINATED_GET
    if (m->state == TERMINATED) return refuse(m, "fmi2GetReal");
#endif
    for (i = 0; i < n; i++) {
        v[i] = value(m, vr[i], &ok);
        if (!ok) return refuse(m, "fmi2GetReal (value reference)");
    }
    return fmi2OK;
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

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) {
    Inst *m = (Inst *)c;
    Saved *p = *s ? (Saved *)*s : (Saved *)malloc(sizeof(Saved));
    if (!p) return fmi2Error;
    p->u = m->u; p->k = m->k; p->x = m->x; p->time = m->time; p->state = m->state;
    *s = p;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) {
    Inst *m = (Inst *)c;
    Saved *p = (Saved *)s;
    if (!p) return refuse(m, "fmi2SetFMUstate (NULL)");
    m->u = p->u; m->k = p->k; m->x = p->x; m->time = p->time; m->state = p->state;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) {
    (void)c;
    if (!s || !*s) return fmi2OK;
    free(*s);
#ifndef BREAK_FREE_STATE
    *s = NULL;
#endif
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) {
    (void)c; (void)s; *n = sizeof(Saved); return fmi2OK;
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) {
    (void)c; if (n != sizeof(Saved)) return fmi2Error; memcpy(b, s, n); return fmi2OK;
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s) {
    (void)c;
    if (n != sizeof(Saved)) return fmi2Error;
    if (!*s) *s = malloc(sizeof(Saved));
    if (!*s) return fmi2Error;
    memcpy(*s, b, n);
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference unk[], size_t nu,
                                        const fmi2ValueReference kn[], size_t nk, const fmi2Real dk[], fmi2Real du[]) {
    Inst *m = (Inst *)c;
    size_t i, j;
#ifdef BREAK_DIRDER
    return refuse(m, "fmi2GetDirectionalDerivative");
#endif
    for (i = 0; i < nu; i++) {
        du[i] = 0.0;
        for (j = 0; j < nk; j++)
            if (kn[j] == VR_U && (unk[i] == VR_Y || unk[i] == VR_DX)) du[i] += m->k * dk[j];
#ifdef BREAK_JACOBIAN
            else if (kn[j] == VR_X && unk[i] == VR_DX) du[i] += dk[j];
#endif
    }
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
    (void)noPrior;
    if (m->state != STEP) return refuse(m, "fmi2DoStep");
    if (!(h > 0)) {
        logmsg(m, fmi2Error, "logStatusError", "step size must be > 0, was %g", h);
        return fmi2Error;
    }
#ifndef BREAK_CLOCK
    if (fabs(t - m->time) > 1e-9 * (1.0 + fabs(t))) {
        logmsg(m, fmi2Error, "logStatusError", "communication point %g, expected %g", t, m->time);
        return fmi2Error;
    }
#endif
#ifndef BREAK_STOP_TIME
    if (m->stopDefined && t + h > m->stop + 1e-9 * (1.0 + fabs(m->stop))) {
        logmsg(m, fmi2Error, "logStatusError", "a step to %g passes the stop time %g", t + h, m->stop);
#if defined(DISCARD_AT_STOP) || defined(BREAK_STATUS)
        return fmi2Discard;
#elif defined(WARN_AT_STOP)
        return fmi2Warning;
#else
        return fmi2Error;
#endif
    }
#endif
#ifdef BREAK_LATE_STEP
    if (t >= 0.5) return refuse(m, "fmi2DoStep (late)");
#endif
    if (!isfinite(m->u)) {
#ifdef BREAK_NAN_HANG
        volatile int spin = 1;
        while (spin) {}
#endif
        return fmi2Discard;
    }
#if defined(BREAK_CLOCK)
    {   /* its own clock: whole internal steps of 0.01 s from where it was, whatever t says */
        long n = (long)floor(h / 0.01 + 1e-9);
        m->x += m->k * m->u * 0.01 * n;
        m->time += 0.01 * n;
    }
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
    Inst *m = (Inst *)c;
    if (m->state != EVENT) return refuse(m, "fmi2EnterContinuousTimeMode");
    m->state = CONTINUOUS;
    return fmi2OK;
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
