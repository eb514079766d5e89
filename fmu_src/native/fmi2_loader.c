/* The FMU's binary as a host loads it: binaries/linux64/<modelIdentifier>.so.
 *
 * It depends on nothing but the C library, so any host can dlopen it whatever Python (if any)
 * it runs. fmi2Instantiate then
 *   1. reads resources/python_runtime.cfg (the Python the FMU was built with);
 *   2. makes that Python's symbols global: if the process already has a Python (a Python host,
 *      or a C host with libpython preloaded) it is used; otherwise the recorded libpython is
 *      loaded with RTLD_GLOBAL, which numpy's and the standard library's extension modules need
 *      (they do not link libpython themselves). Nothing in the host's environment is changed;
 *   3. loads the bridge (fmi2_pybridge.so beside this file, which starts the interpreter with the
 *      recorded home and module path, and never finalizes it) and forwards every call to it.
 * Any failure is logged through the host's logger with the reason, and fmi2Instantiate returns
 * NULL. The forwarding table below is the only list of FMI functions in this file.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <limits.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "fmi2Functions.h"
#include "runtime_cfg.h"

#define BRIDGE_FILE "fmi2_pybridge.so"
#define BRIDGE_PREFIX "spurdiff_bridge_"

/* name, parameter list, argument list of every function with an fmi2Component */
#define FMI2_FORWARDED(X)                                                                          \
    X(fmi2SetDebugLogging, (fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]), (c, on, n, cat)) \
    X(fmi2SetupExperiment, (fmi2Component c, fmi2Boolean td, fmi2Real tol, fmi2Real t0, fmi2Boolean sd, fmi2Real t1), (c, td, tol, t0, sd, t1)) \
    X(fmi2EnterInitializationMode, (fmi2Component c), (c))                                        \
    X(fmi2ExitInitializationMode, (fmi2Component c), (c))                                         \
    X(fmi2Terminate, (fmi2Component c), (c))                                                      \
    X(fmi2Reset, (fmi2Component c), (c))                                                          \
    X(fmi2GetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]), (c, vr, n, v)) \
    X(fmi2GetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]), (c, vr, n, v)) \
    X(fmi2GetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]), (c, vr, n, v)) \
    X(fmi2SetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]), (c, vr, n, v)) \
    X(fmi2SetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]), (c, vr, n, v)) \
    X(fmi2SetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]), (c, vr, n, v)) \
    X(fmi2SetString, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]), (c, vr, n, v)) \
    X(fmi2GetFMUstate, (fmi2Component c, fmi2FMUstate *s), (c, s))                                \
    X(fmi2SetFMUstate, (fmi2Component c, fmi2FMUstate s), (c, s))                                 \
    X(fmi2FreeFMUstate, (fmi2Component c, fmi2FMUstate *s), (c, s))                               \
    X(fmi2SerializedFMUstateSize, (fmi2Component c, fmi2FMUstate s, size_t *n), (c, s, n))        \
    X(fmi2SerializeFMUstate, (fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n), (c, s, b, n)) \
    X(fmi2DeSerializeFMUstate, (fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s), (c, b, n, s)) \
    X(fmi2GetDirectionalDerivative, (fmi2Component c, const fmi2ValueReference u[], size_t nu, const fmi2ValueReference z[], size_t nz, const fmi2Real du[], fmi2Real dz[]), (c, u, nu, z, nz, du, dz)) \
    X(fmi2SetRealInputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[], const fmi2Real v[]), (c, vr, n, o, v)) \
    X(fmi2GetRealOutputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[], fmi2Real v[]), (c, vr, n, o, v)) \
    X(fmi2DoStep, (fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean nsp), (c, t, h, nsp))   \
    X(fmi2CancelStep, (fmi2Component c), (c))                                                     \
    X(fmi2GetStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Status *v), (c, k, v))        \
    X(fmi2GetRealStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Real *v), (c, k, v))      \
    X(fmi2GetIntegerStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Integer *v), (c, k, v)) \
    X(fmi2GetBooleanStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Boolean *v), (c, k, v)) \
    X(fmi2GetStringStatus, (fmi2Component c, const fmi2StatusKind k, fmi2String *v), (c, k, v))

static struct {
    fmi2InstantiateTYPE *fmi2Instantiate;
    fmi2FreeInstanceTYPE *fmi2FreeInstance;
    fmi2GetStringTYPE *fmi2GetString;
#define X_MEMBER(name, params, args) name##TYPE *name;
    FMI2_FORWARDED(X_MEMBER)
#undef X_MEMBER
} B;

static pthread_mutex_t load_lock = PTHREAD_MUTEX_INITIALIZER;

static void log_error(const fmi2CallbackFunctions *f, fmi2String name, const char *fmt, ...)
{
    char msg[4 * CFG_MAX_LINE];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (f && f->logger) {   /* the text as the format, '%' doubled (see fmi2_pybridge.c: emit) */
        char buf[sizeof msg * 2 + 1];
        size_t n = 0;
        for (const char *p = msg; *p; p++) {
            if (*p == '%') buf[n++] = '%';
            buf[n++] = *p;
        }
        buf[n] = 0;
        f->logger(f->componentEnvironment, name ? name : "", fmi2Error, "logStatusError", buf);
    }
    else
        fprintf(stderr, "%s: %s\n", name ? name : "fmi2Instantiate", msg);
}

/* Directory of this shared object (binaries/<platform>/). */
static int own_dir(char *out, size_t size)
{
    Dl_info info;
    if (!dladdr((void *)&own_dir, &info) || !info.dli_fname) return -1;
    snprintf(out, size, "%s", info.dli_fname);
    char *slash = strrchr(out, '/');
    if (!slash) return -1;
    *slash = 0;
    return 0;
}

/* Python's symbols global, then the bridge loaded and its table filled. 0 or -1 with `err`. */
static int load_bridge(const RuntimeCfg *cfg, char *err, size_t errsize)
{
    if (B.fmi2Instantiate) return 0;
    if (!dlsym(RTLD_DEFAULT, "Py_IsInitialized")) {
        if (!dlopen(cfg->libpython, RTLD_NOW | RTLD_GLOBAL)) {
            snprintf(err, errsize,
                     "cannot load %s, the Python %s this FMU was built with (%s): install that Python "
                     "with its shared library, or rebuild the FMU with the host's Python",
                     cfg->libpython, cfg->version, dlerror());
            return -1;
        }
    }
    char dir[PATH_MAX], file[PATH_MAX + 32];
    if (own_dir(dir, sizeof dir) != 0) {
        snprintf(err, errsize, "cannot locate the FMU's binary directory");
        return -1;
    }
    snprintf(file, sizeof file, "%s/%s", dir, BRIDGE_FILE);
    void *h = dlopen(file, RTLD_NOW | RTLD_LOCAL);
    if (!h) {
        snprintf(err, errsize, "cannot load the Python bridge %s: %s", file, dlerror());
        return -1;
    }
    void *sym;
#define LOAD(name)                                                                                  \
    if (!(sym = dlsym(h, BRIDGE_PREFIX #name))) {                                                  \
        snprintf(err, errsize, "the bridge %s lacks %s", file, BRIDGE_PREFIX #name);               \
        return -1;                                                                                 \
    }                                                                                              \
    memcpy(&B.name, &sym, sizeof sym);
#define X_LOAD(name, params, args) LOAD(name)
    FMI2_FORWARDED(X_LOAD)
    LOAD(fmi2FreeInstance)
    LOAD(fmi2GetString)
    LOAD(fmi2Instantiate)   /* last: it marks the table complete */
#undef X_LOAD
#undef LOAD
    return 0;
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    char resources[PATH_MAX], err[4 * CFG_MAX_LINE];
    struct stat st;
    RuntimeCfg cfg;
    if (!instanceName || !*instanceName) {
        log_error(functions, instanceName, "fmi2Instantiate: instanceName must be a non-empty string");
        return NULL;
    }
    if (!fmuResourceLocation || cfg_uri_to_path(fmuResourceLocation, resources, sizeof resources) != 0) {
        log_error(functions, instanceName, "fmi2Instantiate: fmuResourceLocation '%s' is not a local file URI",
                  fmuResourceLocation ? fmuResourceLocation : "(null)");
        return NULL;
    }
    if (stat(resources, &st) != 0 || !S_ISDIR(st.st_mode)) {
        log_error(functions, instanceName, "fmi2Instantiate: the resources folder %s does not exist "
                  "(the FMU was not extracted completely)", resources);
        return NULL;
    }
    if (cfg_read(resources, &cfg, err, sizeof err) != 0) {
        log_error(functions, instanceName, "fmi2Instantiate: %s", err);
        return NULL;
    }
    pthread_mutex_lock(&load_lock);
    int rc = load_bridge(&cfg, err, sizeof err);
    pthread_mutex_unlock(&load_lock);
    cfg_free(&cfg);
    if (rc != 0) {
        log_error(functions, instanceName, "fmi2Instantiate: %s", err);
        return NULL;
    }
    return B.fmi2Instantiate(instanceName, fmuType, fmuGUID, resources, functions, visible, loggingOn);
}

/* Strings are handed out even when the call fails ("" each): some hosts read them without
 * looking at the status (the ecos command line did, after an fmi2Instantiate that returned NULL). */
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[])
{
    fmi2Status s = (c && B.fmi2GetString) ? B.fmi2GetString(c, vr, n, v) : fmi2Error;
    if (s > fmi2Warning && v)
        for (size_t i = 0; i < n; i++) v[i] = "";
    return s;
}

void fmi2FreeInstance(fmi2Component c)
{
    if (c && B.fmi2FreeInstance) B.fmi2FreeInstance(c);
}

#define X_FORWARD(name, params, args)                                                               \
    fmi2Status name params                                                                         \
    {                                                                                              \
        if (!c || !B.name) return fmi2Error;                                                       \
        return B.name args;                                                                        \
    }
FMI2_FORWARDED(X_FORWARD)
#undef X_FORWARD
