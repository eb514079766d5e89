/* The FMU's binary as a host loads it: binaries/linux64/<modelIdentifier>.so.
 *
 * It depends on nothing but the C library, so any host can dlopen it whatever Python (if any) it
 * runs. The FMU carries its own Python (resources/python/, described by
 * resources/python_runtime.cfg, read strictly by runtime_cfg.h). fmi2Instantiate decides where the
 * model runs:
 *   - the process runs no Python (a C host): in this process, on the FMU's own Python (its
 *     libraries made global, the interpreter started isolated with the FMU's module path only);
 *   - the process runs the runtime's Python version (a Python host, or a C host where another of
 *     our FMUs started it): in this process, on that interpreter;
 *   - the process runs another Python version: in a process of its own, on the FMU's Python
 *     (fmi2_remote.c, fmi2_server.c: shared memory, one round trip per call).
 * SPURDIFF_FMU_PROCESS=out asks for the process of its own in any host (a crash of the model is
 * then an error status, never the host's crash); =in refuses instead of starting one; unset or
 * auto: as above. Either way the model is the bridge (fmi2_pybridge.c) over the FMU's package.
 * Any failure is logged through the host's logger with the reason, and fmi2Instantiate returns
 * NULL. Getters and setters refuse a NULL array for n > 0 here, whichever side runs the model.
 * binaries/win64/<modelIdentifier>.dll is this file cross-built with mingw-w64 (the system calls in
 * platform.h): the model runs in the host's process only, on the FMU's own Python (described by
 * resources/python_runtime_win64.cfg) or the host's of the same version; the model's own process
 * is not built for Windows, so a host running another Python version is refused with the reason.
 */
#define _GNU_SOURCE
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "fmi2_inproc.h"
#include "fmi2_remote.h"

#define HANDLE_MAGIC 0x5350444Cu   /* "SPDL" */
#define PROCESS_ENV "SPURDIFF_FMU_PROCESS"

typedef struct {
    unsigned magic;
    const Fmi2Table *t;        /* the bridge's functions, or REMOTE_TABLE */
    fmi2Component inner;
    fmi2CallbackFunctions cb;
    char *iname;
    int fmi3;                  /* the FMI 3.0 binary's instance (spurdiffEnableFmi3): output derivatives */
} Handle;

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
    return plat_own_dir((const void *)&own_dir, out, size);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    char resources[PATH_MAX], bindir[PATH_MAX], err[4 * CFG_MAX_LINE], version[64];
    RuntimeCfg cfg;
    if (!instanceName || !*instanceName) {
        log_error(functions, instanceName, "fmi2Instantiate: instanceName must be a non-empty string");
        return NULL;
    }
    if (!fmuResourceLocation || cfg_uri_to_path(fmuResourceLocation, resources, sizeof resources) != 0
        || plat_path_utf8(resources, sizeof resources) != 0) {
        log_error(functions, instanceName, "fmi2Instantiate: fmuResourceLocation '%.1000s' is not a local file URI",
                  fmuResourceLocation ? fmuResourceLocation : "(null)");
        return NULL;
    }
    if (!plat_is_dir(resources)) {
        log_error(functions, instanceName, "fmi2Instantiate: the resources folder %s does not exist "
                  "(the FMU was not extracted completely)", resources);
        return NULL;
    }
    if (own_dir(bindir, sizeof bindir) != 0) {
        log_error(functions, instanceName, "fmi2Instantiate: cannot locate the FMU's binary folder");
        return NULL;
    }
    if (cfg_read(resources, &cfg, err, sizeof err) != 0) {
        log_error(functions, instanceName, "fmi2Instantiate: %s", err);
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, cfg.guid) != 0) {
        log_error(functions, instanceName, "fmi2Instantiate: GUID '%.200s' does not match this FMU's "
                  "modelDescription.xml ('%s')", fmuGUID ? fmuGUID : "(null)", cfg.guid);
        cfg_free(&cfg);
        return NULL;
    }
    const char *mode = getenv(PROCESS_ENV);
    if (!mode || !*mode) mode = "auto";
    if (strcmp(mode, "auto") && strcmp(mode, "in") && strcmp(mode, "out")) {
        log_error(functions, instanceName, "fmi2Instantiate: %s = '%.40s'; allowed: auto (default), in, out",
                  PROCESS_ENV, mode);
        cfg_free(&cfg);
        return NULL;
    }
    int host = inproc_host_python(&cfg, version, sizeof version);
    int remote = !strcmp(mode, "out") || (host == INPROC_OTHER);
#ifdef _WIN32
    if (remote) {
        if (host == INPROC_OTHER)
            log_error(functions, instanceName, "fmi2Instantiate: this process runs Python %s, the FMU's runtime is "
                      "Python %s, and the win64 binary runs the model in the host's process only (use a host "
                      "without Python or with Python %s)", version, cfg.version, cfg.version);
        else
            log_error(functions, instanceName, "fmi2Instantiate: %s=out: the win64 binary runs the model in the "
                      "host's process only (unset it)", PROCESS_ENV);
        cfg_free(&cfg);
        return NULL;
    }
#endif
    if (remote && !strcmp(mode, "in")) {
        log_error(functions, instanceName, "fmi2Instantiate: this process runs Python %s, the FMU's runtime is "
                  "Python %s, and %s=in forbids the model's own process (unset it to allow one)",
                  version, cfg.version, PROCESS_ENV);
        cfg_free(&cfg);
        return NULL;
    }
    Handle *h = (Handle *)calloc(1, sizeof *h);
    if (!h) {
        cfg_free(&cfg);
        return NULL;
    }
    h->magic = HANDLE_MAGIC;
    h->iname = strdup(instanceName);
    if (functions) h->cb = *functions;
    err[0] = 0;
#ifndef _WIN32
    if (remote) {
        h->t = &REMOTE_TABLE;
        h->inner = remote_instantiate(instanceName, fmuType, fmuGUID, resources, bindir, functions, visible,
                                      loggingOn, err, sizeof err);
    } else
#endif
    if (inproc_load(&cfg, resources, bindir, &h->t, err, sizeof err) == 0) {
        h->inner = h->t->fmi2Instantiate(instanceName, fmuType, fmuGUID, resources, functions, visible, loggingOn);
    }
    cfg_free(&cfg);
    if (!h->inner) {
        if (err[0]) log_error(functions, instanceName, "fmi2Instantiate: %s", err);
        free(h->iname);
        free(h);
        return NULL;
    }
    return h;
}

static Handle *handle(fmi2Component c)
{
    Handle *h = (Handle *)c;
    return (h && h->magic == HANDLE_MAGIC) ? h : NULL;
}

void fmi2FreeInstance(fmi2Component c)
{
    Handle *h = handle(c);
    if (!h) return;
    h->t->fmi2FreeInstance(h->inner);
    h->magic = 0;
    free(h->iname);
    free(h);
}

/* Strings are handed out even when the call fails ("" each): some hosts read them without
 * looking at the status (the ecos command line did, after an fmi2Instantiate that returned NULL). */
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[])
{
    Handle *h = handle(c);
    fmi2Status s = fmi2Error;
    if (h && n && (!vr || !v))
        log_error(&h->cb, h->iname, "fmi2GetString: %s is NULL for nvr = %zu", vr ? "value" : "vr", n);
    else if (h)
        s = h->t->fmi2GetString(h->inner, vr, n, v);
    if (s > fmi2Warning && v)
        for (size_t i = 0; i < n; i++) v[i] = "";
    return s;
}

#define X_ARRAYS(name, params, args)                                                               \
    fmi2Status name params                                                                         \
    {                                                                                              \
        Handle *hd_ = handle(c);                                                                     \
        if (!hd_) return fmi2Error;                                                                  \
        if (n && (!vr || !v)) {                                                                    \
            log_error(&hd_->cb, hd_->iname, #name ": %s is NULL for nvr = %zu", vr ? "value" : "vr", n); \
            return fmi2Error;                                                                      \
        }                                                                                          \
        c = hd_->inner;                                                                              \
        return hd_->t->name args;                                                                    \
    }
FMI2_FORWARDED_ARRAYS(X_ARRAYS)
#undef X_ARRAYS

/* fmi2GetRealOutputDerivatives: the FMI 2.0 FMU declares maxOutputDerivativeOrder = 0 and refuses
 * it here, as the bridge did before it answered the FMI 3.0 binary's fmi3GetOutputDerivatives
 * (the strcmp of two literals is folded by the compiler) */
static int refused_in_fmi2(const Handle *h, const char *fn)
{
    if (h->fmi3 || strcmp(fn, "fmi2GetRealOutputDerivatives")) return 0;
    log_error(&h->cb, h->iname, "fmi2GetRealOutputDerivatives: not offered (maxOutputDerivativeOrder is 0)");
    return 1;
}

#define X_PLAIN(name, params, args)                                                                \
    fmi2Status name params                                                                         \
    {                                                                                              \
        Handle *hd_ = handle(c);                                                                     \
        if (!hd_ || refused_in_fmi2(hd_, #name)) return fmi2Error;                                 \
        c = hd_->inner;                                                                              \
        return hd_->t->name args;                                                                    \
    }
FMI2_FORWARDED_PLAIN(X_PLAIN)
#undef X_PLAIN

/* ------------------------------------------------------------------------------ FMI 3.0 extensions
 * Called by the FMI 3.0 binary's fmi3_loader.c only (linked with this file; the FMI 2.0 FMU's hosts
 * never know these names). */

/* The instance belongs to the FMI 3.0 binary: fmi2GetRealOutputDerivatives reaches the model. */
fmi2Status spurdiffEnableFmi3(fmi2Component c)
{
    Handle *h = handle(c);
    if (!h) return fmi2Error;
    h->fmi3 = 1;
    return fmi2OK;
}

/* fmi2DoStep that may end early at a stick/slip transition, *end the time reached. */
fmi2Status spurdiffDoStepEarly(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean nsp, fmi2Real *end)
{
    Handle *hd = handle(c);
    if (!hd) return fmi2Error;
#ifndef _WIN32
    if (hd->t == &REMOTE_TABLE) return remote_do_step_early(hd->inner, t, h, nsp, end);
#endif
    return inproc_do_step_early(hd->inner, t, h, nsp, end);
}
