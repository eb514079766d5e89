/* The native start: an instance of an FMU whose model steps natively at its defaults, answered here
 * without Python for as long as its host keeps those defaults (spurdiff/fmi/native_start.py says what
 * resources/native_start.bin holds and how it is made).
 *
 * What is answered here, as the model's Python (spurdiff/fmi/adapter.py through fmi2_pybridge.c)
 * answers it: fmi2SetDebugLogging without categories; fmi2SetupExperiment with a finite start and a
 * stop time not before it; entering and leaving Initialization Mode once, in order; every read of a
 * variable before the first step (the values the snapshot recorded for that mode), and after it the
 * native step's slots and the parameters; a set of any settable variable to the value it has before
 * the first step, of the Real inputs after it; fmi2DoStep on the FMU's time by the compiled step;
 * fmi2Terminate. The messages the model logs in these calls go to the host's logger as the bridge
 * sends them (fmi2OK ones only with logging on). Everything else returns NS_PYTHON: a parameter set to
 * another value, an input outside its range at the next step, a step the compiled function does not
 * take (a watch that would log), a step the adapter refuses, FMU states, fmi2Reset, the status
 * functions, a reference the snapshot does not know. Every call answered before the first step or
 * input set while stepping is kept on a tape (one record each), which the loader replays into the
 * model's Python when it starts it; from there the tape holds one record (T_STEPPING) however long the
 * run, and the replay hands the model the native step's state as it is then (its arrays, time and
 * steps: the hand-over's import, ns_live_state), instead of the steps: an instance's memory stays the
 * same over a run of any length, and its Python starts in the same time however many steps it took.
 *
 * The hand-over (ns_open_live) is the same instance made from a stepping model's arrays (its model runs
 * in a process of its own, which wrote them): it answers what a native start answers while stepping,
 * but for fmi2SetDebugLogging and fmi2Terminate, and keeps no tape: the loader gives the arrays back to
 * the model's process (ns_live_state) before any call it does not answer. */
#define _GNU_SOURCE
#include "native_start.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef _WIN32
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#endif

#include "log_text.h"
#include "platform.h"
#include "runtime_cfg.h"

#define NS_MAGIC "SPNS"
#define NS_LIVE_MAGIC "SPNL"      /* a hand-over: native_start.py's live() */
#define NS_FORMAT 3u
#define NS_MAX_FILE (16 * 1024 * 1024)
#define NS_MAX_TAPE ((size_t)64 * 1024 * 1024)   /* calls before stepping: past it, the Python answers */
#define NS_MAX_LIBS 8
#define NS_MAX_FIELDS 32
#define NS_KINDS 4
#define NS_MAX_VR (1u << 20)    /* value references index a table: bounded (native_start.py refuses more) */

enum { K_REAL, K_INTEGER, K_BOOLEAN, K_STRING };
enum { F_SETTABLE = 1, F_INPUT = 2, F_CONSTANT = 4 };
enum { FIELD_NULL, FIELD_DOUBLES, FIELD_FUNCTION };
enum { M_INSTANTIATE, M_SETUP, M_ENTER, M_BUILD, N_PHASES };
enum { P_INSTANTIATED, P_INITIALIZING, P_STEPPING, P_TERMINATED };
enum { T_LOGGING, T_SETUP, T_ENTER, T_EXIT, T_TERMINATE, T_SET_REAL, T_SET_INTEGER, T_SET_BOOLEAN, T_SET_STRING,
       T_BUILD, T_STEPPING };

typedef struct {
    int kind, flags, slot;
    unsigned vr;
    double lo, hi;
    double val[3];            /* instantiated, initializing, stepping (Integer and Boolean as doubles) */
    char *sval[3];            /* String: into the file's buffer */
} Var;

typedef struct {
    int phase, status;
    char *category, *text;    /* into the file's buffer */
} Msg;

typedef int64_t NativeFn(const void *ctx, double *v, double t, double h);

/* A Real value-reference vector read or written while stepping, with where each value is: a master
 * calls with the same few vectors every step (the bridge keeps the same, fmi2_pybridge.h: VrCache) */
#define NS_VECTORS 4
typedef struct {
    fmi2ValueReference *vr;
    size_t n;
    const double **at;        /* each value's place (a slot of v or the parameter's value) */
    const Var **var;          /* each value's variable */
} Vector;

struct NsInst {
    char *file;               /* the file's bytes (strings point into it, NUL-terminated in place) */
    fmi2CallbackFunctions cb;
    char *name;
    int logging_on;
    int early;                /* the model may end a step early: such a step needs its Python */
    PlatLibrary libs[NS_MAX_LIBS];
    int n_libs;
    NativeFn *fn;
    void *ctx[NS_MAX_FIELDS];  /* a structure of pointers, as the step function takes it */
    const void *step_ctx;      /* ctx, or the one array of doubles the function takes itself */
    double *arrays[NS_MAX_FIELDS];
    size_t array_n[NS_MAX_FIELDS];
    int n_fields;
    int direct;               /* the step function takes the first array itself as its context */
    uint64_t digest;          /* the file's (its last 8 bytes) */
    int live;                 /* a hand-over: no tape, fmi2Terminate and every refusal go to the model */
    long pid;                 /* the process it was handed to (a fork's step goes to the model's process) */
    double *v;
    size_t nv, n_in;
    Var *vars;
    size_t n_vars;
    int *index[NS_KINDS];     /* value reference -> variable, -1 none */
    unsigned max_vr[NS_KINDS];
    Msg *msgs;
    size_t n_msgs;
    /* the start cache (see "the start cache" below): sets to other values before the model is built */
    char *cache_dir, *guid, *resources;
    int built;                /* the model was built (a read in Initialization Mode, or its end) */
    unsigned char *has;       /* per variable: set to another value than the file's */
    double *over;             /* that value (Real, Integer, Boolean as a double) */
    char **sover;             /* a String's (a copy) */
    size_t n_over;
    /* the instance */
    int phase, dirty, bad;
    long steps;
    double time, stop, stop_tol;
    unsigned char *tape;
    size_t tape_len, tape_cap, max_tape, last_mark;
    int stepped;              /* T_STEPPING is on the tape: steps and input sets are not recorded */
    Vector vectors[2][NS_VECTORS];   /* reads, writes */
    int next_vector[2];
};

static void emit_phase(NsInst *I, int phase);
static void drop_overrides(NsInst *I);
static int cache_build(NsInst *I);

/* ------------------------------------------------------------------------------ the file */
typedef struct {
    char *p, *end;
    int ok;
} Rd;

static void *rd_take(Rd *r, size_t n)
{
    if (!r->ok || (size_t)(r->end - r->p) < n) {
        r->ok = 0;
        return NULL;
    }
    void *q = r->p;
    r->p += n;
    return q;
}

static uint32_t rd_u32(Rd *r)
{
    uint32_t x = 0;
    void *q = rd_take(r, 4);
    if (q) memcpy(&x, q, 4);
    return x;
}

static int64_t rd_i64(Rd *r)
{
    int64_t x = 0;
    void *q = rd_take(r, 8);
    if (q) memcpy(&x, q, 8);
    return x;
}

static double rd_f64(Rd *r)
{
    double x = 0.0;
    void *q = rd_take(r, 8);
    if (q) memcpy(&x, q, 8);
    return x;
}

/* A string: its length then its bytes, made NUL-terminated in place (the next field's bytes were
 * read already: the length field before the next string is read before its first byte is changed) */
static char *rd_str(Rd *r)
{
    uint32_t n = rd_u32(r);
    char *s = (char *)rd_take(r, n);
    if (!s) return NULL;
    /* the bytes one back onto the length field's last byte, which is read: room for a NUL after them */
    char *d = s - 1;
    memmove(d, s, n);
    d[n] = 0;
    return d;
}

/* FNV-1a, 64 bits: the file's last 8 bytes are that of the bytes before them (native_start.py: digest) */
static uint64_t fnv1a(const unsigned char *p, size_t n)
{
    uint64_t h = 0xCBF29CE484222325ull;
    for (size_t i = 0; i < n; i++) h = (h ^ p[i]) * 0x100000001B3ull;
    return h;
}

static int parse(NsInst *I, const char *resources, size_t len, char *err, size_t errsize)
{
    Rd r = {I->file, I->file + len, 1};
    char *magic = (char *)rd_take(&r, 4);
    if (!magic || memcmp(magic, I->live ? NS_LIVE_MAGIC : NS_MAGIC, 4) != 0 || rd_u32(&r) != NS_FORMAT) {
        snprintf(err, errsize, "%s is not a native %s of format %u", I->live ? "the hand-over" : NS_FILE,
                 I->live ? "hand-over" : "start", NS_FORMAT);
        return -1;
    }
    uint64_t want = 0;   /* (a hand-over has none: it comes from the model's process through shared memory) */
    if (len < 16 || (memcpy(&want, I->file + len - 8, 8), !I->live && fnv1a((const unsigned char *)I->file, len - 8) != want)) {
        snprintf(err, errsize, "%s is damaged (its digest does not match its bytes)", NS_FILE);
        return -1;
    }
    r.end -= 8;
    I->digest = want;
    if (I->live) {   /* the FMU's time, its stop time and that one's tolerance */
        I->time = rd_f64(&r);
        I->stop = rd_f64(&r);
        I->stop_tol = rd_f64(&r);
    }
    I->early = rd_u32(&r) != 0;
    uint32_t n_libs = rd_u32(&r);
    if (n_libs > NS_MAX_LIBS) r.ok = 0;
    for (uint32_t i = 0; r.ok && i < n_libs; i++) {
        char *rel = rd_str(&r), path[PATH_MAX];
        if (!rel || !cfg_relative_ok(rel)) { r.ok = 0; break; }
#ifdef _WIN32
        int w = snprintf(path, sizeof path, "%s/%s.dll", resources, rel);
#else
        int w = snprintf(path, sizeof path, "%s/%s.so", resources, rel);
#endif
        if (w < 0 || (size_t)w >= sizeof path) { r.ok = 0; break; }
        I->libs[i] = plat_open_library(path, 0);
        if (!I->libs[i]) {
            char why[512];
            snprintf(err, errsize, "cannot load %s: %s", path, plat_library_error(why, sizeof why));
            return -1;
        }
        I->n_libs = (int)i + 1;
    }
    uint32_t n_checks = rd_u32(&r);
    for (uint32_t i = 0; r.ok && i < n_checks; i++) {
        uint32_t lib = rd_u32(&r);
        char *sym = rd_str(&r);
        int64_t want = rd_i64(&r);
        if (!r.ok || lib >= n_libs) { r.ok = 0; break; }
        int64_t (*f)(void) = (int64_t (*)(void))(uintptr_t)plat_symbol(I->libs[lib], sym);
        int64_t got = f ? f() : 0;
        if (!f || got != want) {
            snprintf(err, errsize, "the kernel %s: %s is %lld, not %lld (the FMU's files do not belong together)",
                     sym, f ? "its value" : "missing", (long long)got, (long long)want);
            return -1;
        }
    }
    uint32_t fn_lib = rd_u32(&r);
    char *fn_name = rd_str(&r);
    if (r.ok && fn_lib < n_libs) I->fn = (NativeFn *)(uintptr_t)plat_symbol(I->libs[fn_lib], fn_name);
    uint32_t direct = rd_u32(&r);   /* 1: the context is the first field's array itself */
    uint32_t n_fields = rd_u32(&r);
    if (n_fields > NS_MAX_FIELDS || (direct && n_fields != 1)) r.ok = 0;
    for (uint32_t i = 0; r.ok && i < n_fields; i++) {
        uint32_t kind = rd_u32(&r);
        if (kind == FIELD_DOUBLES) {
            uint32_t n = rd_u32(&r);
            double *src = (double *)rd_take(&r, (size_t)n * 8);
            if (!src || !(I->arrays[i] = (double *)malloc(((size_t)n + 1) * sizeof(double)))) { r.ok = 0; break; }
            memcpy(I->arrays[i], src, (size_t)n * 8);
            I->array_n[i] = n;
            I->ctx[i] = I->arrays[i];
        } else if (kind == FIELD_FUNCTION) {
            uint32_t lib = rd_u32(&r);
            char *sym = rd_str(&r);
            if (!r.ok || lib >= n_libs || !(I->ctx[i] = (void *)(uintptr_t)plat_symbol(I->libs[lib], sym))) r.ok = 0;
        } else if (kind != FIELD_NULL) {
            r.ok = 0;
        }
        I->n_fields = (int)i + 1;
    }
    I->direct = direct != 0;
    I->step_ctx = direct ? (const void *)I->arrays[0] : (const void *)I->ctx;
    if (direct && !I->arrays[0]) r.ok = 0;
    I->nv = rd_u32(&r);
    double *v0 = (double *)rd_take(&r, I->nv * 8);
    I->v = v0 ? (double *)malloc((I->nv + 1) * sizeof(double)) : NULL;
    if (v0 && I->v) memcpy(I->v, v0, I->nv * 8);
    I->n_in = rd_u32(&r);
    I->n_vars = rd_u32(&r);
    /* a count is allocated for only when the bytes left can hold it (a variable takes 40 bytes or more,
     * a message 16): a huge count is a bad layout, never a huge allocation */
    if (I->n_vars > (size_t)(r.end - r.p) / 40) r.ok = 0;
    I->vars = r.ok && I->v && I->n_in <= I->nv ? (Var *)calloc(I->n_vars + 1, sizeof(Var)) : NULL;
    if (!I->vars) r.ok = 0;
    for (size_t i = 0; r.ok && i < I->n_vars; i++) {
        Var *x = &I->vars[i];
        x->kind = (int)rd_u32(&r);
        x->vr = rd_u32(&r);
        x->flags = (int)rd_u32(&r);
        x->slot = (int)(int32_t)rd_u32(&r);
        x->lo = rd_f64(&r);
        x->hi = rd_f64(&r);
        for (int p = 0; p < 3; p++) {
            if (x->kind == K_STRING) x->sval[p] = rd_str(&r);
            else x->val[p] = rd_f64(&r);
        }
        if (x->kind < 0 || x->kind >= NS_KINDS || x->slot >= (int)I->nv || x->vr >= NS_MAX_VR
            || (x->kind == K_REAL && (x->flags & F_INPUT) && (x->slot < 0 || (size_t)x->slot >= I->n_in)))
            r.ok = 0;
        else if (x->vr > I->max_vr[x->kind])
            I->max_vr[x->kind] = x->vr;
    }
    for (int k = 0; r.ok && k < NS_KINDS; k++) {
        I->index[k] = (int *)malloc(((size_t)I->max_vr[k] + 1) * sizeof(int));
        if (!I->index[k]) { r.ok = 0; break; }
        for (size_t j = 0; j <= I->max_vr[k]; j++) I->index[k][j] = -1;
    }
    for (size_t i = 0; r.ok && i < I->n_vars; i++) I->index[I->vars[i].kind][I->vars[i].vr] = (int)i;
    I->n_msgs = rd_u32(&r);
    if (I->n_msgs > (size_t)(r.end - r.p) / 16) r.ok = 0;
    I->msgs = r.ok ? (Msg *)calloc(I->n_msgs + 1, sizeof(Msg)) : NULL;
    if (!I->msgs) r.ok = 0;
    for (size_t i = 0; r.ok && i < I->n_msgs; i++) {
        uint32_t phase = rd_u32(&r), status = rd_u32(&r);   /* checked unsigned: no negative one slips through */
        I->msgs[i].phase = (int)phase;
        I->msgs[i].status = (int)status;
        I->msgs[i].category = rd_str(&r);
        I->msgs[i].text = rd_str(&r);
        if (phase >= N_PHASES || status > fmi2Error) r.ok = 0;
    }
    if (!r.ok || r.p != r.end || !I->fn) {
        snprintf(err, errsize, "%s is damaged (%s)", NS_FILE, !I->fn && r.ok ? "its step function is missing" : "bad layout");
        return -1;
    }
    return 0;
}

int ns_open(const char *resources, const char *name, const fmi2CallbackFunctions *cb, int logging_on,
            NsInst **out, char *err, size_t errsize)
{
    char file[PATH_MAX];
    *out = NULL;
    if (cfg_join(resources, NS_FILE, file, sizeof file) != 0) return 0;
    /* plat_open_read refuses nothing: a missing file is "no native start", anything else is read strictly */
    int fd = plat_open_read(file);
    if (fd < 0) return 0;
    close(fd);
    size_t len = 0;
    char *text = cfg_slurp(file, NS_MAX_FILE, &len, err, errsize);
    if (!text) return -1;
    NsInst *I = (NsInst *)calloc(1, sizeof *I);
    if (!I || !(I->name = cfg_strdup(name))) {
        free(I);
        free(text);
        snprintf(err, errsize, "out of memory");
        return -1;
    }
    I->file = text;
    if (cb) I->cb = *cb;
    I->logging_on = logging_on;
    if (parse(I, resources, len, err, errsize) != 0) {
        ns_free(I);
        return -1;
    }
    I->phase = P_INSTANTIATED;
    I->dirty = 1;
    I->stop = INFINITY;
    /* the tape's limit: NS_MAX_TAPE, or SPURDIFF_FMU_START_TAPE bytes (smaller, for the tests of what
     * happens past it) */
    I->max_tape = NS_MAX_TAPE;
    const char *limit = getenv("SPURDIFF_FMU_START_TAPE");
    if (limit && *limit) {
        char *end = NULL;
        unsigned long long x = strtoull(limit, &end, 10);
        if (end && !*end && x < NS_MAX_TAPE) I->max_tape = (size_t)x;
    }
    emit_phase(I, M_INSTANTIATE);
    *out = I;
    return 1;
}

void ns_free(NsInst *I)
{
    if (!I) return;
    for (int i = 0; i < NS_MAX_FIELDS; i++) free(I->arrays[i]);
    for (int k = 0; k < NS_KINDS; k++) free(I->index[k]);
    /* the kernels stay loaded: the model's Python loads the same files (a dlclose gains nothing) */
    for (int w = 0; w < 2; w++)
        for (int k = 0; k < NS_VECTORS; k++) {
            free(I->vectors[w][k].vr);
            free(I->vectors[w][k].at);
            free(I->vectors[w][k].var);
        }
    free(I->vars);
    free(I->msgs);
    free(I->v);
    free(I->tape);
    free(I->file);
    free(I->name);
    drop_overrides(I);
    free(I->has);
    free(I->over);
    free(I->sover);
    free(I->cache_dir);
    free(I->guid);
    free(I->resources);
    free(I);
}

long ns_steps(const NsInst *I) { return I->steps; }

int ns_open_live(const void *bytes, size_t len, const char *resources, const char *name,
                 const fmi2CallbackFunctions *cb, NsInst **out, char *err, size_t errsize)
{
    *out = NULL;
    NsInst *I = (NsInst *)calloc(1, sizeof *I);
    if (!I || len > NS_MAX_FILE || !(I->file = (char *)malloc(len + 1)) || !(I->name = cfg_strdup(name))) {
        if (I) ns_free(I);
        snprintf(err, errsize, len > NS_MAX_FILE ? "the hand-over is larger than %d bytes" : "out of memory",
                 NS_MAX_FILE);
        return -1;
    }
    memcpy(I->file, bytes, len);
    if (cb) I->cb = *cb;
    I->live = 1;
    if (parse(I, resources, len, err, errsize) != 0) {
        ns_free(I);
        return -1;
    }
    I->phase = P_STEPPING;
#ifndef _WIN32
    I->pid = (long)getpid();
#endif
    *out = I;
    return 1;
}

int ns_is_live(const NsInst *I) { return I->live; }

int ns_live_state(const NsInst *I, double **arrays, size_t *n, double *time, int *bad, long *steps)
{
    size_t total = I->nv;
    for (int i = 0; i < I->n_fields; i++) total += I->arrays[i] ? I->array_n[i] : 0;
    double *out = (double *)malloc((total ? total : 1) * sizeof *out);
    if (!out) return -1;
    memcpy(out, I->v, I->nv * sizeof *out);
    size_t at = I->nv;
    for (int i = 0; i < I->n_fields; i++)
        if (I->arrays[i]) {
            memcpy(out + at, I->arrays[i], I->array_n[i] * sizeof *out);
            at += I->array_n[i];
        }
    *arrays = out;
    *n = total;
    *time = I->time;
    *bad = I->bad;
    *steps = I->steps;
    return 0;
}

/* ------------------------------------------------------------------------------ messages */
static void emit_phase(NsInst *I, int phase)
{
    for (size_t i = 0; i < I->n_msgs; i++) {
        const Msg *m = &I->msgs[i];
        if (m->phase != phase || !(m->status != fmi2OK || I->logging_on)) continue;
        log_text(&I->cb, I->name, (fmi2Status)m->status, m->category, m->text);
    }
}

/* ------------------------------------------------------------------------------ the tape */
static int tape_put(NsInst *I, const void *p, size_t n)
{
    if (I->tape_len + n > I->tape_cap) {
        size_t cap = I->tape_cap ? 2 * I->tape_cap : 4096;
        while (cap < I->tape_len + n) cap *= 2;
        unsigned char *t = (unsigned char *)realloc(I->tape, cap);
        if (!t) return -1;
        I->tape = t;
        I->tape_cap = cap;
    }
    memcpy(I->tape + I->tape_len, p, n);
    I->tape_len += n;
    return 0;
}

typedef struct {
    int32_t op, status;
    uint64_t n;               /* values, or the payload's bytes */
} Rec;

static int record(NsInst *I, int op, uint64_t n, const void *a, size_t na, const void *b, size_t nb)
{
    if (I->live) return 0;   /* a hand-over keeps no tape: its model's process has the calls before it */
    Rec h = {op, fmi2OK, n};
    size_t mark = I->last_mark = I->tape_len;
    if (mark > I->max_tape) return -1;   /* any call past the limit (sets without steps too) goes to the Python */
    if (tape_put(I, &h, sizeof h) != 0 || (na && tape_put(I, a, na) != 0) || (nb && tape_put(I, b, nb) != 0)) {
        I->tape_len = mark;
        return -1;
    }
    return 0;
}

/* A step or an input set while stepping: T_STEPPING on the tape once (the replay hands the model the
 * state as it is then, ns_replay), nothing after it. 0, or -1 (no memory: the Python answers). */
static int stepping(NsInst *I)
{
    if (I->stepped || I->live) return 0;
    if (record(I, T_STEPPING, 0, NULL, 0, NULL, 0) != 0) return -1;
    I->stepped = 1;
    return 0;
}

/* The last record off the tape (its call is not answered here after all): NS_PYTHON. */
static int unrecord(NsInst *I)
{
    I->tape_len = I->last_mark;
    return NS_PYTHON;
}

/* ------------------------------------------------------------------------------ the calls */
static const Var *var_of(const NsInst *I, int kind, fmi2ValueReference vr)
{
    if (vr > I->max_vr[kind] || !I->index[kind]) return NULL;
    int i = I->index[kind][vr];
    return i < 0 ? NULL : &I->vars[i];
}

int ns_set_debug_logging(NsInst *I, fmi2Boolean on, size_t n)
{
    int32_t x = on ? 1 : 0;
    if (I->live || n != 0 || record(I, T_LOGGING, 0, &x, sizeof x, NULL, 0) != 0) return NS_PYTHON;
    I->logging_on = x;
    return fmi2OK;
}

int ns_setup_experiment(NsInst *I, fmi2Boolean td, fmi2Real tol, fmi2Real t0, fmi2Boolean sd, fmi2Real t1)
{
    if (I->phase != P_INSTANTIATED || !isfinite(t0) || (sd && !(isfinite(t1) && t1 >= t0))) return NS_PYTHON;
    double d[3] = {tol, t0, t1};
    int32_t b[2] = {td ? 1 : 0, sd ? 1 : 0};
    if (record(I, T_SETUP, 0, d, sizeof d, b, sizeof b) != 0) return NS_PYTHON;
    I->time = t0;
    I->stop = sd ? t1 : INFINITY;
    /* the adapter's _time_tolerance(stop, 0.0): 1e-9 * max(1, |stop|) */
    I->stop_tol = sd ? 1e-9 * (fabs(t1) > 1.0 ? fabs(t1) : 1.0) : 0.0;
    emit_phase(I, M_SETUP);
    return fmi2OK;
}

int ns_enter_initialization_mode(NsInst *I)
{
    if (I->phase != P_INSTANTIATED || record(I, T_ENTER, 0, NULL, 0, NULL, 0) != 0) return NS_PYTHON;
    I->phase = P_INITIALIZING;
    emit_phase(I, M_ENTER);
    return fmi2OK;
}

int ns_exit_initialization_mode(NsInst *I)
{
    if (I->phase != P_INITIALIZING || (I->dirty && cache_build(I) != 0) || record(I, T_EXIT, 0, NULL, 0, NULL, 0) != 0)
        return NS_PYTHON;
    if (I->dirty) emit_phase(I, M_BUILD);   /* the model is built now unless a read built it */
    I->dirty = 0;
    I->built = 1;
    I->phase = P_STEPPING;
    return fmi2OK;
}

int ns_terminate(NsInst *I)
{
    if (I->live || I->phase != P_STEPPING || record(I, T_TERMINATE, 0, NULL, 0, NULL, 0) != 0) return NS_PYTHON;
    I->phase = P_TERMINATED;
    return fmi2OK;
}

/* A read of `n` variables of `kind`: -1 (the model's Python answers), or the value's source for each
 * in the order asked (0: the snapshot's values of the mode, 1: the slot) checked for all first. */
static int readable(NsInst *I, int kind, const fmi2ValueReference vr[], size_t n)
{
    for (size_t i = 0; i < n; i++) {
        const Var *x = var_of(I, kind, vr[i]);
        if (!x) return -1;
        if (I->phase >= P_STEPPING && !(x->flags & F_CONSTANT) && x->slot < 0) return -1;
    }
    if (I->phase == P_INITIALIZING && I->dirty) {   /* the read builds the model (the adapter's _read) */
        /* on the tape too: a later set the Python refuses leaves the model built by this read in place */
        int32_t what[3] = {kind, n ? (int32_t)vr[0] : 0, n ? 1 : 0};   /* a read of none builds it too */
        if (cache_build(I) != 0 || record(I, T_BUILD, 0, what, sizeof what, NULL, 0) != 0) return -1;
        emit_phase(I, M_BUILD);
        I->dirty = 0;
        I->built = 1;
    }
    return 0;
}

static double value_of(const NsInst *I, const Var *x)
{
    if (I->phase >= P_STEPPING)
        return x->slot >= 0 && !(x->flags & F_CONSTANT) ? I->v[x->slot] : x->val[2];
    if (I->phase == P_INITIALIZING && I->built) return x->val[1];
    size_t i = (size_t)(x - I->vars);   /* before the build: the values set, the file's else */
    return I->n_over && I->has[i] ? I->over[i] : x->val[0];
}

static const char *string_of(const NsInst *I, const Var *x)
{
    if (I->phase >= P_STEPPING) return x->sval[2];
    if (I->phase == P_INITIALIZING && I->built) return x->sval[1];
    size_t i = (size_t)(x - I->vars);
    return I->n_over && I->has[i] ? I->sover[i] : x->sval[0];
}

/* The vector `vr` (reads: every value readable while stepping; writes: every value an input) with its
 * places, made once per vector; NULL: not such a vector (the slow path decides). */
static const Vector *vector(NsInst *I, int write, const fmi2ValueReference vr[], size_t n)
{
    Vector *c = I->vectors[write];
    for (int k = 0; k < NS_VECTORS; k++)
        if (c[k].vr && c[k].n == n && memcmp(c[k].vr, vr, n * sizeof *vr) == 0) return &c[k];
    if (n == 0 || n > 4096) return NULL;
    for (size_t i = 0; i < n; i++) {
        const Var *x = var_of(I, K_REAL, vr[i]);
        if (!x || (write ? !(x->flags & F_INPUT) : (!(x->flags & F_CONSTANT) && x->slot < 0))) return NULL;
    }
    Vector *e = &c[I->next_vector[write]];
    I->next_vector[write] = (I->next_vector[write] + 1) % NS_VECTORS;
    free(e->vr);
    free(e->at);
    free(e->var);
    e->vr = (fmi2ValueReference *)malloc(n * sizeof *vr);
    e->at = (const double **)malloc(n * sizeof *e->at);
    e->var = (const Var **)malloc(n * sizeof *e->var);
    if (!e->vr || !e->at || !e->var) {
        free(e->vr);
        free(e->at);
        free(e->var);
        e->vr = NULL;
        e->at = NULL;
        e->var = NULL;
        return NULL;
    }
    memcpy(e->vr, vr, n * sizeof *vr);
    for (size_t i = 0; i < n; i++) {
        const Var *x = e->var[i] = var_of(I, K_REAL, vr[i]);
        e->at[i] = x->slot >= 0 && !(x->flags & F_CONSTANT) ? &I->v[x->slot] : &x->val[2];
    }
    e->n = n;
    return e;
}

int ns_get_real(NsInst *I, const fmi2ValueReference vr[], size_t n, fmi2Real v[])
{
    const Vector *e = I->phase >= P_STEPPING ? vector(I, 0, vr, n) : NULL;
    if (e) {
        for (size_t i = 0; i < n; i++) v[i] = *e->at[i];
        return fmi2OK;
    }
    if (readable(I, K_REAL, vr, n) != 0) return NS_PYTHON;
    for (size_t i = 0; i < n; i++) v[i] = value_of(I, var_of(I, K_REAL, vr[i]));
    return fmi2OK;
}

int ns_get_integer(NsInst *I, const fmi2ValueReference vr[], size_t n, fmi2Integer v[])
{
    if (readable(I, K_INTEGER, vr, n) != 0) return NS_PYTHON;
    for (size_t i = 0; i < n; i++) v[i] = (fmi2Integer)value_of(I, var_of(I, K_INTEGER, vr[i]));
    return fmi2OK;
}

int ns_get_boolean(NsInst *I, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[])
{
    if (readable(I, K_BOOLEAN, vr, n) != 0) return NS_PYTHON;
    for (size_t i = 0; i < n; i++) v[i] = value_of(I, var_of(I, K_BOOLEAN, vr[i])) != 0.0 ? fmi2True : fmi2False;
    return fmi2OK;
}

int ns_get_string(NsInst *I, const fmi2ValueReference vr[], size_t n, fmi2String v[])
{
    if (readable(I, K_STRING, vr, n) != 0) return NS_PYTHON;
    for (size_t i = 0; i < n; i++) v[i] = string_of(I, var_of(I, K_STRING, vr[i]));
    return fmi2OK;
}

/* A set before the first step: every variable settable and set to the value it has (the start
 * value): then the model's build is as recorded. With the start cache on and before the model's build,
 * a settable variable may be set to another value too (kept in I->over: the build then looks for the
 * snapshot of exactly those values, cache_build). All or none: 1 taken, 0 not (nothing changed). */
static int same_value(int kind, const Var *x, const double *d, const fmi2String *s, size_t i)
{
    if (kind == K_STRING) return s[i] && strcmp(s[i], x->sval[0]) == 0;
    if (kind == K_BOOLEAN) return (d[i] != 0.0) == (x->val[0] != 0.0);
    return memcmp(&d[i], &x->val[0], sizeof(double)) == 0;   /* a Real bit for bit (-0.0 is not 0.0 here) */
}

static int take_sets(NsInst *I, int kind, const fmi2ValueReference vr[], size_t n, const double *d,
                     const fmi2String *s)
{
    if (I->phase != P_INSTANTIATED && I->phase != P_INITIALIZING) return 0;
    int defer = I->cache_dir && !I->built && !I->live;
    for (size_t i = 0; i < n; i++) {
        const Var *x = var_of(I, kind, vr[i]);
        if (!x || !(x->flags & F_SETTABLE)) return 0;
        if (!same_value(kind, x, d, s, i) && (!defer || (kind == K_STRING && !s[i]))) return 0;
    }
    if (!defer) return 1;
    if (!I->has) {
        I->has = (unsigned char *)calloc(I->n_vars + 1, 1);
        I->over = (double *)calloc(I->n_vars + 1, sizeof *I->over);
        I->sover = (char **)calloc(I->n_vars + 1, sizeof *I->sover);
        if (!I->has || !I->over || !I->sover) return 0;
    }
    char **copies = kind == K_STRING ? (char **)calloc(n + 1, sizeof *copies) : NULL;
    if (kind == K_STRING && !copies) return 0;
    for (size_t i = 0; kind == K_STRING && i < n; i++)
        if (!(copies[i] = cfg_strdup(s[i]))) {
            for (size_t j = 0; j < i; j++) free(copies[j]);
            free(copies);
            return 0;
        }
    for (size_t i = 0; i < n; i++) {   /* in order: a reference set twice in one call keeps the last value */
        size_t k = (size_t)(var_of(I, kind, vr[i]) - I->vars);
        int differs = !same_value(kind, &I->vars[k], d, s, i);
        if (I->has[k]) I->n_over--;
        free(I->sover[k]);
        I->sover[k] = NULL;
        I->has[k] = (unsigned char)differs;
        if (differs) {
            I->n_over++;
            if (kind == K_STRING) I->sover[k] = copies[i], copies[i] = NULL;
            else I->over[k] = kind == K_BOOLEAN ? (d[i] != 0.0 ? 1.0 : 0.0) : d[i];
        }
    }
    for (size_t i = 0; kind == K_STRING && i < n; i++) free(copies[i]);
    free(copies);
    return 1;
}

static void drop_overrides(NsInst *I)
{
    for (size_t i = 0; I->sover && i < I->n_vars; i++) {
        free(I->sover[i]);
        I->sover[i] = NULL;
    }
    if (I->has) memset(I->has, 0, I->n_vars);
    I->n_over = 0;
}

int ns_set_real(NsInst *I, const fmi2ValueReference vr[], size_t n, const fmi2Real v[])
{
    if (I->phase == P_STEPPING) {   /* the inputs into their slots, each checked against its range */
        if (n == 0) return fmi2OK;
        const Vector *e = vector(I, 1, vr, n);
        if (!e || stepping(I) != 0) return NS_PYTHON;
        for (size_t i = 0; i < n; i++) {
            const Var *x = e->var[i];
            I->v[x->slot] = v[i];
            if (!(x->lo <= v[i] && v[i] <= x->hi)) I->bad = 1;   /* NaN too: the next step needs the Python */
        }
        return fmi2OK;
    }
    if (record(I, T_SET_REAL, n, vr, n * sizeof *vr, v, n * sizeof *v) != 0) return NS_PYTHON;
    if (!take_sets(I, K_REAL, vr, n, v, NULL)) return unrecord(I);
    I->dirty = 1;
    return fmi2OK;
}

static int set_ints(NsInst *I, int kind, int op, const fmi2ValueReference vr[], size_t n, const int *v)
{
    double d[64];
    if (n > 64) return NS_PYTHON;
    for (size_t i = 0; i < n; i++) d[i] = (double)v[i];
    if (record(I, op, n, vr, n * sizeof *vr, v, n * sizeof *v) != 0) return NS_PYTHON;
    if (!take_sets(I, kind, vr, n, d, NULL)) return unrecord(I);
    I->dirty = 1;
    return fmi2OK;
}

int ns_set_integer(NsInst *I, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[])
{
    return set_ints(I, K_INTEGER, T_SET_INTEGER, vr, n, v);
}

int ns_set_boolean(NsInst *I, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[])
{
    return set_ints(I, K_BOOLEAN, T_SET_BOOLEAN, vr, n, v);
}

int ns_set_string(NsInst *I, const fmi2ValueReference vr[], size_t n, const fmi2String v[])
{
    /* the tape keeps the references, then each string (u32 length, its bytes) */
    size_t bytes = 0;
    for (size_t i = 0; i < n; i++) bytes += 4 + (v[i] ? strlen(v[i]) : 0);
    unsigned char *pack = (unsigned char *)malloc(bytes ? bytes : 1), *q = pack;
    if (!pack) return NS_PYTHON;
    for (size_t i = 0; i < n; i++) {
        uint32_t len = v[i] ? (uint32_t)strlen(v[i]) : 0;
        memcpy(q, &len, 4);
        if (len) memcpy(q + 4, v[i], len);
        q += 4 + len;
    }
    int rc = record(I, T_SET_STRING, n, vr, n * sizeof *vr, pack, bytes);
    free(pack);
    if (rc != 0) return NS_PYTHON;
    if (!take_sets(I, K_STRING, vr, n, NULL, v)) return unrecord(I);
    I->dirty = 1;
    return fmi2OK;
}

int ns_do_step(NsInst *I, fmi2Real t, fmi2Real h, fmi2Boolean nsp, int early, fmi2Real *end)
{
    /* the adapter's checks (fmi2_do_step) and the bridge's native_step: anything it would refuse or
     * take in Python is left to the Python */
    if (I->phase != P_STEPPING || I->bad || (early && I->early) || !(h > 0.0 && h < INFINITY)) return NS_PYTHON;
#ifndef _WIN32
    if (I->live && (long)getpid() != I->pid) return NS_PYTHON;   /* a forked host: the model's process refuses it */
#endif
    double at = t >= 0.0 ? t : -t;
    if (!(fabs(t - I->time) <= 1e-9 * (at > 1.0 ? at : 1.0) + 1e-6 * h) || at == INFINITY) return NS_PYTHON;
    if (t + h > I->stop + (I->stop_tol + 1e-6 * h)) return NS_PYTHON;
    (void)nsp;
    if (stepping(I) != 0) return NS_PYTHON;
    if (I->fn(I->step_ctx, I->v, t, h) != 0) return NS_PYTHON;   /* not taken: nothing but scratch changed */
    I->time = t + h;
    I->steps++;
    if (end) *end = t + h;
    return fmi2OK;
}

/* ------------------------------------------------------------------------------ the start cache
 * A host that sets parameters to other values than the FMU's defaults starts the model's Python at the
 * model's build (the first read in Initialization Mode, or its end), and when the instance ends, the
 * loader keeps the native start of exactly those values (the model's own snapshot of them, made as the
 * build makes native_start.bin) in the user's cache: <cache>/spurdiff/starts/<key>.bin, the key a digest
 * of the FMU's GUID, its native_start.bin and the values set. The next instance that sets the same values
 * builds from that file instead: no Python, no model process. A file is used only from a folder of this
 * user's (mode 0700, not a link), when it is a regular file of this user's that nobody else may write, its
 * digest matches its bytes, its kernels pass their checks, and its variables and its values before the
 * build are exactly the file's and the values set; anything else is a miss (the Python builds, as without
 * the cache). */
int ns_start_cache(NsInst *I, const char *dir, const char *guid, const char *resources)
{
    if (!dir) return 0;
    I->cache_dir = cfg_strdup(dir);
    I->guid = cfg_strdup(guid ? guid : "");
    I->resources = cfg_strdup(resources);
    if (I->cache_dir && I->guid && I->resources) return 0;
    free(I->cache_dir);
    free(I->guid);
    free(I->resources);
    I->cache_dir = I->guid = I->resources = NULL;
    return -1;
}

static uint64_t fnv_more(uint64_t h, const void *p, size_t n)
{
    const unsigned char *b = (const unsigned char *)p;
    for (size_t i = 0; i < n; i++) h = (h ^ b[i]) * 0x100000001B3ull;
    return h;
}

/* The values set (kind, value reference, then the double or u32 length and the bytes), in the file's order
 * of the variables: a new array (*len bytes), NULL when none or no memory. */
static unsigned char *pack_overrides(const NsInst *I, size_t *len)
{
    size_t n = 0;
    for (size_t i = 0; i < I->n_vars && I->n_over; i++)
        if (I->has[i]) n += 8 + (I->vars[i].kind == K_STRING ? 4 + strlen(I->sover[i]) : 8);
    *len = n;
    unsigned char *out = n ? (unsigned char *)malloc(n) : NULL, *q = out;
    for (size_t i = 0; out && i < I->n_vars; i++) {
        if (!I->has[i]) continue;
        uint32_t head[2] = {(uint32_t)I->vars[i].kind, I->vars[i].vr};
        memcpy(q, head, 8);
        q += 8;
        if (I->vars[i].kind == K_STRING) {
            uint32_t l = (uint32_t)strlen(I->sover[i]);
            memcpy(q, &l, 4);
            memcpy(q + 4, I->sover[i], l);
            q += 4 + l;
        } else {
            memcpy(q, &I->over[i], 8);
            q += 8;
        }
    }
    return out;
}

/* The cache file of the values set: 0 and `path` (with the values packed in *sets, a new array of *len
 * bytes, when sets is not NULL), or -1 (no cache, no values set, too long). */
static int cache_path(const NsInst *I, char *path, size_t size, unsigned char **sets, size_t *len)
{
    size_t n = 0;
    unsigned char *packed = I->cache_dir && I->n_over ? pack_overrides(I, &n) : NULL;
    if (!packed) return -1;
    uint64_t h = fnv_more(0xCBF29CE484222325ull, I->guid, strlen(I->guid) + 1);
    h = fnv_more(h, &I->digest, sizeof I->digest);
    h = fnv_more(h, packed, n);
    int w = snprintf(path, size, "%s/%016llx.bin", I->cache_dir, (unsigned long long)h);
    if (w < 0 || (size_t)w >= size || !sets) {
        free(packed);
        return w < 0 || (size_t)w >= size ? -1 : 0;
    }
    *sets = packed;
    *len = n;
    return 0;
}

static int seen_before(const char *path);

int ns_cache_want(const NsInst *I, char *path, size_t size, unsigned char **sets, size_t *len)
{
    *sets = NULL;
    *len = 0;
    if (cache_path(I, path, size, sets, len) != 0) return 0;
    if (seen_before(path)) return 1;
    free(*sets);   /* the first time: only the mark */
    *sets = NULL;
    *len = 0;
    return 0;
}

#ifndef _WIN32
/* `dir` a folder of this user's that nobody else may enter (mode 0700 or stricter), not a link, no
 * folder above it another user could replace it from (runtime_unpack.h): 0, or -1 */
static int private_dir(const char *dir)
{
    char why[4300];
    return ru_private_dir(dir, why, sizeof why) ? -1 : 0;
}

/* The cache file's bytes (a new array, *len), or NULL (none, or not to be trusted: see above). */
static char *cache_read(const char *dir, const char *path, size_t *len)
{
    if (private_dir(dir) != 0) return NULL;
    int fd = open(path, O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) return NULL;
    struct stat st;
    char *buf = NULL;
    if (fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_uid == geteuid() && (st.st_mode & 022) == 0
        && st.st_size >= 16 && st.st_size <= NS_MAX_FILE && (buf = (char *)malloc((size_t)st.st_size + 1))) {
        size_t got = 0;
        while (got < (size_t)st.st_size) {
            ssize_t r = read(fd, buf + got, (size_t)st.st_size - got);
            if (r <= 0) break;
            got += (size_t)r;
        }
        if (got != (size_t)st.st_size) {
            free(buf);
            buf = NULL;
        }
        *len = got;
        if (buf) futimens(fd, NULL);   /* used now: the last to be pruned */
    }
    close(fd);
    return buf;
}

/* Two touches: the values of `path` (<key>.bin) were set in an earlier instance too (its mark <key>.seen,
 * a regular file of this user's, is there): 1; else the mark is made now and 0. A host's sweep over
 * values it sets once each then costs no snapshot per instance, a host that loads the same values again
 * gets one at the second instance's end and starts natively from the third. */
static int seen_before(const char *path)
{
    char mark[PATH_MAX];
    size_t n = strlen(path);
    if (n < 4 || n + 2 > sizeof mark) return 0;
    memcpy(mark, path, n - 4);
    memcpy(mark + n - 4, ".seen", 6);
    struct stat st;
    if (lstat(mark, &st) == 0 && S_ISREG(st.st_mode) && st.st_uid == geteuid()) return 1;
    ns_cache_store(mark, "", 0);
    return 0;
}

/* The folder's files beyond NS_CACHE_FILES, least recently used first (modification time: a file used is
 * touched), removed: only our names (16 hexadecimal digits, then .bin or .seen), only regular files. */
#define NS_CACHE_FILES 512
typedef struct {
    char name[32];
    time_t mtime;
} Entry;

static int older(const void *a, const void *b)
{
    time_t x = ((const Entry *)a)->mtime, y = ((const Entry *)b)->mtime;
    return x < y ? -1 : x > y;
}

static void prune(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return;
    Entry *e = NULL;
    size_t n = 0, cap = 0;
    struct dirent *de;
    while ((de = readdir(d))) {
        const char *nm = de->d_name;
        size_t l = strlen(nm), hex = 0;
        while (hex < l && ((nm[hex] >= '0' && nm[hex] <= '9') || (nm[hex] >= 'a' && nm[hex] <= 'f'))) hex++;
        if (hex != 16 || (strcmp(nm + 16, ".bin") && strcmp(nm + 16, ".seen"))) continue;
        char p[PATH_MAX];
        struct stat st;
        if (snprintf(p, sizeof p, "%s/%s", dir, nm) >= (int)sizeof p || lstat(p, &st) != 0 || !S_ISREG(st.st_mode))
            continue;
        if (n == cap) {
            Entry *more = (Entry *)realloc(e, (cap = cap ? 2 * cap : 64) * sizeof *e);
            if (!more) break;
            e = more;
        }
        snprintf(e[n].name, sizeof e[n].name, "%s", nm);
        e[n++].mtime = st.st_mtime;
    }
    closedir(d);
    if (n > NS_CACHE_FILES) {
        qsort(e, n, sizeof *e, older);
        for (size_t i = 0; i < n - NS_CACHE_FILES; i++) {
            char p[PATH_MAX];
            if (snprintf(p, sizeof p, "%s/%s", dir, e[i].name) < (int)sizeof p) unlink(p);
        }
    }
    free(e);
}

int ns_cache_store(const char *path, const void *bytes, size_t len)
{
    /* the folder, made with each missing folder above it (0700, as mkdir -p), then checked private */
    char dir[PATH_MAX];
    const char *slash = strrchr(path, '/');
    if (!slash || slash == path || (size_t)(slash - path) >= sizeof dir || len > NS_MAX_FILE) return -1;
    memcpy(dir, path, (size_t)(slash - path));
    dir[slash - path] = 0;
    if (ru_make_dirs(dir) != 0 || private_dir(dir) != 0) return -1;   /* runtime_unpack.h */
    char tmp[PATH_MAX];
    if (snprintf(tmp, sizeof tmp, "%s/.new-XXXXXX", dir) >= (int)sizeof tmp) return -1;
    int fd = mkstemp(tmp);   /* mode 0600 */
    if (fd < 0) return -1;
    size_t put = 0;
    while (put < len) {
        ssize_t w = write(fd, (const char *)bytes + put, len - put);
        if (w <= 0) break;
        put += (size_t)w;
    }
    int ok = put == len && close(fd) == 0;
    if (!ok || rename(tmp, path) != 0) {
        if (put != len) close(fd);
        unlink(tmp);
        return -1;
    }
    prune(dir);
    return 0;
}
#else
static int seen_before(const char *path)
{
    (void)path;
    return 0;
}

int ns_cache_store(const char *path, const void *bytes, size_t len)
{
    (void)path; (void)bytes; (void)len;
    return -1;
}
#endif

/* T (a parsed cache file) is the model of exactly this instance's variables and values before the build */
static int fits(const NsInst *I, const NsInst *T)
{
    if (T->n_vars != I->n_vars) return 0;
    for (size_t i = 0; i < I->n_vars; i++) {
        const Var *a = &I->vars[i], *b = &T->vars[i];
        if (a->kind != b->kind || a->vr != b->vr || a->flags != b->flags) return 0;
        int set = I->n_over && I->has[i];
        if (a->kind == K_STRING) {
            if (strcmp(set ? I->sover[i] : a->sval[0], b->sval[0]) != 0) return 0;
        } else {
            double want = set ? I->over[i] : a->val[0];
            if (a->kind == K_BOOLEAN ? (want != 0.0) != (b->val[0] != 0.0) : memcmp(&want, &b->val[0], 8) != 0) return 0;
        }
    }
    return 1;
}

#define SWAP(f) do { __typeof__(I->f) t_ = I->f; I->f = T->f; T->f = t_; } while (0)
#define SWAP_ARRAY(f) do { for (size_t k_ = 0; k_ < sizeof I->f / sizeof I->f[0]; k_++) SWAP(f[k_]); } while (0)

/* Before the model's build: 0 (no values set, or built from the cache file of the values set), or -1
 * (the Python builds it; nothing changed). */
static int cache_build(NsInst *I)
{
    if (!I->n_over) return 0;
#ifdef _WIN32
    return -1;
#else
    char path[PATH_MAX];
    size_t len = 0;
    char *bytes = cache_path(I, path, sizeof path, NULL, NULL) == 0 ? cache_read(I->cache_dir, path, &len) : NULL;
    if (!bytes) return -1;
    NsInst *T = (NsInst *)calloc(1, sizeof *T);
    char err[512];
    if (!T) {
        free(bytes);
        return -1;
    }
    T->file = bytes;
    if (parse(T, I->resources, len, err, sizeof err) != 0 || !fits(I, T)) {
        ns_free(T);
        return -1;
    }
    /* the model's data from T; the instance's own (its phase, time, tape, logging, values set) stays */
    SWAP(file); SWAP(early); SWAP_ARRAY(libs); SWAP(n_libs); SWAP(fn); SWAP_ARRAY(ctx); SWAP_ARRAY(arrays);
    SWAP_ARRAY(array_n); SWAP(n_fields); SWAP(direct); SWAP(v); SWAP(nv); SWAP(n_in); SWAP(vars); SWAP(n_vars);
    SWAP_ARRAY(index); SWAP_ARRAY(max_vr); SWAP(msgs); SWAP(n_msgs); SWAP_ARRAY(vectors[0]);
    SWAP_ARRAY(vectors[1]);
    I->step_ctx = I->direct ? (const void *)I->arrays[0] : (const void *)I->ctx;
    T->n_libs = 0;   /* the kernels stay loaded either way */
    ns_free(T);
    drop_overrides(I);   /* the file's values before the build are the values set now */
    return 0;
#endif
}
#undef SWAP
#undef SWAP_ARRAY

/* ------------------------------------------------------------------------------ the replay */
/* T_STEPPING replayed: the model's Python, stepping from its start, takes the native step's state as it
 * is now (the hand-over's export makes the model's plan hold its state, the import then replaces that
 * with these arrays, time and steps). The status, or fmi2Error with the reason in `err`. */
static fmi2Status hand_over(const NsInst *I, const NsHandOver *ho, fmi2Component c, char *err, size_t errsize)
{
    unsigned char *bytes = NULL;
    size_t len = 0;
    int kind = ho->take(c, &bytes, &len);
    free(bytes);
    if (kind != 1) {
        snprintf(err, errsize, "the model's Python %s the native step's state", kind == 0 ? "was not ready for"
                 : "has no compiled step to take");
        return fmi2Error;
    }
    double *arrays = NULL, time = 0.0;
    size_t n = 0;
    int bad = 0;
    long steps = 0;
    if (ns_live_state(I, &arrays, &n, &time, &bad, &steps) != 0) {
        snprintf(err, errsize, "out of memory handing over the native step's state");
        return fmi2Error;
    }
    fmi2Status s = ho->give(c, arrays, n, time, bad, steps);
    free(arrays);
    if (s > fmi2Warning) snprintf(err, errsize, "the model's Python did not take the state of the %ld native steps",
                                  steps);
    return s;
}

int ns_replay(const NsInst *I, const Fmi2Table *t, fmi2Component c, const NsHandOver *ho, char *err, size_t errsize)
{
    static const char *const NAMES[] = {"fmi2SetDebugLogging", "fmi2SetupExperiment", "fmi2EnterInitializationMode",
                                        "fmi2ExitInitializationMode", "fmi2Terminate", "fmi2SetReal",
                                        "fmi2SetInteger", "fmi2SetBoolean", "fmi2SetString",
                                        "a read in Initialization Mode", "the native steps' hand-over"};
    size_t pos = 0, count = 0;
    while (pos < I->tape_len) {
        Rec h;
        memcpy(&h, I->tape + pos, sizeof h);
        const unsigned char *p = I->tape + pos + sizeof h;
        size_t n = (size_t)h.n, size = 0;
        fmi2Status s = fmi2Error;
        switch (h.op) {
        case T_LOGGING: {
            int32_t on;
            memcpy(&on, p, sizeof on);
            s = t->fmi2SetDebugLogging(c, on ? fmi2True : fmi2False, 0, NULL);
            size = sizeof on;
            break;
        }
        case T_SETUP: {
            double d[3];
            int32_t b[2];
            memcpy(d, p, sizeof d);
            memcpy(b, p + sizeof d, sizeof b);
            s = t->fmi2SetupExperiment(c, b[0], d[0], d[1], b[1], d[2]);
            size = sizeof d + sizeof b;
            break;
        }
        case T_ENTER: s = t->fmi2EnterInitializationMode(c); break;
        case T_EXIT: s = t->fmi2ExitInitializationMode(c); break;
        case T_TERMINATE: s = t->fmi2Terminate(c); break;
        case T_SET_REAL:
        case T_SET_INTEGER:
        case T_SET_BOOLEAN:
        case T_SET_STRING: {
            fmi2ValueReference *vr = (fmi2ValueReference *)malloc((n ? n : 1) * sizeof *vr);
            size_t each = h.op == T_SET_REAL ? sizeof(fmi2Real) : h.op == T_SET_STRING ? 0 : sizeof(int);
            void *vals = malloc((n ? n : 1) * (each ? each : sizeof(fmi2String)));
            if (!vr || !vals) {
                free(vr);
                free(vals);
                snprintf(err, errsize, "out of memory replaying the start");
                return -1;
            }
            memcpy(vr, p, n * sizeof *vr);
            if (each) memcpy(vals, p + n * sizeof *vr, n * each);
            size = n * (sizeof(fmi2ValueReference) + each);
            char *strs = NULL;
            if (h.op == T_SET_REAL) s = t->fmi2SetReal(c, vr, n, (const fmi2Real *)vals);
            else if (h.op == T_SET_INTEGER) s = t->fmi2SetInteger(c, vr, n, (const fmi2Integer *)vals);
            else if (h.op == T_SET_BOOLEAN) s = t->fmi2SetBoolean(c, vr, n, (const fmi2Boolean *)vals);
            else {   /* each string: u32 length, its bytes (ns_set_string), made NUL-terminated in a copy */
                fmi2String *sv = (fmi2String *)vals;
                size_t total = 0, at = size;
                for (size_t i = 0; i < n; i++) {
                    uint32_t len;
                    memcpy(&len, p + at, 4);
                    at += 4 + len;
                    total += len + 1;
                }
                strs = (char *)malloc(total ? total : 1);
                char *q = strs;
                at = size;
                for (size_t i = 0; strs && i < n; i++) {
                    uint32_t len;
                    memcpy(&len, p + at, 4);
                    memcpy(q, p + at + 4, len);
                    q[len] = 0;
                    sv[i] = q;
                    q += len + 1;
                    at += 4 + len;
                }
                s = strs ? t->fmi2SetString(c, vr, n, sv) : fmi2Error;
                size = at;
            }
            free(strs);
            free(vr);
            free(vals);
            break;
        }
        case T_STEPPING:
            s = hand_over(I, ho, c, err, errsize);
            if (s > fmi2Warning) return -1;
            break;
        case T_BUILD: {   /* the read that built the model: the same read (its values are the snapshot's) */
            int32_t what[3];
            memcpy(what, p, sizeof what);
            fmi2ValueReference vr = (fmi2ValueReference)what[1];
            size_t k = (size_t)what[2];
            fmi2Real r;
            fmi2Integer i;
            fmi2Boolean b;
            fmi2String str;
            s = what[0] == K_REAL ? t->fmi2GetReal(c, &vr, k, &r) : what[0] == K_INTEGER ? t->fmi2GetInteger(c, &vr, k, &i)
                : what[0] == K_BOOLEAN ? t->fmi2GetBoolean(c, &vr, k, &b) : t->fmi2GetString(c, &vr, k, &str);
            size = sizeof what;
            break;
        }
        default:
            snprintf(err, errsize, "the start's record %zu is damaged", count);
            return -1;
        }
        if (s != (fmi2Status)h.status) {
            snprintf(err, errsize, "replaying the start in the model's Python: call %zu (%s) answered %d, not %d as "
                     "natively", count + 1, NAMES[h.op], (int)s, (int)h.status);
            return -1;
        }
        pos += sizeof h + size;
        count++;
    }
    /* the outputs as the native step left them */
    for (size_t i = 0; I->phase >= P_STEPPING && i < I->n_vars; i++) {
        const Var *x = &I->vars[i];
        if (x->kind != K_REAL || x->slot < (int)I->n_in || (x->flags & F_CONSTANT)) continue;
        fmi2Real got;
        if (t->fmi2GetReal(c, &x->vr, 1, &got) > fmi2Warning || memcmp(&got, &I->v[x->slot], sizeof got) != 0) {
            snprintf(err, errsize, "replaying the start in the model's Python: the variable with value reference "
                     "%u is %.17g there, %.17g natively, after %ld steps", x->vr, got, I->v[x->slot], I->steps);
            return -1;
        }
    }
    return 0;
}
