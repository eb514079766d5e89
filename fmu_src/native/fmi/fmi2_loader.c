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
 * Before any of that, an FMU that carries a native start (resources/native_start.bin, native_start.c)
 * answers the instance without Python while the host keeps the FMU's defaults: its Python (in this
 * process or its own, as above) starts at the first call the native start does not answer, which
 * is then passed on after the calls before the first step were replayed there and the native step's
 * state handed to it (promote). SPURDIFF_FMU_START=python
 * starts the Python at fmi2Instantiate, as an FMU without a native start does; unset or auto: as above.
 * A model in its own process that has a compiled step hands it to the host's process (the hand-over):
 * at a step, the loader asks the model's process for the step's arrays and steps them here
 * (native_start.c: ns_open_live) with the native start's rules, bit for bit what the model's process
 * computes, so that a step costs no round trip; any call not answered here gives the arrays back
 * first (give_back), and is then passed on. SPURDIFF_FMU_STEP=model keeps every step in the model's
 * process; unset or auto: as above.
 * The start cache (native_start.c): a host that sets parameters to other values starts the Python at the
 * model's build; at fmi2FreeInstance the loader asks the model for its native start of exactly those
 * values and keeps it in the user's cache (<XDG_CACHE_HOME or ~/.cache>/spurdiff/starts, or the absolute
 * folder SPURDIFF_FMU_START_CACHE_DIR), where the next instance that sets the same values finds it and
 * builds without Python. SPURDIFF_FMU_START_CACHE=off neither reads nor writes it; unset or auto: as
 * above (not on Windows).
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
#include "log_text.h"
#include "native_start.h"

#define HANDLE_MAGIC 0x5350444Cu   /* "SPDL" */
#define PROCESS_ENV "SPURDIFF_FMU_PROCESS"
#define START_ENV "SPURDIFF_FMU_START"
#define STEP_ENV "SPURDIFF_FMU_STEP"
#define CACHE_ENV "SPURDIFF_FMU_START_CACHE"
#define LIVE_SHORT 8               /* a hand-over given back within this many steps: ask later next time */
#define LIVE_WAIT_MAX 1024u        /* the most steps the model's process takes before the loader asks again */
#define HELD_MAX 65536             /* the bytes of the messages held while the Python starts */

typedef struct {
    unsigned magic;
    const Fmi2Table *t;        /* the bridge's functions, or REMOTE_TABLE */
    fmi2Component inner;
    fmi2CallbackFunctions cb;
    char *iname;
    int fmi3;                  /* the FMI 3.0 binary's instance (spurdiffEnableFmi3): output derivatives */
    /* the native start and what starting the Python later needs */
    NsInst *ns;                /* answering natively, no model yet */
    int broken;                /* the Python could not start after a native start: every call fails */
    int remote;
    RuntimeCfg cfg;
    fmi2Type type;
    char *guid, *resources, *bindir;
    fmi2Boolean visible, logging;
    fmi2CallbackFunctions relay_cb;   /* the model's callbacks after a native start (relay below) */
    int handover;              /* the model's own process hands its compiled step to this one (ns then live) */
    int live_never;            /* it has none to hand over (asked again after fmi2Reset or fmi2SetFMUstate) */
    unsigned live_wait, live_backoff;   /* steps the model's process takes before the loader asks again */
    char *cache_file;          /* the start cache's file to write at fmi2FreeInstance (native_start.c) */
    unsigned char *cache_sets; /* the values set that the model's snapshot is of */
    size_t cache_sets_len;
    int muted;                 /* the replay runs: its messages are held, shown only if it fails */
    char *held;
    size_t held_len;
} Handle;

static void log_va(const fmi2CallbackFunctions *f, fmi2String name, fmi2Status status, const char *fmt, va_list ap)
{
    char msg[4 * CFG_MAX_LINE];
    vsnprintf(msg, sizeof msg, fmt, ap);
    log_text(f, name ? name : "fmi2Instantiate", status, status == fmi2Warning ? "logStatusWarning" : "logStatusError",
             msg);
}

static void log_error(const fmi2CallbackFunctions *f, fmi2String name, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    log_va(f, name, fmi2Error, fmt, ap);
    va_end(ap);
}

static void log_warning(const fmi2CallbackFunctions *f, fmi2String name, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    log_va(f, name, fmi2Warning, fmt, ap);
    va_end(ap);
}

/* Directory of this shared object (binaries/<platform>/). */
static int own_dir(char *out, size_t size)
{
    return plat_own_dir((const void *)&own_dir, out, size);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

/* Start the model (its Python in this process or its own, as the header says) with the callbacks `cb`:
 * 0, or -1 (`err` says why, or is empty when the model logged it). */
static int start_model(Handle *h, const fmi2CallbackFunctions *cb, char *err, size_t errsize)
{
#ifndef _WIN32
    if (h->remote) {
        h->t = &REMOTE_TABLE;
        h->inner = remote_instantiate(h->iname, h->type, h->guid, h->resources, h->bindir, cb, h->visible, h->logging,
                                      err, errsize);
    } else
#endif
    if (inproc_load(&h->cfg, h->resources, h->bindir, &h->t, err, errsize) == 0) {
        h->inner = h->t->fmi2Instantiate(h->iname, h->type, h->guid, h->resources, cb, h->visible, h->logging);
    }
    return h->inner ? 0 : -1;
}

static void drop(Handle *h)
{
    if (h->ns) ns_free(h->ns);
    cfg_free(&h->cfg);
    h->magic = 0;
    free(h->iname);
    free(h->guid);
    free(h->resources);
    free(h->bindir);
    free(h->held);
    free(h->cache_file);
    free(h->cache_sets);
    free(h);
}

/* The model's logger after a native start: the host's, but for the messages of the replay, which are
 * held (the host saw them from the native start) and shown only if the replay fails. */
static void relay(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                  fmi2String message, ...)
{
    Handle *h = (Handle *)env;
    va_list ap, aq;
    va_start(ap, message);
    va_copy(aq, ap);
    int len = vsnprintf(NULL, 0, message ? message : "", ap);   /* the whole text, however long */
    va_end(ap);
    char *text = len >= 0 ? (char *)malloc((size_t)len + 1) : NULL;
    if (text) vsnprintf(text, (size_t)len + 1, message ? message : "", aq);
    va_end(aq);
    if (!text) return;
    if (h->muted) {
        size_t n = strlen(text) + 2;
        char *held = h->held_len + n <= HELD_MAX ? (char *)realloc(h->held, h->held_len + n) : NULL;
        if (held) {
            held[h->held_len] = (char)('0' + (int)status);
            memcpy(held + h->held_len + 1, text, n - 1);
            h->held = held;
            h->held_len += n;
        }
    } else {
        log_text(&h->cb, name, status, category, text);
    }
    free(text);
}

/* the model's early-return step (FMI 3.0), wherever it runs */
typedef fmi2Status StepEarly(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean nsp, fmi2Real *end);
static StepEarly *early_step_of(const Handle *h)
{
#ifndef _WIN32
    if (h->remote) return remote_do_step_early;
#endif
    (void)h;
    return inproc_do_step_early;
}

/* the model's side of the native start's hand-over (ns_replay), wherever it runs */
#ifndef _WIN32
static int remote_take(fmi2Component c, unsigned char **bytes, size_t *len)
{
    fmi2Status pre;
    int kind = remote_native_export(c, bytes, len, &pre);
    return pre > fmi2Warning ? -1 : kind;
}
static const NsHandOver REMOTE_HAND_OVER = {remote_take, remote_native_import};
#endif
static const NsHandOver INPROC_HAND_OVER = {inproc_native_export, inproc_native_import};

static const NsHandOver *hand_over_of(const Handle *h)
{
#ifndef _WIN32
    if (h->remote) return &REMOTE_HAND_OVER;
#endif
    (void)h;
    return &INPROC_HAND_OVER;
}

/* The call the native start does not answer: start the model's Python, replay the native start's
 * calls there (its steps as their state), go on with the model. 0, or -1 (logged; the instance then
 * fails every call). */
static int promote(Handle *h)
{
    char err[4 * CFG_MAX_LINE];
    err[0] = 0;
    long steps = ns_steps(h->ns);
    h->relay_cb = h->cb;
    h->relay_cb.logger = relay;
    h->relay_cb.componentEnvironment = h;
    h->muted = 1;
    int rc = start_model(h, &h->relay_cb, err, sizeof err);
    if (rc == 0) rc = ns_replay(h->ns, h->t, h->inner, hand_over_of(h), err, sizeof err);
    h->muted = 0;
    if (rc != 0) {
        for (size_t i = 0; h->held && i < h->held_len; i += strlen(h->held + i + 1) + 2)
            relay(h, h->iname, (fmi2Status)(h->held[i] - '0'), "logAll", h->held + i + 1);
        log_error(&h->cb, h->iname, "starting the model's Python after the native start (%ld steps): %s", steps,
                  err[0] ? err : "see the messages above");
        if (h->inner) h->t->fmi2FreeInstance(h->inner);
        h->inner = NULL;
        h->broken = 1;
    }
    free(h->held);
    h->held = NULL;
    h->held_len = 0;
    char file[PATH_MAX];
    unsigned char *sets = NULL;
    size_t len = 0;
    if (rc == 0 && ns_cache_want(h->ns, file, sizeof file, &sets, &len) && (h->cache_file = strdup(file))) {
        h->cache_sets = sets;   /* the model's snapshot of these values, at fmi2FreeInstance */
        h->cache_sets_len = len;
    } else {
        free(sets);
    }
    ns_free(h->ns);
    h->ns = NULL;
    return rc;
}

#ifndef _WIN32
/* ------------------------------------------------------------------------------ the hand-over */
static void back_off(Handle *h)
{
    h->live_backoff = h->live_backoff * 2 + 1 < LIVE_WAIT_MAX ? h->live_backoff * 2 + 1 : LIVE_WAIT_MAX;
    h->live_wait = h->live_backoff;
}

/* Before a step of the model in its own process: its compiled step here when it has one (h->ns live
 * after). 0, or -1 when the step must not be taken (*pre: the status, a deferred fmi2SetReal failed;
 * else *pre is the status of the calls that went with the question). */
static int take_step(Handle *h, fmi2Status *pre)
{
    *pre = fmi2OK;
    if (!h->handover || h->ns || !h->inner || h->broken || h->live_never) return 0;
    if (h->live_wait) {
        h->live_wait--;
        return 0;
    }
    unsigned char *bytes = NULL;
    size_t len = 0;
    int kind = remote_native_export(h->inner, &bytes, &len, pre);
    if (*pre > fmi2Warning) {
        free(bytes);
        return -1;
    }
    if (kind < 0) {
        h->live_never = 1;
    } else if (kind == 0) {
        back_off(h);
    } else {
        char err[4 * CFG_MAX_LINE];
        if (ns_open_live(bytes, len, h->resources, h->iname, &h->cb, &h->ns, err, sizeof err) < 0) {
            /* nothing to give back: the model's process keeps its state until its arrays come back */
            log_warning(&h->cb, h->iname, "fmi2DoStep: the compiled step stays in the model's process: %s", err);
            h->live_never = 1;
        }
    }
    free(bytes);
    return 0;
}

/* The hand-over's arrays back to the model's process before a call not answered here: 0, or -1
 * (logged; the model's state is lost with them, and the instance fails every call). */
static int give_back(Handle *h)
{
    double *arrays = NULL, time = 0.0;
    size_t n = 0;
    int bad = 0, rc = -1;
    long steps = 0;
    if (ns_live_state(h->ns, &arrays, &n, &time, &bad, &steps) == 0)
        rc = remote_native_import(h->inner, arrays, n, time, bad, steps) <= fmi2Warning ? 0 : -1;
    free(arrays);
    if (steps < LIVE_SHORT) back_off(h);
    else h->live_backoff = 0;
    ns_free(h->ns);
    h->ns = NULL;
    if (rc != 0) {
        log_error(&h->cb, h->iname, "the model's process did not take back the state of the %ld steps taken in "
                  "this one: the instance is lost; free it and instantiate again", steps);
        h->broken = 1;
    }
    return rc;
}
#endif

/* The environment variable `env`: "auto" when unset or empty, its value when that is "auto" or `other`;
 * else NULL, logged naming both. */
static const char *env_mode(const fmi2CallbackFunctions *f, fmi2String name, const char *env, const char *other)
{
    const char *v = getenv(env);
    if (!v || !*v) return "auto";
    if (!strcmp(v, "auto") || !strcmp(v, other)) return v;
    log_error(f, name, "fmi2Instantiate: %s = '%.40s'; allowed: auto (default), %s", env, v, other);
    return NULL;
}

/* The start cache's folder: $SPURDIFF_FMU_START_CACHE_DIR (absolute), else $XDG_CACHE_HOME/spurdiff/starts
 * (an absolute XDG_CACHE_HOME), else $HOME/.cache/spurdiff/starts: 0, or -1 (none, too long, or Windows:
 * no cache). */
static int start_cache_dir(char *out, size_t size)
{
#ifdef _WIN32
    (void)out; (void)size;
    return -1;
#else
    const char *own = getenv(CACHE_ENV "_DIR"), *xdg = getenv("XDG_CACHE_HOME"), *home = getenv("HOME");
    int w;
    if (own && own[0] == '/') w = snprintf(out, size, "%s", own);
    else if (own && own[0]) return -1;   /* not absolute: no cache (never a folder relative to the host's) */
    else if (xdg && xdg[0] == '/') w = snprintf(out, size, "%s/spurdiff/starts", xdg);
    else if (home && home[0] == '/') w = snprintf(out, size, "%s/.cache/spurdiff/starts", home);
    else return -1;
    return w < 0 || (size_t)w >= size ? -1 : 0;
#endif
}

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
    const char *start = env_mode(functions, instanceName, START_ENV, "python");
    if (!start) {
        cfg_free(&cfg);
        return NULL;
    }
    const char *step = env_mode(functions, instanceName, STEP_ENV, "model");
    if (!step) {
        cfg_free(&cfg);
        return NULL;
    }
    const char *caching = env_mode(functions, instanceName, CACHE_ENV, "off");
    if (!caching) {
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
    h->remote = remote;
    h->handover = remote && !strcmp(step, "auto");
    h->cfg = cfg;
    h->type = fmuType;
    h->guid = strdup(fmuGUID);
    h->resources = strdup(resources);
    h->bindir = strdup(bindir);
    h->visible = visible;
    h->logging = loggingOn;
    err[0] = 0;
    int native = 0;
    /* another type than co-simulation: the model refuses it (its message), never the native start */
    if (!strcmp(start, "auto") && fmuType == fmi2CoSimulation && h->iname && h->guid && h->resources && h->bindir) {
        native = ns_open(resources, instanceName, functions, loggingOn ? 1 : 0, &h->ns, err, sizeof err);
        if (native < 0) {   /* a damaged native start: the Python starts now, as without one */
            log_warning(functions, instanceName, "fmi2Instantiate: the native start is not used: %s", err);
            err[0] = 0;
        }
        char dir[PATH_MAX];
        if (native > 0 && !strcmp(caching, "auto") && start_cache_dir(dir, sizeof dir) == 0)
            ns_start_cache(h->ns, dir, h->guid, h->resources);   /* (no memory: without it) */
    }
    if (native <= 0 && start_model(h, functions, err, sizeof err) != 0) {
        if (err[0]) log_error(functions, instanceName, "fmi2Instantiate: %s", err);
        drop(h);
        return NULL;
    }
    return h;
}

static Handle *handle(fmi2Component c)
{
    Handle *h = (Handle *)c;
    return (h && h->magic == HANDLE_MAGIC) ? h : NULL;
}

/* The instance ready for the model's call: 0, or -1 (it cannot start: logged once, then silent). */
static int model_ready(Handle *h)
{
    if (h->broken) return -1;
#ifndef _WIN32
    if (h->ns && ns_is_live(h->ns)) return give_back(h);
#endif
    return h->ns ? promote(h) : 0;
}

/* The model's native start of the values set, into the start cache (nothing said when it cannot be had:
 * the cache is an optimization; the next instance then starts its Python as this one did). */
static void keep_start(Handle *h)
{
    if (!h->cache_file || !h->inner || h->broken) return;
    unsigned char *bytes = NULL;
    size_t len = 0;
    int got;
#ifndef _WIN32
    if (h->remote) got = remote_start_snapshot(h->inner, h->cache_sets, h->cache_sets_len, &bytes, &len);
    else
#endif
    got = inproc_start_snapshot(h->inner, h->cache_sets, h->cache_sets_len, &bytes, &len);
    if (got == 1) ns_cache_store(h->cache_file, bytes, len);
    free(bytes);
}

void fmi2FreeInstance(fmi2Component c)
{
    Handle *h = handle(c);
    if (!h) return;
    keep_start(h);
    if (h->inner) h->t->fmi2FreeInstance(h->inner);
    drop(h);
}

/* ------------------------------------------------------------------------------ the native start's calls
 * nsw_<function>: the native start's answer to the call (a status), or NS_PYTHON */
#define NS(c) (((Handle *)(c))->ns)
static int nsw_fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) { return ns_get_real(NS(c), vr, n, v); }
static int nsw_fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) { return ns_get_integer(NS(c), vr, n, v); }
static int nsw_fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) { return ns_get_boolean(NS(c), vr, n, v); }
static int nsw_fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]) { return ns_set_real(NS(c), vr, n, v); }
static int nsw_fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) { return ns_set_integer(NS(c), vr, n, v); }
static int nsw_fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) { return ns_set_boolean(NS(c), vr, n, v); }
static int nsw_fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) { return ns_set_string(NS(c), vr, n, v); }
static int nsw_fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) { (void)cat; return ns_set_debug_logging(NS(c), on, n); }
static int nsw_fmi2SetupExperiment(fmi2Component c, fmi2Boolean td, fmi2Real tol, fmi2Real t0, fmi2Boolean sd, fmi2Real t1) { return ns_setup_experiment(NS(c), td, tol, t0, sd, t1); }
static int nsw_fmi2EnterInitializationMode(fmi2Component c) { return ns_enter_initialization_mode(NS(c)); }
static int nsw_fmi2ExitInitializationMode(fmi2Component c) { return ns_exit_initialization_mode(NS(c)); }
static int nsw_fmi2Terminate(fmi2Component c) { return ns_terminate(NS(c)); }
static int nsw_fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean nsp) { return ns_do_step(NS(c), t, h, nsp, 0, NULL); }
/* the model's Python answers these */
#define NS_NONE(name, params, args) static int nsw_##name params { return NS_PYTHON; }
NS_NONE(fmi2Reset, (fmi2Component c), (c))
NS_NONE(fmi2GetFMUstate, (fmi2Component c, fmi2FMUstate *s), (c, s))
NS_NONE(fmi2SetFMUstate, (fmi2Component c, fmi2FMUstate s), (c, s))
NS_NONE(fmi2FreeFMUstate, (fmi2Component c, fmi2FMUstate *s), (c, s))
NS_NONE(fmi2SerializedFMUstateSize, (fmi2Component c, fmi2FMUstate s, size_t *n), (c, s, n))
NS_NONE(fmi2SerializeFMUstate, (fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n), (c, s, b, n))
NS_NONE(fmi2DeSerializeFMUstate, (fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s), (c, b, n, s))
NS_NONE(fmi2GetDirectionalDerivative, (fmi2Component c, const fmi2ValueReference u[], size_t nu, const fmi2ValueReference z[], size_t nz, const fmi2Real du[], fmi2Real dz[]), (c, u, nu, z, nz, du, dz))
NS_NONE(fmi2SetRealInputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[], const fmi2Real v[]), (c, vr, n, o, v))
NS_NONE(fmi2GetRealOutputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[], fmi2Real v[]), (c, vr, n, o, v))
NS_NONE(fmi2CancelStep, (fmi2Component c), (c))
NS_NONE(fmi2GetStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Status *v), (c, k, v))
NS_NONE(fmi2GetRealStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Real *v), (c, k, v))
NS_NONE(fmi2GetIntegerStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Integer *v), (c, k, v))
NS_NONE(fmi2GetBooleanStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Boolean *v), (c, k, v))
NS_NONE(fmi2GetStringStatus, (fmi2Component c, const fmi2StatusKind k, fmi2String *v), (c, k, v))
#undef NS_NONE

/* Strings are handed out even when the call fails ("" each): some hosts read them without
 * looking at the status (the ecos command line did, after an fmi2Instantiate that returned NULL). */
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[])
{
    Handle *h = handle(c);
    fmi2Status s = fmi2Error;
    if (h && n && (!vr || !v))
        log_error(&h->cb, h->iname, "fmi2GetString: %s is NULL for nvr = %zu", vr ? "value" : "vr", n);
    else if (h && h->ns && (s = (fmi2Status)ns_get_string(h->ns, vr, n, v)) != (fmi2Status)NS_PYTHON)
        ;
    else if (h && model_ready(h) == 0)
        s = h->t->fmi2GetString(h->inner, vr, n, v);
    else
        s = fmi2Error;
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
        if (hd_->ns) {                                                                             \
            int r_ = nsw_##name args;                                                              \
            if (r_ != NS_PYTHON) return (fmi2Status)r_;                                            \
        }                                                                                          \
        if (model_ready(hd_) != 0) return fmi2Error;                                               \
        c = hd_->inner;                                                                              \
        return hd_->t->name args;                                                                    \
    }
FMI2_FORWARDED_ARRAYS(X_ARRAYS)
#undef X_ARRAYS

static fmi2Status worse(fmi2Status a, fmi2Status b) { return a > b ? a : b; }

/* Before a step: the hand-over (take_step) when the model runs in its own process. */
static int before_step(Handle *h, fmi2Status *pre)
{
#ifndef _WIN32
    return take_step(h, pre);
#else
    (void)h;
    *pre = fmi2OK;
    return 0;
#endif
}

/* After fmi2Reset or fmi2SetFMUstate passed on: the model may have a compiled step to hand over now. */
static void after_reset(Handle *h)
{
    h->live_never = 0;
    h->live_wait = h->live_backoff = 0;
}

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
        fmi2Status pre_ = fmi2OK;                                                                  \
        if (!strcmp(#name, "fmi2DoStep") && !hd_->ns && before_step(hd_, &pre_) != 0) return pre_; \
        if (hd_->ns) {                                                                             \
            int r_ = nsw_##name args;                                                              \
            if (r_ != NS_PYTHON) return worse((fmi2Status)r_, pre_);                               \
        }                                                                                          \
        if (model_ready(hd_) != 0) return fmi2Error;                                               \
        c = hd_->inner;                                                                              \
        fmi2Status s_ = hd_->t->name args;                                                           \
        if (!strcmp(#name, "fmi2Reset") || !strcmp(#name, "fmi2SetFMUstate")) after_reset(hd_);   \
        return worse(s_, pre_);                                                                    \
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
    fmi2Status pre = fmi2OK;
    if (!hd->ns && before_step(hd, &pre) != 0) return pre;
    if (hd->ns) {
        int r = ns_do_step(hd->ns, t, h, nsp, 1, end);
        if (r != NS_PYTHON) return worse((fmi2Status)r, pre);
    }
    if (model_ready(hd) != 0) return fmi2Error;
    return worse(early_step_of(hd)(hd->inner, t, h, nsp, end), pre);
}
