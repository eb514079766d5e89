/* See fmi2_inproc.h. */
#define _GNU_SOURCE
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <string.h>

#include "fmi2_inproc.h"

#ifdef _WIN32
#include "win_stdio.h"
#define BRIDGE_FILE "fmi2_pybridge.dll"
static HANDLE std_nul[3];   /* the NUL handles python3X.dll's C runtime started on (win_stdio.h), for the bridge */
#else
#define BRIDGE_FILE "fmi2_pybridge.so"
#endif
#define BRIDGE_PREFIX "spurdiff_bridge_"

static Fmi2Table B;
static spurdiffDoStepEarlyTYPE *B_do_step_early;   /* the bridge's FMI 3.0 extension */
static spurdiffNativeExportTYPE *B_native_export;   /* the hand-over of the native step */
static spurdiffNativeImportTYPE *B_native_import;
static spurdiffStartSnapshotTYPE *B_start_snapshot;   /* the start cache */
static spurdiffForkTYPE *B_fork;                     /* the model processes' zygote */
static int B_loaded;
static pthread_mutex_t load_lock = PTHREAD_MUTEX_INITIALIZER;

int inproc_host_python(const RuntimeCfg *cfg, char *version, size_t size)
{
    const char *(*get_version)(void);
    void *sym = plat_process_symbol("Py_GetVersion");
    if (size) version[0] = 0;
    if (!sym) return INPROC_NONE;
    memcpy(&get_version, &sym, sizeof sym);
    const char *v = get_version();   /* callable before initialization: a constant string */
    size_t n = strlen(cfg->version);
    snprintf(version, size, "%.*s", (int)strcspn(v, " "), v);
    return (strncmp(v, cfg->version, n) == 0 && (v[n] == '.' || v[n] == ' ' || v[n] == 0)) ? INPROC_SAME
                                                                                           : INPROC_OTHER;
}

static int load_python(const RuntimeCfg *cfg, const char *resources, char *err, size_t errsize)
{
    char v[64], file[PATH_MAX], why[1024];
    int host = inproc_host_python(cfg, v, sizeof v);
    if (host == INPROC_SAME) return 0;
    if (host == INPROC_OTHER) {
        snprintf(err, errsize, "this process runs Python %s; the FMU's runtime is Python %s", v, cfg->version);
        return -1;
    }
    char root[PATH_MAX];   /* where the runtime's files are: resources/, or the archives unpacked */
    if (cfg_runtime_root(resources, cfg, root, sizeof root, err, errsize) != 0) return -1;
    for (int i = 0; i < cfg->n_preload; i++) {
        if (cfg_join(root, cfg->preload[i], file, sizeof file) != 0 || !plat_open_library(file, 1)) {
            snprintf(err, errsize, "cannot load %s, a library of the FMU's runtime: %s", file,
                     plat_library_error(why, sizeof why));
            return -1;
        }
    }
    PlatLibrary lib;
    if (cfg_join(root, cfg->libpython, file, sizeof file) != 0 || !(lib = plat_open_library(file, 1))) {
        snprintf(err, errsize, "cannot load %s, the FMU's Python %s: %s", file, cfg->version,
                 plat_library_error(why, sizeof why));
        return -1;
    }
    /* the library must be the version the description names (the bridge was compiled for it) */
    if (inproc_host_python(cfg, v, sizeof v) != INPROC_SAME) {
        snprintf(err, errsize, "%s is Python %s, but the FMU's runtime description says %s (the FMU is damaged: "
                 "rebuild it)", file, v[0] ? v : "(unknown)", cfg->version);
        return -1;
    }
    (void)lib;
    return 0;
}

static int load_bridge(const char *bindir, char *err, size_t errsize)
{
    char file[PATH_MAX + 32], why[1024];
    snprintf(file, sizeof file, "%s/%s", bindir, BRIDGE_FILE);
    PlatLibrary h = plat_open_library(file, 0);
    if (!h) {
        snprintf(err, errsize, "cannot load the Python bridge %s: %s", file, plat_library_error(why, sizeof why));
        return -1;
    }
    void *sym;
#define SYMBOL(var, name)                                                                           \
    if (!(sym = plat_symbol(h, BRIDGE_PREFIX name))) {                                              \
        snprintf(err, errsize, "the bridge %s lacks %s", file, BRIDGE_PREFIX name);                \
        return -1;                                                                                 \
    }                                                                                              \
    memcpy(&var, &sym, sizeof sym);
#define LOAD(name) SYMBOL(B.name, #name)
#define X_LOAD(name, params, args) LOAD(name)
    FMI2_FORWARDED(X_LOAD)
    LOAD(fmi2FreeInstance)
    LOAD(fmi2GetString)
    LOAD(fmi2Instantiate)
    /* the bridge's own extensions */
    SYMBOL(B_do_step_early, "spurdiffDoStepEarly")
    SYMBOL(B_native_export, "spurdiffNativeExport")
    SYMBOL(B_native_import, "spurdiffNativeImport")
    SYMBOL(B_start_snapshot, "spurdiffStartSnapshot")
#ifndef _WIN32
    SYMBOL(B_fork, "spurdiffFork")
#endif
#ifdef _WIN32
    void (*held)(const HANDLE *);
    SYMBOL(held, "winStdioHeld")
    held(std_nul);   /* the bridge reconnects them once Python has made its streams */
#endif
#undef X_LOAD
#undef LOAD
#undef SYMBOL
    return 0;
}

int inproc_load(const RuntimeCfg *cfg, const char *resources, const char *bindir, const Fmi2Table **table,
                char *err, size_t errsize)
{
    int rc = 0;
    pthread_mutex_lock(&load_lock);
    if (!B_loaded) {
#ifdef _WIN32
        HANDLE saved[3];
        winstd_hold(saved, std_nul);   /* the C runtime python3X.dll brings starts on NUL for a stream Python refuses */
        rc = load_python(cfg, resources, err, errsize);
        winstd_release(saved, std_nul);
#else
        rc = load_python(cfg, resources, err, errsize);
#endif
        if (rc == 0) rc = load_bridge(bindir, err, errsize);
        if (rc == 0) B_loaded = 1;
    } else {
        /* the bridge is loaded: the Python it runs on must still be the runtime's version */
        char v[64];
        if (inproc_host_python(cfg, v, sizeof v) != INPROC_SAME) {
            snprintf(err, errsize, "this process runs Python %s; the FMU's runtime is Python %s", v, cfg->version);
            rc = -1;
        }
    }
    pthread_mutex_unlock(&load_lock);
    if (rc == 0) *table = &B;
    return rc;
}

fmi2Status inproc_do_step_early(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean nsp, fmi2Real *end)
{
    return B_do_step_early ? B_do_step_early(c, t, h, nsp, end) : fmi2Error;
}

int inproc_native_export(fmi2Component c, unsigned char **bytes, size_t *len)
{
    *bytes = NULL;
    *len = 0;
    return B_native_export ? B_native_export(c, bytes, len) : -1;
}

fmi2Status inproc_native_import(fmi2Component c, const double *arrays, size_t n, double time, int bad, long steps)
{
    return B_native_import ? B_native_import(c, arrays, n, time, bad, steps) : fmi2Error;
}

int inproc_start_snapshot(fmi2Component c, const unsigned char *sets, size_t n, unsigned char **bytes, size_t *len)
{
    *bytes = NULL;
    *len = 0;
    return B_start_snapshot ? B_start_snapshot(c, sets, n, bytes, len) : -1;
}

long inproc_fork(void)
{
    return B_fork ? B_fork() : -1;
}
