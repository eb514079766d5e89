/* The FMI 3.0 co-simulation functions of an FMI 3.0 FMU's binary:
 * binaries/x86_64-linux/<modelIdentifier>.so is this file linked with the FMI 2.0 loader
 * (fmi2_loader.c, fmi2_inproc.c, fmi2_remote.c; -Wl,-Bsymbolic so the calls below never reach
 * another FMU's fmi2 functions). Every FMI 3.0 call is mapped onto the loader's FMI 2.0 calls, so
 * the model runs exactly as in the FMI 2.0 FMU: in this process on the FMU's own Python, on the
 * host's Python of the same version, or in its own process (SPURDIFF_FMU_PROCESS), over the same
 * bridge and adapter (spurdiff/fmi/adapter.py), with the same refusals:
 *
 *   fmi3InstantiateCoSimulation       fmi2Instantiate (resourcePath made a file URI); refuses
 *                                     eventModeUsed (hasEventMode is false) and required
 *                                     intermediate variables (providesIntermediateUpdate false)
 *   fmi3EnterInitializationMode       fmi2SetupExperiment + fmi2EnterInitializationMode
 *   fmi3ExitInitializationMode        fmi2ExitInitializationMode (then Step Mode)
 *   fmi3DoStep                        fmi2DoStep; lastSuccessfulTime and terminateSimulation from
 *                                     fmi2GetRealStatus / fmi2GetBooleanStatus after a refused
 *                                     step; eventHandlingNeeded false. With earlyReturnAllowed:
 *                                     the loader's spurdiffDoStepEarly (the model ends the step
 *                                     just past a stick/slip switch: earlyReturn true,
 *                                     lastSuccessfulTime the time reached)
 *   fmi3GetOutputDerivatives          fmi2GetRealOutputDerivatives (the loader passes it on for
 *                                     this binary's instances only: spurdiffEnableFmi3)
 *   fmi3Get/SetFloat64, Int32,        fmi2Get/SetReal, Integer, Boolean (converted), String;
 *   Boolean, String                   nValues must equal nValueReferences (no arrays); the
 *                                     independent variable `time` (TIME_VR) is answered here
 *   FMU state functions               the fmi2 ones
 *   fmi3Terminate, fmi3Reset,         the fmi2 ones
 *   fmi3FreeInstance
 *
 * Everything else (Model Exchange, Scheduled Execution, Event Mode, clocks, configuration mode,
 * the other types, directional and adjoint derivatives, dependencies) is not offered: fmi3Error
 * with one logged line saying so (NULL for the other instantiate functions).
 *
 * The model's log lines come from the FMI 2.0 side: the logger below formats them (the bridge
 * passes the text as the format, '%' doubled) and names the FMI 3.0 function and status instead
 * of the FMI 2.0 one (fmi3_names.h) before handing them to the host's fmi3LogMessageCallback.
 */
#define _GNU_SOURCE
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <math.h>
#include <string.h>

#include "fmi2Functions.h"
#include "fmi3Functions.h"
#include "fmi3_names.h"

#define INSTANCE3_MAGIC 0x53504433u   /* "SPD3" */
/* the value reference of the independent variable `time` (harness/build/modeldescription3.py writes the same) */
#define TIME_VR 2147483647u

/* the FMI 2.0 loader's FMI 3.0 extensions (fmi2_loader.c) */
fmi2Status spurdiffEnableFmi3(fmi2Component c);
fmi2Status spurdiffDoStepEarly(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean nsp, fmi2Real *end);

typedef struct {
    unsigned magic;
    fmi2Component inner;          /* the FMI 2.0 loader's instance */
    char *name;
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback log;
    fmi2CallbackFunctions cb;     /* what the FMI 2.0 side logs through (componentEnvironment: this) */
    bool early_return_allowed;
    double time;                  /* the independent variable: start time, then the last successful time */
} Instance3;

/* ------------------------------------------------------------------------------ logging */
static void say(const Instance3 *I, fmi3Status status, const char *category, const char *msg)
{
    if (I && I->log) I->log(I->env, status, category, msg);
    else fprintf(stderr, "%s: %s\n", I && I->name ? I->name : "fmi3", msg);
}

static void sayf(const Instance3 *I, fmi3Status status, const char *fmt, ...)
{
    char msg[4096];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    say(I, status, status >= fmi3Error ? "logStatusError" : "logAll", msg);
}

/* The FMI 2.0 side's logger: the message formatted, its FMI 2.0 names made FMI 3.0 ones. */
static void logger2(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                    fmi2String message, ...)
{
    (void)name;
    const Instance3 *I = (const Instance3 *)env;
    char text[16384], out[16384 + 1024];
    va_list ap;
    va_start(ap, message);
    vsnprintf(text, sizeof text, message ? message : "", ap);
    va_end(ap);
    fmi3_rename(text, out, sizeof out);
    if (category && !strcmp(category, "logStatusPending")) category = "logAll";
    say(I, (fmi3Status)status, category ? category : "logAll", out);
}

static void *alloc2(size_t n, size_t size) { return calloc(n, size); }

/* ------------------------------------------------------------------------------ instances */
static Instance3 *valid(fmi3Instance instance)
{
    Instance3 *I = (Instance3 *)instance;
    return (I && I->magic == INSTANCE3_MAGIC) ? I : NULL;
}

const char *fmi3GetVersion(void) { return fmi3Version; }

/* resourcePath (a native path, FMI 3.0 section 2.3.1) as the file URI fmi2Instantiate reads. */
static char *resource_uri(const char *path)
{
    size_t n = strlen(path);
    char *uri = (char *)malloc(7 + 3 * n + 1), *q = uri;
    if (!uri) return NULL;
    memcpy(q, "file://", 7);
    q += 7;
#ifdef _WIN32   /* C:\dir\resources\ -> file:///C:/dir/resources/ (runtime_cfg.h reads /C:/ as C:/); the
                 * extra '/' fits: the drive letter and ':' take one byte each where 3 were allowed */
    if (path[0] != '/') *q++ = '/';
#endif
    for (const char *p = path; *p; p++) {
        if (*p == '%') { memcpy(q, "%25", 3); q += 3; }
#ifdef _WIN32
        else if (*p == '\\') *q++ = '/';
#endif
        else *q++ = *p;
    }
    *q = 0;
    return uri;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate)
{
    (void)requiredIntermediateVariables;
    (void)intermediateUpdate;
    Instance3 probe = {INSTANCE3_MAGIC, NULL, (char *)(instanceName ? instanceName : ""), instanceEnvironment,
                       logMessage, {0}, false, 0.0};
    if (eventModeUsed) {
        sayf(&probe, fmi3Error, "fmi3InstantiateCoSimulation: eventModeUsed = true, but this FMU has no Event "
             "Mode (hasEventMode = false): instantiate with eventModeUsed = false");
        return NULL;
    }
    if (nRequiredIntermediateVariables) {
        sayf(&probe, fmi3Error, "fmi3InstantiateCoSimulation: %zu required intermediate variables given, but "
             "this FMU provides no intermediate update (providesIntermediateUpdate = false): give none",
             nRequiredIntermediateVariables);
        return NULL;
    }
#ifdef _WIN32   /* absolute on Windows: a drive letter, ':' and a separator (C:\ or C:/) */
    if (!resourcePath || !((resourcePath[0] | 32) >= 'a' && (resourcePath[0] | 32) <= 'z' && resourcePath[1] == ':'
                           && (resourcePath[2] == '\\' || resourcePath[2] == '/'))) {
#else
    if (!resourcePath || resourcePath[0] != '/') {
#endif
        sayf(&probe, fmi3Error, "fmi3InstantiateCoSimulation: resourcePath '%.1000s' is not an absolute path "
             "to the FMU's extracted resources folder", resourcePath ? resourcePath : "(null)");
        return NULL;
    }
    Instance3 *I = (Instance3 *)calloc(1, sizeof *I);
    char *uri = resource_uri(resourcePath);
    if (!I || !uri) {
        free(I);
        free(uri);
        sayf(&probe, fmi3Error, "fmi3InstantiateCoSimulation: out of memory");
        return NULL;
    }
    *I = probe;
    I->name = strdup(instanceName ? instanceName : "");
    I->early_return_allowed = earlyReturnAllowed;
    I->cb.logger = logger2;
    I->cb.allocateMemory = alloc2;
    I->cb.freeMemory = free;
    I->cb.componentEnvironment = I;
    I->inner = fmi2Instantiate(instanceName, fmi2CoSimulation, instantiationToken, uri, &I->cb,
                               visible ? fmi2True : fmi2False, loggingOn ? fmi2True : fmi2False);
    free(uri);
    if (!I->inner) {   /* the loader or the model logged why */
        free(I->name);
        free(I);
        return NULL;
    }
    spurdiffEnableFmi3(I->inner);
    return I;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    Instance3 probe = {INSTANCE3_MAGIC, NULL, (char *)(instanceName ? instanceName : ""), instanceEnvironment,
                       logMessage, {0}, false, 0.0};
    sayf(&probe, fmi3Error, "fmi3InstantiateModelExchange: this FMU offers Co-Simulation only "
         "(use fmi3InstantiateCoSimulation)");
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    Instance3 probe = {INSTANCE3_MAGIC, NULL, (char *)(instanceName ? instanceName : ""), instanceEnvironment,
                       logMessage, {0}, false, 0.0};
    sayf(&probe, fmi3Error, "fmi3InstantiateScheduledExecution: this FMU offers Co-Simulation only "
         "(use fmi3InstantiateCoSimulation)");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance)
{
    Instance3 *I = valid(instance);
    if (!I) return;
    fmi2FreeInstance(I->inner);
    I->magic = 0;
    free(I->name);
    free(I);
}

#define ENTER3                                                                                     \
    Instance3 *I = valid(instance);                                                                \
    if (!I) return fmi3Error;
/* ENTER3 and the value-reference and value arrays checked (the getters' and setters' prelude) */
#define ENTER3_ARRAYS(fn)                                                                          \
    ENTER3                                                                                         \
    if (!arrays_ok(I, fn, valueReferences, nValueReferences, values, nValues)) return fmi3Error;

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    ENTER3
    if (nCategories && !categories) {
        sayf(I, fmi3Error, "fmi3SetDebugLogging: categories is NULL for nCategories = %zu", nCategories);
        return fmi3Error;
    }
    return (fmi3Status)fmi2SetDebugLogging(I->inner, loggingOn ? fmi2True : fmi2False, nCategories, categories);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    ENTER3
    fmi2Status s = fmi2SetupExperiment(I->inner, toleranceDefined ? fmi2True : fmi2False, tolerance, startTime,
                                       stopTimeDefined ? fmi2True : fmi2False, stopTime);
    if (s > fmi2Warning) return (fmi3Status)s;
    I->time = startTime;
    fmi2Status e = fmi2EnterInitializationMode(I->inner);
    return (fmi3Status)(e > s ? e : s);
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    ENTER3
    return (fmi3Status)fmi2ExitInitializationMode(I->inner);
}

fmi3Status fmi3Terminate(fmi3Instance instance)
{
    ENTER3
    return (fmi3Status)fmi2Terminate(I->inner);
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    ENTER3
    fmi2Status s = fmi2Reset(I->inner);
    if (s <= fmi2Warning) I->time = 0.0;
    return (fmi3Status)s;
}

/* ------------------------------------------------------------------------------ stepping */
fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime)
{
    ENTER3
    if (!eventHandlingNeeded || !terminateSimulation || !earlyReturn || !lastSuccessfulTime) {
        sayf(I, fmi3Error, "fmi3DoStep: %s is NULL (every output argument of fmi3DoStep is required)",
             !eventHandlingNeeded ? "eventHandlingNeeded" : !terminateSimulation ? "terminateSimulation"
             : !earlyReturn ? "earlyReturn" : "lastSuccessfulTime");
        return fmi3Error;
    }
    if (!(communicationStepSize > 0.0) || !isfinite(communicationStepSize)) {
        /* an illegal argument: FMI 3.0 2.2.4 "When detecting illegal arguments [...] the FMU must
         * return fmi3Error" (FMI 2.0 has no such sentence: there the model's fmi2Discard stands) */
        sayf(I, fmi3Error, "fmi3DoStep at t = %g s refused: communicationStepSize = %g must be > 0 and finite",
             currentCommunicationPoint, communicationStepSize);
        return fmi3Error;
    }
    fmi2Status s;
    fmi2Real end = currentCommunicationPoint + communicationStepSize;
    if (I->early_return_allowed)   /* the model may stop at a stick/slip switch (FMI 3.0 4.1.3, 4.2.1) */
        s = spurdiffDoStepEarly(I->inner, currentCommunicationPoint, communicationStepSize,
                                noSetFMUStatePriorToCurrentPoint ? fmi2True : fmi2False, &end);
    else
        s = fmi2DoStep(I->inner, currentCommunicationPoint, communicationStepSize,
                       noSetFMUStatePriorToCurrentPoint ? fmi2True : fmi2False);
    *eventHandlingNeeded = false;
    *earlyReturn = false;
    if (s <= fmi2Warning) {
        I->time = currentCommunicationPoint + communicationStepSize;
        if (I->early_return_allowed && end < I->time) {
            I->time = end;
            *earlyReturn = true;
        }
        *terminateSimulation = false;
        *lastSuccessfulTime = I->time;
        return (fmi3Status)s;
    }
    /* refused: the model kept its state at its last successful time, and says whether going on
     * can help (a step that failed fails again from the same state; the stop time was reached) */
    fmi2Real t = I->time;
    fmi2Boolean terminated = fmi2False;
    if (fmi2GetRealStatus(I->inner, fmi2LastSuccessfulTime, &t) <= fmi2Warning) I->time = t;
    if (fmi2GetBooleanStatus(I->inner, fmi2Terminated, &terminated) > fmi2Warning) terminated = fmi2True;
    *terminateSimulation = terminated ? true : false;
    *lastSuccessfulTime = I->time;
    return (fmi3Status)s;
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance)
{
    ENTER3
    sayf(I, fmi3Error, "fmi3EnterStepMode: only from Event Mode, which this FMU does not have (hasEventMode = "
         "false): fmi3ExitInitializationMode enters Step Mode");
    return fmi3Error;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance)
{
    ENTER3
    sayf(I, fmi3Error, "fmi3EnterEventMode: this FMU has no Event Mode (hasEventMode = false)");
    return fmi3Error;
}


/* ------------------------------------------------------------------------------ values */
/* NULL arrays and nValues: the same rule for every getter and setter. */
static int arrays_ok(Instance3 *I, const char *fn, const fmi3ValueReference vr[], size_t nvr, const void *values,
                     size_t nValues)
{
    if (nvr && (!vr || !values)) {
        sayf(I, fmi3Error, "%s: %s is NULL for nValueReferences = %zu", fn, vr ? "values" : "valueReferences", nvr);
        return 0;
    }
    if (nValues != nvr) {
        sayf(I, fmi3Error, "%s: nValues = %zu, nValueReferences = %zu: this FMU has no array variables, the two "
             "must be equal", fn, nValues, nvr);
        return 0;
    }
    return 1;
}

/* The position of TIME_VR in vr (or -1). */
static long time_index(const fmi3ValueReference vr[], size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (vr[i] == TIME_VR) return (long)i;
    return -1;
}

/* The derivatives of Float64 outputs at the FMU's time (FMI 3.0 section 4.1.2: after fmi3DoStep,
 * at the end of the communication step): the model answers them (spurdiff/fmi/adapter.py, the orders and references
 * checked there against maxOutputDerivativeOrder and the outputs, each refusal naming them);
 * the independent variable is refused here. */
fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues)
{
    ENTER3
    if (!arrays_ok(I, "fmi3GetOutputDerivatives", valueReferences, nValueReferences, values, nValues))
        return fmi3Error;
    if (nValueReferences && !orders) {
        sayf(I, fmi3Error, "fmi3GetOutputDerivatives: orders is NULL for nValueReferences = %zu", nValueReferences);
        return fmi3Error;
    }
    if (nValueReferences && time_index(valueReferences, nValueReferences) >= 0) {
        sayf(I, fmi3Error, "fmi3GetOutputDerivatives: value reference %u is the independent variable time, not an "
             "output", TIME_VR);
        return fmi3Error;
    }
    if (!nValueReferences) return fmi3OK;
    return (fmi3Status)fmi2GetRealOutputDerivatives(I->inner, valueReferences, nValueReferences,
                                                    (const fmi2Integer *)orders, values);
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float64 values[], size_t nValues)
{
    ENTER3_ARRAYS("fmi3GetFloat64")
    if (!nValueReferences || time_index(valueReferences, nValueReferences) < 0)
        return (fmi3Status)fmi2GetReal(I->inner, valueReferences, nValueReferences, values);
    /* `time` among them: it is answered here, the others by the model */
    fmi3ValueReference *rest = (fmi3ValueReference *)malloc(nValueReferences * sizeof *rest);
    double *got = (double *)malloc(nValueReferences * sizeof *got);
    fmi2Status s = fmi2Error;
    if (rest && got) {
        size_t m = 0;
        for (size_t i = 0; i < nValueReferences; i++)
            if (valueReferences[i] != TIME_VR) rest[m++] = valueReferences[i];
        s = m ? fmi2GetReal(I->inner, rest, m, got) : fmi2OK;
        if (s <= fmi2Warning)
            for (size_t i = 0, k = 0; i < nValueReferences; i++)
                values[i] = valueReferences[i] == TIME_VR ? I->time : got[k++];
    } else {
        sayf(I, fmi3Error, "fmi3GetFloat64: out of memory");
    }
    free(rest);
    free(got);
    return (fmi3Status)s;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float64 values[], size_t nValues)
{
    ENTER3_ARRAYS("fmi3SetFloat64")
    if (nValueReferences && time_index(valueReferences, nValueReferences) >= 0) {
        sayf(I, fmi3Error, "fmi3SetFloat64: value reference %u is the independent variable time, which cannot be set",
             TIME_VR);
        return fmi3Error;
    }
    return (fmi3Status)fmi2SetReal(I->inner, valueReferences, nValueReferences, values);
}

/* fmi3Int32 and fmi2Integer are both int */
_Static_assert(sizeof(fmi3Int32) == sizeof(fmi2Integer), "fmi3Int32 and fmi2Integer differ");

fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int32 values[], size_t nValues)
{
    ENTER3_ARRAYS("fmi3GetInt32")
    return (fmi3Status)fmi2GetInteger(I->inner, valueReferences, nValueReferences, (fmi2Integer *)values);
}

fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int32 values[], size_t nValues)
{
    ENTER3_ARRAYS("fmi3SetInt32")
    return (fmi3Status)fmi2SetInteger(I->inner, valueReferences, nValueReferences, (const fmi2Integer *)values);
}

fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Boolean values[], size_t nValues)
{
    ENTER3_ARRAYS("fmi3GetBoolean")
    fmi2Boolean *b = (fmi2Boolean *)calloc(nValueReferences ? nValueReferences : 1, sizeof *b);
    if (!b) { sayf(I, fmi3Error, "fmi3GetBoolean: out of memory"); return fmi3Error; }
    fmi2Status s = fmi2GetBoolean(I->inner, valueReferences, nValueReferences, b);
    if (s <= fmi2Warning)
        for (size_t i = 0; i < nValueReferences; i++) values[i] = b[i] ? true : false;
    free(b);
    return (fmi3Status)s;
}

fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Boolean values[], size_t nValues)
{
    ENTER3_ARRAYS("fmi3SetBoolean")
    fmi2Boolean *b = (fmi2Boolean *)calloc(nValueReferences ? nValueReferences : 1, sizeof *b);
    if (!b) { sayf(I, fmi3Error, "fmi3SetBoolean: out of memory"); return fmi3Error; }
    for (size_t i = 0; i < nValueReferences; i++) b[i] = values[i] ? fmi2True : fmi2False;
    fmi2Status s = fmi2SetBoolean(I->inner, valueReferences, nValueReferences, b);
    free(b);
    return (fmi3Status)s;
}

fmi3Status fmi3GetString(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         fmi3String values[], size_t nValues)
{
    ENTER3
    if (!arrays_ok(I, "fmi3GetString", valueReferences, nValueReferences, values, nValues)) {
        if (values) for (size_t i = 0; i < nValues; i++) values[i] = "";   /* as fmi2GetString: never garbage */
        return fmi3Error;
    }
    return (fmi3Status)fmi2GetString(I->inner, valueReferences, nValueReferences, values);
}

fmi3Status fmi3SetString(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const fmi3String values[], size_t nValues)
{
    ENTER3_ARRAYS("fmi3SetString")
    return (fmi3Status)fmi2SetString(I->inner, valueReferences, nValueReferences, values);
}

/* The types this FMU has no variable of: nothing to get or set (n = 0 is fine). */
#define NO_SUCH_TYPE(fn, ctype, type)                                                              \
    fmi3Status fn(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, \
                  ctype values[], size_t nValues)                                                  \
    {                                                                                              \
        ENTER3                                                                                     \
        if (!arrays_ok(I, #fn, valueReferences, nValueReferences, values, nValues)) return fmi3Error; \
        if (!nValueReferences) return fmi3OK;                                                      \
        sayf(I, fmi3Error, "%s: value reference %u is not a " type " variable of this FMU (it has none)", #fn, \
             valueReferences[0]);                                                                  \
        return fmi3Error;                                                                          \
    }
NO_SUCH_TYPE(fmi3GetFloat32, fmi3Float32, "Float32")
NO_SUCH_TYPE(fmi3GetInt8, fmi3Int8, "Int8")
NO_SUCH_TYPE(fmi3GetUInt8, fmi3UInt8, "UInt8")
NO_SUCH_TYPE(fmi3GetInt16, fmi3Int16, "Int16")
NO_SUCH_TYPE(fmi3GetUInt16, fmi3UInt16, "UInt16")
NO_SUCH_TYPE(fmi3GetUInt32, fmi3UInt32, "UInt32")
NO_SUCH_TYPE(fmi3GetInt64, fmi3Int64, "Int64")
NO_SUCH_TYPE(fmi3GetUInt64, fmi3UInt64, "UInt64")
NO_SUCH_TYPE(fmi3SetFloat32, const fmi3Float32, "Float32")
NO_SUCH_TYPE(fmi3SetInt8, const fmi3Int8, "Int8")
NO_SUCH_TYPE(fmi3SetUInt8, const fmi3UInt8, "UInt8")
NO_SUCH_TYPE(fmi3SetInt16, const fmi3Int16, "Int16")
NO_SUCH_TYPE(fmi3SetUInt16, const fmi3UInt16, "UInt16")
NO_SUCH_TYPE(fmi3SetUInt32, const fmi3UInt32, "UInt32")
NO_SUCH_TYPE(fmi3SetInt64, const fmi3Int64, "Int64")
NO_SUCH_TYPE(fmi3SetUInt64, const fmi3UInt64, "UInt64")
#undef NO_SUCH_TYPE

/* fmi3GetClock / fmi3SetClock: nothing to do for no value references, else fmi3Error (no clocks here) */
static fmi3Status no_clocks(Instance3 *I, const char *fn, const fmi3ValueReference vr[], size_t n)
{
    if (!n) return fmi3OK;
    sayf(I, fmi3Error, "%s: this FMU has no clocks (value reference %u)", fn, vr ? vr[0] : 0u);
    return fmi3Error;
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[])
{
    ENTER3
    (void)values;
    return no_clocks(I, "fmi3GetClock", valueReferences, nValueReferences);
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[])
{
    ENTER3
    (void)values;
    return no_clocks(I, "fmi3SetClock", valueReferences, nValueReferences);
}

/* fmi3GetBinary / fmi3SetBinary: the arrays checked; nothing to do for no value references, else
 * fmi3Error (no Binary variables here) */
static fmi3Status no_binary(Instance3 *I, const char *fn, const fmi3ValueReference vr[], size_t n, const void *values,
                            size_t nValues)
{
    if (!arrays_ok(I, fn, vr, n, values, nValues)) return fmi3Error;
    if (!n) return fmi3OK;
    sayf(I, fmi3Error, "%s: value reference %u is not a Binary variable of this FMU (it has none)", fn, vr[0]);
    return fmi3Error;
}

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues)
{
    ENTER3
    (void)valueSizes;
    return no_binary(I, "fmi3GetBinary", valueReferences, nValueReferences, values, nValues);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues)
{
    ENTER3
    (void)valueSizes;
    return no_binary(I, "fmi3SetBinary", valueReferences, nValueReferences, values, nValues);
}

/* ------------------------------------------------------------------------------ FMU state */
fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    ENTER3
    return (fmi3Status)fmi2GetFMUstate(I->inner, (fmi2FMUstate *)FMUState);
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    ENTER3
    fmi2Status s = fmi2SetFMUstate(I->inner, (fmi2FMUstate)FMUState);
    fmi2Real t;
    if (s <= fmi2Warning && fmi2GetRealStatus(I->inner, fmi2LastSuccessfulTime, &t) <= fmi2Warning) I->time = t;
    return (fmi3Status)s;
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    ENTER3
    return (fmi3Status)fmi2FreeFMUstate(I->inner, (fmi2FMUstate *)FMUState);
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size)
{
    ENTER3
    return (fmi3Status)fmi2SerializedFMUstateSize(I->inner, (fmi2FMUstate)FMUState, size);
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size)
{
    ENTER3
    return (fmi3Status)fmi2SerializeFMUstate(I->inner, (fmi2FMUstate)FMUState, (fmi2Byte *)serializedState, size);
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState)
{
    ENTER3
    return (fmi3Status)fmi2DeSerializeFMUstate(I->inner, (const fmi2Byte *)serializedState, size,
                                               (fmi2FMUstate *)FMUState);
}

/* ------------------------------------------------------------------------------ not offered */
#define NOT_OFFERED(fn, params, what)                                                              \
    fmi3Status fn params                                                                           \
    {                                                                                              \
        ENTER3                                                                                     \
        sayf(I, fmi3Error, "%s: %s", #fn, what);                                                   \
        return fmi3Error;                                                                          \
    }
NOT_OFFERED(fmi3GetNumberOfVariableDependencies,
            (fmi3Instance instance, fmi3ValueReference vr, size_t *n),
            "not offered (the dependencies are in modelDescription.xml)")
NOT_OFFERED(fmi3GetVariableDependencies,
            (fmi3Instance instance, fmi3ValueReference dependent, size_t elementIndicesOfDependent[],
             fmi3ValueReference independents[], size_t elementIndicesOfIndependents[],
             fmi3DependencyKind dependencyKinds[], size_t nDependencies),
            "not offered (the dependencies are in modelDescription.xml)")
NOT_OFFERED(fmi3GetDirectionalDerivative,
            (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
             const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
             fmi3Float64 sensitivity[], size_t nSensitivity),
            "not offered (providesDirectionalDerivatives is false)")
NOT_OFFERED(fmi3GetAdjointDerivative,
            (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
             const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
             fmi3Float64 sensitivity[], size_t nSensitivity),
            "not offered (providesAdjointDerivatives is false)")
NOT_OFFERED(fmi3EnterConfigurationMode, (fmi3Instance instance), "not offered (this FMU has no structural parameters)")
NOT_OFFERED(fmi3ExitConfigurationMode, (fmi3Instance instance), "not offered (this FMU has no structural parameters)")
/* the clock functions: (instance, vr, n, and what each takes) */
#define NO_CLOCKS(fn, ...)                                                                         \
    NOT_OFFERED(fn, (fmi3Instance instance, const fmi3ValueReference vr[], size_t n, __VA_ARGS__),            \
                "this FMU has no clocks")
NO_CLOCKS(fmi3GetIntervalDecimal, fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[])
NO_CLOCKS(fmi3GetIntervalFraction, fmi3UInt64 counters[], fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[])
NO_CLOCKS(fmi3GetShiftDecimal, fmi3Float64 shifts[])
NO_CLOCKS(fmi3GetShiftFraction, fmi3UInt64 counters[], fmi3UInt64 resolutions[])
NO_CLOCKS(fmi3SetIntervalDecimal, const fmi3Float64 intervals[])
NO_CLOCKS(fmi3SetIntervalFraction, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
NO_CLOCKS(fmi3SetShiftDecimal, const fmi3Float64 shifts[])
NO_CLOCKS(fmi3SetShiftFraction, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
#undef NO_CLOCKS
NOT_OFFERED(fmi3EvaluateDiscreteStates, (fmi3Instance instance), "not offered (Model Exchange and Event Mode only)")
NOT_OFFERED(fmi3UpdateDiscreteStates,
            (fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate, fmi3Boolean *terminateSimulation,
             fmi3Boolean *nominalsOfContinuousStatesChanged, fmi3Boolean *valuesOfContinuousStatesChanged,
             fmi3Boolean *nextEventTimeDefined, fmi3Float64 *nextEventTime),
            "not offered (this FMU has no Event Mode)")
NOT_OFFERED(fmi3EnterContinuousTimeMode, (fmi3Instance instance), "not offered (Co-Simulation only)")
NOT_OFFERED(fmi3CompletedIntegratorStep,
            (fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *enterEventMode,
             fmi3Boolean *terminateSimulation),
            "not offered (Co-Simulation only)")
NOT_OFFERED(fmi3SetTime, (fmi3Instance instance, fmi3Float64 time), "not offered (Co-Simulation only)")
NOT_OFFERED(fmi3SetContinuousStates, (fmi3Instance instance, const fmi3Float64 x[], size_t n),
            "not offered (Co-Simulation only)")
NOT_OFFERED(fmi3GetContinuousStateDerivatives, (fmi3Instance instance, fmi3Float64 d[], size_t n),
            "not offered (Co-Simulation only)")
NOT_OFFERED(fmi3GetEventIndicators, (fmi3Instance instance, fmi3Float64 e[], size_t n),
            "not offered (Co-Simulation only)")
NOT_OFFERED(fmi3GetContinuousStates, (fmi3Instance instance, fmi3Float64 x[], size_t n),
            "not offered (Co-Simulation only)")
NOT_OFFERED(fmi3GetNominalsOfContinuousStates, (fmi3Instance instance, fmi3Float64 x[], size_t n),
            "not offered (Co-Simulation only)")
NOT_OFFERED(fmi3GetNumberOfEventIndicators, (fmi3Instance instance, size_t *n), "not offered (Co-Simulation only)")
NOT_OFFERED(fmi3GetNumberOfContinuousStates, (fmi3Instance instance, size_t *n), "not offered (Co-Simulation only)")
NOT_OFFERED(fmi3ActivateModelPartition,
            (fmi3Instance instance, fmi3ValueReference clockReference, fmi3Float64 activationTime),
            "not offered (Co-Simulation only)")
#undef NOT_OFFERED
