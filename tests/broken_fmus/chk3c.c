/* Chk3C: a small FMI 3.0 FMU in C (co-simulation and model exchange) for the compliance-kit tests, the
   FMI 3.0 counterpart of chkc.c, built by tests/broken_fmus/chk_build.py against the FMI 3.0 headers fmpy
   ships; what the two share is in chk_common.h.

   Model: x' = k u (x a state, start 0), y = k u (direct feedthrough); input u (start 1), fixed parameter k
   (start 2), structural parameter n (start 1: internal substeps per doStep; settable in Configuration Mode).
   Co-simulation with event mode (no events of its own) and intermediate update (one call per doStep at its
   end). Without any BREAK_* macro it follows FMI 3.0 in everything the kit checks; each BREAK_* macro
   breaks one thing:

   BREAK_BASIC          fmi3DoStep refused after the second step
   BREAK_VERSION        fmi3GetVersion returns "2.0"
   BREAK_TOKEN          fmi3Instantiate* accept any instantiationToken
   BREAK_INIT_GET       fmi3GetFloat64 refused in Initialization Mode
   BREAK_STOP_TIME      a doStep past the defined stop time is accepted
   BREAK_TERMINATED_GET fmi3GetFloat64 refused after fmi3Terminate
   BREAK_RESET          fmi3Reset keeps x
   BREAK_STATE_NOOP     fmi3SetFMUState does nothing
   BREAK_EARLY_STEP     fmi3DoStep in Instantiated accepted (does nothing)
   BREAK_ZERO_STEP      a doStep with communicationStepSize = 0 refused with fmi3Discard (not fmi3Error)
   BREAK_LATE_STEP      doSteps after t = 0.5 s refused: only a long run sees it
   BREAK_ME             fmi3CompletedIntegratorStep refused (model exchange)
   BREAK_DERIV_ORDER    fmi3GetOutputDerivatives accepts order 0 and orders above maxOutputDerivativeOrder
   BREAK_DERIV_NAN      fmi3GetOutputDerivatives gives NaN
   BREAK_EARLY_ANYWAY   every doStep says earlyReturn = true although earlyReturnAllowed is false
   BREAK_EARLY_TIME     with earlyReturnAllowed, a doStep returns early with lastSuccessfulTime t - h (before its
                        step started)
   BREAK_LOGGER         the logger gets a NULL instanceEnvironment
   BREAK_DEBUG_LOGGING  fmi3SetDebugLogging refuses the declared categories
   BREAK_SHARED_GLOBAL  x lives in a global variable: two instances disturb each other
   BREAK_FREE_STATE     fmi3FreeFMUState leaves the pointer as it was (not NULL)
   BREAK_SERIALIZE      fmi3DeserializeFMUState restores x = 0
   BREAK_VARIABLE_STEP  a doStep whose size differs from the first one is refused (although
                        canHandleVariableCommunicationStepSize)
   BREAK_CLOCK          fmi3DoStep ignores currentCommunicationPoint and keeps its own clock: whole internal
                        steps of 0.01 s only (a step of 0.006 s does nothing)
   BREAK_DIRDER         fmi3GetDirectionalDerivative refused although providesDirectionalDerivative
   BREAK_JACOBIAN       fmi3GetDirectionalDerivative gives d der(x)/d x = 1 (it is 0)
   BREAK_EVENT_MODE     fmi3EnterStepMode refused (instantiated with eventModeUsed = true)
   BREAK_INTERMEDIATE   the intermediate update callback gets a time past the step's end
   BREAK_CONFIGURATION  fmi3ExitConfigurationMode refused
   BREAK_LIBM           x advanced with exp() from libm; built without -lm, so libm is not declared (DT_NEEDED)
   BREAK_STALE_Y        y (declared to depend on u) is computed in fmi3DoStep and fmi3CompletedIntegratorStep
                        only: after fmi3SetFloat64(u) it keeps its old value (model exchange: until the next
                        integrator step)
*/
#include "fmi3Functions.h"

#ifndef TOKEN
#define TOKEN "{c0ffee00-5b0d-4c1e-9a1e-000000000003}"
#endif

enum { VR_TIME = 0, VR_U = 1, VR_K = 2, VR_X = 3, VR_Y = 4, VR_DX = 5, VR_N = 6 };
enum { INSTANTIATED, CONFIGURATION, INITIALIZATION, STEP, EVENT, CONTINUOUS, TERMINATED };
enum { ME, CS };

typedef struct {
    double u, k, x, time, stop, ystale, firsth;
    unsigned long long n;
    int stopDefined, state, type, logging, eventModeUsed, earlyReturnAllowed;
    char name[64];
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback log;
    fmi3IntermediateUpdateCallback update;
} Inst;

#ifdef BREAK_SHARED_GLOBAL
static double shared_x;
#define X(m) shared_x
#else
#define X(m) ((m)->x)
#endif

#define CHK_STATUS fmi3Status
#define CHK_OK fmi3OK
#define CHK_ERROR fmi3Error
#define CHK_STOP_STATUS fmi3Error
#define CHK_VR fmi3ValueReference
#define CHK_TIME_VR VR_TIME
#ifdef BREAK_LOGGER
#define CHK_LOG(m, st, cat, msg) do { if ((m)->log) (m)->log(NULL, st, cat, msg); } while (0)
#else
#define CHK_LOG(m, st, cat, msg) do { if ((m)->log) (m)->log((m)->env, st, cat, msg); } while (0)
#endif
#include "chk_common.h"

static void reset_values(Inst *m) {
#ifdef BREAK_RESET
    if (m->state != INSTANTIATED) { m->u = 1.0; m->k = 2.0; m->time = 0.0; m->firsth = 0.0; return; }
#endif
    m->u = 1.0; m->k = 2.0; X(m) = 0.0; m->time = 0.0; m->n = 1; m->ystale = 2.0; m->firsth = 0.0;
}

#ifdef BREAK_VERSION
const char *fmi3GetVersion(void) { return "2.0"; }
#else
const char *fmi3GetVersion(void) { return fmi3Version; }
#endif

fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cats[]) {
    return debug_logging((Inst *)c, on, n, cats);
}

static Inst *make(fmi3String name, fmi3String token, fmi3Boolean logging, fmi3InstanceEnvironment env,
                  fmi3LogMessageCallback log, int type) {
    Inst *m;
#ifdef BREAK_TOKEN
    (void)token;
    if (0) {
#else
    if (!token || strcmp(token, TOKEN)) {
#endif
        if (log) log(env, fmi3Error, "logStatusError", "wrong instantiationToken");
        return NULL;
    }
    m = (Inst *)calloc(1, sizeof(Inst));
    if (!m) return NULL;
    strncpy(m->name, name ? name : "", sizeof m->name - 1);
    m->env = env; m->log = log; m->logging = logging; m->type = type;
    reset_values(m);
    m->state = INSTANTIATED;
    return m;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String name, fmi3String token, fmi3String res, fmi3Boolean visible,
                                          fmi3Boolean logging, fmi3InstanceEnvironment env,
                                          fmi3LogMessageCallback log) {
    (void)res; (void)visible;
    return make(name, token, logging, env, log, ME);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String res, fmi3Boolean visible,
                                         fmi3Boolean logging, fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference req[], size_t nreq, fmi3InstanceEnvironment env,
                                         fmi3LogMessageCallback log, fmi3IntermediateUpdateCallback update) {
    Inst *m;
    (void)res; (void)visible; (void)req; (void)nreq;
    m = make(name, token, logging, env, log, CS);
    if (m) { m->eventModeUsed = eventModeUsed; m->update = update; m->earlyReturnAllowed = earlyReturnAllowed; }
    return m;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String name, fmi3String token, fmi3String res, fmi3Boolean visible,
                                               fmi3Boolean logging, fmi3InstanceEnvironment env,
                                               fmi3LogMessageCallback log, fmi3ClockUpdateCallback cu,
                                               fmi3LockPreemptionCallback lp, fmi3UnlockPreemptionCallback up) {
    (void)name; (void)token; (void)res; (void)visible; (void)logging; (void)cu; (void)lp; (void)up;
    if (log) log(env, fmi3Error, "logStatusError", "no scheduled execution");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance c) { free(c); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean tolDefined, fmi3Float64 tol, fmi3Float64 start,
                                       fmi3Boolean stopDefined, fmi3Float64 stop) {
    Inst *m = (Inst *)c;
    fmi3Status st = start_initialization(m, start, stopDefined, stop, "fmi3EnterInitializationMode");
    (void)tolDefined; (void)tol;
    if (st == fmi3OK) m->state = INITIALIZATION;
    return st;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
    Inst *m = (Inst *)c;
    return exit_initialization(m, (m->type == CS && !m->eventModeUsed) ? STEP : EVENT, "fmi3ExitInitializationMode");
}

fmi3Status fmi3EnterEventMode(fmi3Instance c) {
    Inst *m = (Inst *)c;
    if (m->state != STEP && m->state != CONTINUOUS) return refuse(m, "fmi3EnterEventMode");
    if (m->type == CS && !m->eventModeUsed) return refuse(m, "fmi3EnterEventMode (eventModeUsed is false)");
    m->state = EVENT;
    return fmi3OK;
}

fmi3Status fmi3Terminate(fmi3Instance c) { return terminate((Inst *)c, "fmi3Terminate"); }

fmi3Status fmi3Reset(fmi3Instance c) {
    Inst *m = (Inst *)c;
    reset_values(m);
    m->state = INSTANTIATED;
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 v[], size_t nv) {
    Inst *m = (Inst *)c;
    if (m->state == INSTANTIATED || m->state == CONFIGURATION || nv != nvr) return refuse(m, "fmi3GetFloat64");
    return get_reals(m, vr, nvr, v, "fmi3GetFloat64");
}

fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Float64 v[], size_t nv) {
    Inst *m = (Inst *)c;
    size_t i;
    int early = m->state == INSTANTIATED || m->state == INITIALIZATION;
    if (nv != nvr) return refuse(m, "fmi3SetFloat64");
    for (i = 0; i < nvr; i++) {
        if (vr[i] == VR_U && m->state != CONFIGURATION && m->state != TERMINATED) m->u = v[i];
        else if (vr[i] == VR_K && early) m->k = v[i];
        else if (vr[i] == VR_X && (early || m->state == CONTINUOUS)) X(m) = v[i];
        else return refuse(m, "fmi3SetFloat64");
    }
    return fmi3OK;
}

fmi3Status fmi3GetUInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3UInt64 v[], size_t nv) {
    Inst *m = (Inst *)c;
    size_t i;
    if (nv != nvr) return refuse(m, "fmi3GetUInt64");
    for (i = 0; i < nvr; i++) {
        if (vr[i] != VR_N) return refuse(m, "fmi3GetUInt64 (value reference)");
        v[i] = m->n;
    }
    return fmi3OK;
}

fmi3Status fmi3SetUInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3UInt64 v[], size_t nv) {
    Inst *m = (Inst *)c;
    size_t i;
    if (nv != nvr) return refuse(m, "fmi3SetUInt64");
    for (i = 0; i < nvr; i++) {
        if (vr[i] != VR_N || (m->state != INSTANTIATED && m->state != CONFIGURATION) || v[i] < 1 || v[i] > 100)
            return refuse(m, "fmi3SetUInt64 (n: in Instantiated or Configuration Mode, 1 to 100)");
        m->n = v[i];
    }
    return fmi3OK;
}

/* the types this FMU has no variables of: nothing to get or set */
#define NONE_GET(T, name) fmi3Status name(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, T v[], size_t nv) \
    { (void)vr; (void)v; (void)nv; return nvr ? refuse((Inst *)c, #name) : fmi3OK; }
#define NONE_SET(T, name) fmi3Status name(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const T v[], size_t nv) \
    { (void)vr; (void)v; (void)nv; return nvr ? refuse((Inst *)c, #name) : fmi3OK; }
NONE_GET(fmi3Float32, fmi3GetFloat32) NONE_GET(fmi3Int8, fmi3GetInt8) NONE_GET(fmi3UInt8, fmi3GetUInt8)
NONE_GET(fmi3Int16, fmi3GetInt16) NONE_GET(fmi3UInt16, fmi3GetUInt16) NONE_GET(fmi3Int32, fmi3GetInt32)
NONE_GET(fmi3UInt32, fmi3GetUInt32) NONE_GET(fmi3Int64, fmi3GetInt64) NONE_GET(fmi3Boolean, fmi3GetBoolean)
NONE_GET(fmi3String, fmi3GetString)
NONE_SET(fmi3Float32, fmi3SetFloat32) NONE_SET(fmi3Int8, fmi3SetInt8) NONE_SET(fmi3UInt8, fmi3SetUInt8)
NONE_SET(fmi3Int16, fmi3SetInt16) NONE_SET(fmi3UInt16, fmi3SetUInt16) NONE_SET(fmi3Int32, fmi3SetInt32)
NONE_SET(fmi3UInt32, fmi3SetUInt32) NONE_SET(fmi3Int64, fmi3SetInt64) NONE_SET(fmi3Boolean, fmi3SetBoolean)
NONE_SET(fmi3String, fmi3SetString)

fmi3Status fmi3GetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, size_t sizes[], fmi3Binary v[],
                         size_t nv) {
    (void)vr; (void)sizes; (void)v; (void)nv; return nvr ? refuse((Inst *)c, "fmi3GetBinary") : fmi3OK;
}
fmi3Status fmi3SetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const size_t sizes[],
                         const fmi3Binary v[], size_t nv) {
    (void)vr; (void)sizes; (void)v; (void)nv; return nvr ? refuse((Inst *)c, "fmi3SetBinary") : fmi3OK;
}
fmi3Status fmi3GetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Clock v[]) {
    (void)vr; (void)v; return nvr ? refuse((Inst *)c, "fmi3GetClock") : fmi3OK;
}
fmi3Status fmi3SetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Clock v[]) {
    (void)vr; (void)v; return nvr ? refuse((Inst *)c, "fmi3SetClock") : fmi3OK;
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance c, fmi3ValueReference vr, size_t *n) {
    (void)vr; (void)n; return refuse((Inst *)c, "fmi3GetNumberOfVariableDependencies");
}
fmi3Status fmi3GetVariableDependencies(fmi3Instance c, fmi3ValueReference dep, size_t ei[], fmi3ValueReference ind[],
                                       size_t eii[], fmi3DependencyKind kinds[], size_t n) {
    (void)dep; (void)ei; (void)ind; (void)eii; (void)kinds; (void)n;
    return refuse((Inst *)c, "fmi3GetVariableDependencies");
}

CHK_STATE_FUNCTIONS(fmi3Instance, fmi3FMUState, fmi3Byte, fmi3GetFMUState, fmi3SetFMUState, fmi3FreeFMUState,
                    fmi3SerializedFMUStateSize, fmi3SerializeFMUState, fmi3DeserializeFMUState)

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance c, const fmi3ValueReference unk[], size_t nu,
                                        const fmi3ValueReference kn[], size_t nk, const fmi3Float64 seed[], size_t ns,
                                        fmi3Float64 sens[], size_t nsens) {
#ifdef BREAK_DIRDER
    return refuse((Inst *)c, "fmi3GetDirectionalDerivative");
#endif
    if (ns != nk || nsens != nu) return refuse((Inst *)c, "fmi3GetDirectionalDerivative (sizes)");
    directional_derivative((Inst *)c, unk, nu, kn, nk, seed, sens);
    return fmi3OK;
}
fmi3Status fmi3GetAdjointDerivative(fmi3Instance c, const fmi3ValueReference unk[], size_t nu,
                                    const fmi3ValueReference kn[], size_t nk, const fmi3Float64 seed[], size_t ns,
                                    fmi3Float64 sens[], size_t nsens) {
    (void)unk; (void)nu; (void)kn; (void)nk; (void)seed; (void)ns; (void)sens; (void)nsens;
    return refuse((Inst *)c, "fmi3GetAdjointDerivative");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance c) {
    return move((Inst *)c, INSTANTIATED, CONFIGURATION, "fmi3EnterConfigurationMode");
}
fmi3Status fmi3ExitConfigurationMode(fmi3Instance c) {
#ifdef BREAK_CONFIGURATION
    return refuse((Inst *)c, "fmi3ExitConfigurationMode");
#endif
    return move((Inst *)c, CONFIGURATION, INSTANTIATED, "fmi3ExitConfigurationMode");
}

/* clocks: this FMU has none */
#define NO_CLOCK(name, ...) fmi3Status name(fmi3Instance c, __VA_ARGS__) { return refuse((Inst *)c, #name); }
NO_CLOCK(fmi3GetIntervalDecimal, const fmi3ValueReference vr[], size_t n, fmi3Float64 i[], fmi3IntervalQualifier q[])
NO_CLOCK(fmi3GetIntervalFraction, const fmi3ValueReference vr[], size_t n, fmi3UInt64 c_[], fmi3UInt64 r[],
         fmi3IntervalQualifier q[])
NO_CLOCK(fmi3GetShiftDecimal, const fmi3ValueReference vr[], size_t n, fmi3Float64 s[])
NO_CLOCK(fmi3GetShiftFraction, const fmi3ValueReference vr[], size_t n, fmi3UInt64 c_[], fmi3UInt64 r[])
NO_CLOCK(fmi3SetIntervalDecimal, const fmi3ValueReference vr[], size_t n, const fmi3Float64 i[])
NO_CLOCK(fmi3SetIntervalFraction, const fmi3ValueReference vr[], size_t n, const fmi3UInt64 c_[], const fmi3UInt64 r[])
NO_CLOCK(fmi3SetShiftDecimal, const fmi3ValueReference vr[], size_t n, const fmi3Float64 s[])
NO_CLOCK(fmi3SetShiftFraction, const fmi3ValueReference vr[], size_t n, const fmi3UInt64 c_[], const fmi3UInt64 r[])
NO_CLOCK(fmi3ActivateModelPartition, fmi3ValueReference clock, fmi3Float64 t)

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance c) {
    Inst *m = (Inst *)c;
    return m->state == EVENT || m->state == STEP || m->state == CONTINUOUS ? fmi3OK : refuse(m, "fmi3EvaluateDiscreteStates");
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *needUpdate, fmi3Boolean *terminate,
                                    fmi3Boolean *nominalsChanged, fmi3Boolean *valuesChanged, fmi3Boolean *nextDefined,
                                    fmi3Float64 *next) {
    Inst *m = (Inst *)c;
    if (m->state != EVENT) return refuse(m, "fmi3UpdateDiscreteStates");
    *needUpdate = fmi3False; *terminate = fmi3False; *nominalsChanged = fmi3False; *valuesChanged = fmi3False;
    *nextDefined = fmi3False; *next = 0.0;
    return fmi3OK;
}

/* ---- model exchange */
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) {
    Inst *m = (Inst *)c;
    if (m->type != ME || m->state != EVENT) return refuse(m, "fmi3EnterContinuousTimeMode");
    m->state = CONTINUOUS;
    return fmi3OK;
}
fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean noPrior, fmi3Boolean *enterEventMode,
                                       fmi3Boolean *terminate) {
    Inst *m = (Inst *)c;
    (void)noPrior;
    if (m->state != CONTINUOUS) return refuse(m, "fmi3CompletedIntegratorStep");
#ifdef BREAK_ME
    return refuse(m, "fmi3CompletedIntegratorStep");
#endif
    m->ystale = m->k * m->u;
    *enterEventMode = fmi3False; *terminate = fmi3False;
    return fmi3OK;
}
fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 t) {
    Inst *m = (Inst *)c;
    if (m->state != CONTINUOUS && m->state != EVENT) return refuse(m, "fmi3SetTime");
    m->time = t;
    return fmi3OK;
}
fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 x[], size_t n) {
    Inst *m = (Inst *)c;
    if (m->state != CONTINUOUS || n != 1) return refuse(m, "fmi3SetContinuousStates");
    X(m) = x[0];
    return fmi3OK;
}
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 dx[], size_t n) {
    Inst *m = (Inst *)c;
    if (m->state == INSTANTIATED || m->state == CONFIGURATION || n != 1) return refuse(m, "fmi3GetContinuousStateDerivatives");
    dx[0] = m->k * m->u;
    return fmi3OK;
}
fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 z[], size_t n) {
    (void)z; return n ? refuse((Inst *)c, "fmi3GetEventIndicators") : fmi3OK;
}
fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n) {
    Inst *m = (Inst *)c;
    if (m->state == INSTANTIATED || m->state == CONFIGURATION || n != 1) return refuse(m, "fmi3GetContinuousStates");
    x[0] = X(m);
    return fmi3OK;
}
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 nominals[], size_t n) {
    if (n != 1) return refuse((Inst *)c, "fmi3GetNominalsOfContinuousStates");
    nominals[0] = 1.0;
    return fmi3OK;
}
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n) { (void)c; *n = 0; return fmi3OK; }
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n) { (void)c; *n = 1; return fmi3OK; }

/* ---- co-simulation */
fmi3Status fmi3EnterStepMode(fmi3Instance c) {
    Inst *m = (Inst *)c;
#ifdef BREAK_EVENT_MODE
    return refuse(m, "fmi3EnterStepMode");
#endif
    if (m->type != CS || m->state != EVENT) return refuse(m, "fmi3EnterStepMode");
    m->state = STEP;
    return fmi3OK;
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Int32 orders[],
                                    fmi3Float64 v[], size_t nv) {
    Inst *m = (Inst *)c;
    size_t i;
    if (nv != nvr || (m->state != STEP && m->state != TERMINATED)) return refuse(m, "fmi3GetOutputDerivatives");
    for (i = 0; i < nvr; i++) {   /* maxOutputDerivativeOrder = 1: dx/dt = k u, dy/dt = 0 (u held) */
#ifndef BREAK_DERIV_ORDER
        if (orders[i] != 1) {
            logmsg(m, fmi3Error, "logStatusError", "fmi3GetOutputDerivatives: order %d (allowed: 1)", (int)orders[i]);
            return fmi3Error;
        }
#endif
        if (vr[i] == VR_X) v[i] = m->k * m->u;
        else if (vr[i] == VR_Y) v[i] = 0.0;
        else return refuse(m, "fmi3GetOutputDerivatives (value reference)");
#ifdef BREAK_DERIV_NAN
        v[i] = NAN;
#endif
    }
    return fmi3OK;
}

fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean noPrior, fmi3Boolean *eventNeeded,
                      fmi3Boolean *terminate, fmi3Boolean *earlyReturn, fmi3Float64 *lastTime) {
    Inst *m = (Inst *)c;
    fmi3Status st;
#ifndef BREAK_CLOCK
    unsigned long long i;
#endif
    (void)noPrior;
    *eventNeeded = fmi3False; *terminate = fmi3False; *earlyReturn = fmi3False; *lastTime = m->time;
#ifdef BREAK_EARLY_STEP
    if (m->state == INSTANTIATED) return fmi3OK;
#endif
    if (m->state != STEP) return refuse(m, "fmi3DoStep");
#ifdef BREAK_ZERO_STEP
    if (h == 0) return fmi3Discard;
#endif
    if ((st = step_checks(m, t, h, "fmi3DoStep (late)")) != fmi3OK) return st;
#ifdef BREAK_BASIC
    if (t > 1.5 * h) return refuse(m, "fmi3DoStep (third step)");
#endif
#ifdef BREAK_VARIABLE_STEP
    if (m->firsth > 0 && fabs(h - m->firsth) > 1e-12 * m->firsth) return refuse(m, "fmi3DoStep (another step size)");
#endif
    if (m->firsth == 0) m->firsth = h;
    if (!isfinite(m->u)) return fmi3Discard;
#ifdef BREAK_CLOCK
    own_clock_step(m, h);
#elif defined(BREAK_LIBM)
    for (i = 0; i < m->n; i++) X(m) += m->k * m->u * h / (double)m->n * exp(0.0 * X(m));
    m->time = t + h;
#else
    for (i = 0; i < m->n; i++) X(m) += m->k * m->u * h / (double)m->n;
    m->time = t + h;
#endif
    m->ystale = m->k * m->u;
    *lastTime = m->time;
#ifdef BREAK_EARLY_ANYWAY
    *earlyReturn = fmi3True;
#endif
#ifdef BREAK_EARLY_TIME
    if (m->earlyReturnAllowed) { *earlyReturn = fmi3True; *lastTime = t - h; }
#endif
    if (m->update) {
        fmi3Boolean early = fmi3False;
        fmi3Float64 earlyTime = 0.0;
#ifdef BREAK_INTERMEDIATE
        m->update(m->env, t + 2 * h, fmi3False, fmi3True, fmi3True, fmi3False, &early, &earlyTime);
#else
        m->update(m->env, t + h, fmi3False, fmi3True, fmi3True, fmi3False, &early, &earlyTime);
#endif
    }
    return fmi3OK;
}
