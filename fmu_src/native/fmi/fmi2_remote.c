/* The model in its own process, seen from the host (see ipc.h for the protocol and
 * fmi2_server.c for the other side).
 *
 * remote_instantiate starts binaries/<platform>/spurdiff_fmu_server (fmi2_remote_spawn.c: a
 * memfd and the read end of a pipe handed over) and forwards fmi2Instantiate. Every later call is
 * one round trip, but for fmi2SetReal deferred to the next call and fmi2GetReal answered from
 * what fmi2DoStep brought back (fmi2_remote_batch.c: a set / doStep / get step is one round
 * trip); the model's log records come back with the answer and go to the host's logger on the
 * calling thread. When the server dies (a crash of the model), the call returns fmi2Error with
 * the signal named, and so does every later call but fmi2FreeInstance. The server ends with
 * fmi2FreeInstance, or by itself when the host process is gone (its pipe reads end of file, or
 * its parent is no longer the host).
 *
 * No call waits without bound (call_watch): a model process that is stopped (SIGSTOP, SIGTSTP,
 * SIGTTIN, SIGTTOU) for STOPPED_MS, that uses no CPU for SILENT_MS while a call is out, or that has
 * not answered within the call deadline (SPURDIFF_FMU_CALL_TIMEOUT seconds, default DEADLINE_S)
 * ends the call with fmi2Error naming the cause; the process is then killed and the instance lost
 * like a crashed one. A process that forked after fmi2Instantiate: the model's process belongs to
 * the parent; the child's calls are refused with the reason logged and its fmi2FreeInstance frees
 * only its own copy (the parent's model process goes on).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <pthread.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "fmi2_remote.h"
#include "fmi2_remote_batch.h"
#include "log_text.h"
#include "fmi2_remote_spawn.h"
#include "ipc.h"

#define STOPPED_MS 1000            /* stopped this long during a call: fmi2Error */
#define SILENT_MS 10000            /* no CPU used this long during a call (blocked for good): fmi2Error */
#define DEADLINE_S 600.0           /* any call, unless SPURDIFF_FMU_CALL_TIMEOUT says otherwise */
#define REMOTE_MAGIC 0x52454D54u   /* "REMT" */
#define RSTATE_MAGIC 0x52535441u   /* "RSTA" */

typedef struct {
    unsigned magic;
    char *name;
    fmi2CallbackFunctions cb;
    void *base;
    IpcHeader *h;
    int shm_fd, pipe_w;
    pid_t pid;
    void *folder;              /* the FMU folder's record (fmi2_remote_spawn.c: the zygote) */
    int forked;                /* the server was forked by the folder's zygote */
    int dead;                  /* the server is gone: every call but free fails */
    pid_t owner;               /* the process that instantiated (a forked child is not) */
    uint32_t call;             /* the call out, and what call_watch knows of the server since it went out */
    uint64_t sent_ns, stopped_ns, cpu_ns, deadline_ns;
    long long cpu;
    char *strings;             /* the last fmi2GetString / fmi2GetStringStatus answer's text */
    fmi2String *string_ptrs;
    int logged;                /* the last answer came with the model's messages */
    Batch batch;               /* deferred sets, the values the last step brought back */
    IpcSpin spin;              /* the host's spin before it sleeps on an answer */
} Remote;

typedef struct {
    unsigned magic;
    Remote *owner;
    uint64_t id;
} RState;

/* ---------------------------------------------------------------------------- logging */
static void sayf(Remote *r, fmi2Status status, const char *fmt, ...)
{
    char msg[4096];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    log_text(&r->cb, r->name, status, status >= fmi2Error ? "logStatusError" : "logAll", msg);
}

/* The server's log records of the last call, to the host's logger. */
static void replay(Remote *r)
{
    IpcBuf b = {ipc_log(r->base), (size_t)(r->h->log_len <= IPC_LOG_CAP ? r->h->log_len : 0), 0, 0};
    while (b.pos < b.cap && !b.bad) {
        size_t ncat, nmsg;
        int32_t status = ipc_get_i32(&b);
        const char *cat = ipc_get_str(&b, &ncat);
        const char *msg = ipc_get_str(&b, &nmsg);
        if (b.bad) break;
        char category[128], *text = (char *)malloc(nmsg + 1);
        if (!text) break;
        snprintf(category, sizeof category, "%.*s", (int)ncat, cat ? cat : "logAll");
        memcpy(text, msg ? msg : "", nmsg);
        text[nmsg] = 0;
        if (status < fmi2OK || status > fmi2Pending) status = fmi2Error;
        log_text(&r->cb, r->name, (fmi2Status)status, category, text);
        free(text);
    }
    if (r->h->log_dropped)
        sayf(r, fmi2Warning, "%u log messages of the model did not fit the shared log area", r->h->log_dropped);
    r->h->log_len = 0;
    r->h->log_dropped = 0;
}

/* ---------------------------------------------------------------------------- the server */
static const char *signal_name(int sig)
{
    const char *s = strsignal(sig);
    return s ? s : "unknown signal";
}

/* 1 while the server runs; else marks the instance dead and logs why (once). */
static int server_alive(void *ctx)
{
    Remote *r = (Remote *)ctx;
    if (r->dead) return 0;
    int st;
    pid_t w = waitpid(r->pid, &st, WNOHANG);
    if (w == 0) return 1;
    if (w < 0 && errno == ECHILD) {   /* a zygote's process: the zygote reaps it and says how it ended */
        if (atomic_load(&r->h->ended)) {
            w = r->pid;
            st = r->h->wait_status;
        } else if (kill(r->pid, 0) == 0 && !proc_ended(r->pid)) {
            return 1;   /* (a zygote's process whose zygote is gone ends: init reaps it, or nobody) */
        }
    }
    r->dead = 1;
    if (w == r->pid && WIFSIGNALED(st))
        sayf(r, fmi2Error, "the model's process (pid %d) ended with signal %d (%s): the instance is lost; "
             "free it and instantiate again", (int)r->pid, WTERMSIG(st), signal_name(WTERMSIG(st)));
    else if (w == r->pid && WIFEXITED(st))
        sayf(r, fmi2Error, "the model's process (pid %d) exited with status %d: the instance is lost; free it and "
             "instantiate again", (int)r->pid, WEXITSTATUS(st));
    else
        sayf(r, fmi2Error, "the model's process (pid %d) is gone: the instance is lost", (int)r->pid);
    return 0;
}

static const char *call_name(uint32_t call)
{
    static const char *names[N_CALLS] = {
        [CALL_INSTANTIATE] = "fmi2Instantiate", [CALL_FREE] = "fmi2FreeInstance", [CALL_SETUP_EXPERIMENT] =
        "fmi2SetupExperiment", [CALL_ENTER_INIT] = "fmi2EnterInitializationMode", [CALL_EXIT_INIT] =
        "fmi2ExitInitializationMode", [CALL_TERMINATE] = "fmi2Terminate", [CALL_RESET] = "fmi2Reset",
        [CALL_GET_REAL] = "fmi2GetReal", [CALL_SET_REAL] = "fmi2SetReal", [CALL_GET_STATE] = "fmi2GetFMUstate",
        [CALL_SET_STATE] = "fmi2SetFMUstate", [CALL_SERIALIZE] = "fmi2SerializeFMUstate", [CALL_DESERIALIZE] =
        "fmi2DeSerializeFMUstate", [CALL_DO_STEP] = "fmi2DoStep", [CALL_DO_STEP_EARLY] = "fmi2DoStep (early return)",
        [CALL_NATIVE_EXPORT] = "fmi2DoStep (handing the step to this process)",
        [CALL_NATIVE_IMPORT] = "giving the step back to the model's process",
        [CALL_START_SNAPSHOT] = "fmi2FreeInstance (the native start of the values set)"};
    return call < N_CALLS && names[call] ? names[call] : "the call";
}

/* The call's end without an answer: logged, the server killed, the instance lost. */
static int call_lost(Remote *r, const char *why)
{
    sayf(r, fmi2Error, "%s: the model's process (pid %d) %s: the call ends with fmi2Error, the process is ended and "
         "the instance is lost; free it and instantiate again", call_name(r->call), (int)r->pid, why);
    r->dead = 1;
    kill(r->pid, SIGKILL);
    waitpid(r->pid, NULL, 0);
    r->pid = 0;
    return 0;
}

/* ipc_wait_change's check after each slice of the host's wait: the server alive, not stopped, not
 * silent, within the deadline (1); else the call is lost (0). */
static int call_watch(void *ctx)
{
    Remote *r = (Remote *)ctx;
    if (!server_alive(r)) return 0;
    uint64_t now = ipc_now_ns();
    char state = '?';
    long long cpu = -1;
    if (proc_state(r->pid, &state, &cpu) == 0) {
        if (state == 'T' || state == 't') {
            if (!r->stopped_ns) r->stopped_ns = now;
            else if (now - r->stopped_ns >= (uint64_t)STOPPED_MS * 1000000u)
                return call_lost(r, "has been stopped for 1 s (SIGSTOP, SIGTSTP, or SIGTTIN / SIGTTOU: a read or, "
                                    "with tostop, a write on a terminal)");
        } else {
            r->stopped_ns = 0;
        }
        if (cpu != r->cpu || state == 'R' || state == 'T' || state == 't') {
            r->cpu = cpu;
            r->cpu_ns = now;
        } else if (now - r->cpu_ns >= (uint64_t)SILENT_MS * 1000000u) {
            return call_lost(r, "has not answered and has used no CPU for 10 s (blocked: hung)");
        }
    }
    if (now >= r->deadline_ns) {
        char why[160];
        snprintf(why, sizeof why, "has not answered within %.6g s (SPURDIFF_FMU_CALL_TIMEOUT)",
                 (double)(r->deadline_ns - r->sent_ns) / 1e9);
        return call_lost(r, why);
    }
    return 1;
}

/* The call deadline (ns) from SPURDIFF_FMU_CALL_TIMEOUT (seconds, > 0), else DEADLINE_S. */
static uint64_t call_deadline(void)
{
    const char *e = getenv("SPURDIFF_FMU_CALL_TIMEOUT");
    char *end = NULL;
    double sec = e && *e ? strtod(e, &end) : 0.0;
    if (!(end && *end == 0 && sec > 0.0 && sec < 1e7)) sec = DEADLINE_S;
    return (uint64_t)(sec * 1e9);
}

/* Send the call written in the data area (`len` bytes) and wait for the answer. The answer's
 * status, or fmi2Error when the server died, stopped, went silent or passed the deadline. */
static fmi2Status roundtrip(Remote *r, uint32_t call, size_t len, IpcBuf *answer)
{
    if (getpid() != r->owner) {
        sayf(r, fmi2Error, "%s refused: this process (pid %d) is a fork of the one that instantiated the FMU (pid "
             "%d); the model's process belongs to that one: instantiate again in this process", call_name(call),
             (int)getpid(), (int)r->owner);
        return fmi2Error;
    }
    if (r->dead) {
        sayf(r, fmi2Error, "the model's process is gone (see the earlier message): only fmi2FreeInstance is possible");
        return fmi2Error;
    }
    r->call = call;
    r->sent_ns = r->cpu_ns = ipc_now_ns();
    r->deadline_ns = r->sent_ns + call_deadline();
    r->stopped_ns = 0;
    r->cpu = -1;
    IpcHeader *h = r->h;
    h->call = call;
    h->len = len;
    h->pre_len = r->batch.pre_len;   /* the deferred calls before it */
    r->batch.pre_len = 0;
    uint32_t seq = atomic_load(&h->req) + 1;
    ipc_publish(&h->req, seq, &h->server_sleeps);
    uint32_t old = seq - 1;
    /* spin up to 100 us (while it pays): the answer to a get or set comes in a few microseconds */
    if (ipc_wait_change(&h->resp, old, &h->host_sleeps, &r->spin, 50000000L, call_watch, r) != 0) return fmi2Error;
    r->logged = h->log_len || h->log_dropped;
    replay(r);
    *answer = (IpcBuf){ipc_data(r->base), h->len <= IPC_DATA_CAP ? (size_t)h->len : 0, 0, 0};
    int32_t s = h->status;
    fmi2Status st = (s >= fmi2OK && s <= fmi2Pending) ? (fmi2Status)s : fmi2Error;
    batch_answered(&r->batch, call, st);
    return st;
}

/* The call's arguments go after the deferred calls waiting at the data area's start. */
static IpcBuf request(Remote *r)
{
    IpcBuf b = {ipc_data(r->base) + r->batch.pre_len, IPC_DATA_CAP - r->batch.pre_len, 0, 0};
    return b;
}

static fmi2Status too_large(Remote *r, const char *fn)
{
    sayf(r, fmi2Error, "%s: the arguments do not fit the shared memory's %zu bytes", fn, (size_t)IPC_DATA_CAP);
    return fmi2Error;
}

static void drop(Remote *r)
{
    if (!r) return;
    if (r->base && r->base != MAP_FAILED) munmap(r->base, IPC_SIZE);
    if (r->shm_fd >= 0) close(r->shm_fd);
    if (r->pipe_w >= 0) close(r->pipe_w);
    free(r->name);
    free(r->strings);
    free(r->string_ptrs);
    r->magic = 0;
    free(r);
}

fmi2Component remote_instantiate(fmi2String name, fmi2Type type, fmi2String guid, const char *resources,
                                 const char *bindir, const fmi2CallbackFunctions *cb, fmi2Boolean visible,
                                 fmi2Boolean logging, char *err, size_t errsize)
{
    Remote *r = (Remote *)calloc(1, sizeof *r);
    if (!r) { snprintf(err, errsize, "out of memory"); return NULL; }
    r->magic = REMOTE_MAGIC;
    r->shm_fd = r->pipe_w = -1;
    r->owner = getpid();
    r->name = strdup(name ? name : "");
    if (cb) r->cb = *cb;
    if (spawn_server(resources, bindir, &r->shm_fd, &r->base, &r->pipe_w, &r->pid, &r->folder, &r->forked, err, errsize) != 0) {
        drop(r);
        return NULL;
    }
    r->h = (IpcHeader *)r->base;
    r->spin = (IpcSpin){100000, 100000, 0};
    IpcBuf b = request(r), a;
    ipc_str(&b, name);
    ipc_i32(&b, (int32_t)type);
    ipc_str(&b, guid);
    ipc_str(&b, resources);
    ipc_i32(&b, visible);
    ipc_i32(&b, logging);
    fmi2Status s = b.bad ? fmi2Error : roundtrip(r, CALL_INSTANTIATE, b.pos, &a);
    if (s > fmi2Warning) {
        err[0] = 0;   /* the model's process logged why */
        if (!r->dead) {
            IpcBuf f = request(r);
            roundtrip(r, CALL_FREE, 0, &f);
        }
        if (r->pipe_w >= 0) { close(r->pipe_w); r->pipe_w = -1; }
        reap_server(r->pid, 2000);
        release_server(r->folder, r->forked);
        drop(r);
        return NULL;
    }
    return r;
}

static Remote *valid(fmi2Component c)
{
    Remote *r = (Remote *)c;
    return (r && r->magic == REMOTE_MAGIC) ? r : NULL;
}

static void remote_free(fmi2Component c)
{
    Remote *r = valid(c);
    if (!r) return;
    if (getpid() != r->owner) {   /* a forked child's copy: its memory and descriptors only */
        sayf(r, fmi2Warning, "fmi2FreeInstance in a fork (pid %d) of the process that instantiated the FMU (pid %d): "
             "this process's copy is freed, the model's process goes on for that one", (int)getpid(), (int)r->owner);
        r->pid = 0;
        drop(r);
        return;
    }
    if (!r->dead) {
        IpcBuf a;
        roundtrip(r, CALL_FREE, 0, &a);
    }
    if (r->pipe_w >= 0) { close(r->pipe_w); r->pipe_w = -1; }   /* the server sees end of file */
    reap_server(r->pid, 5000);
    release_server(r->folder, r->forked);
    drop(r);
}

/* ---------------------------------------------------------------------------- the calls */
#define R_ENTER                                                                                    \
    Remote *r = valid(c);                                                                          \
    if (!r) return fmi2Error;                                                                      \
    IpcBuf b = request(r), a;                                                                      \
    (void)a;

#define R_SEND(call, fn)                                                                           \
    if (b.bad) return too_large(r, fn);                                                            \
    fmi2Status s = roundtrip(r, call, b.pos, &a);

static fmi2Status r_simple(fmi2Component c, uint32_t call)
{
    R_ENTER
    R_SEND(call, "call")
    return s;
}

static fmi2Status remote_fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[])
{
    R_ENTER
    ipc_i32(&b, on);
    ipc_u64(&b, n);
    for (size_t i = 0; i < n; i++) ipc_str(&b, cat ? cat[i] : NULL);
    R_SEND(CALL_SET_DEBUG_LOGGING, "fmi2SetDebugLogging")
    return s;
}

static fmi2Status remote_fmi2SetupExperiment(fmi2Component c, fmi2Boolean td, fmi2Real tol, fmi2Real t0,
                                             fmi2Boolean sd, fmi2Real t1)
{
    R_ENTER
    ipc_i32(&b, td);
    ipc_f64(&b, tol);
    ipc_f64(&b, t0);
    ipc_i32(&b, sd);
    ipc_f64(&b, t1);
    R_SEND(CALL_SETUP_EXPERIMENT, "fmi2SetupExperiment")
    return s;
}

static fmi2Status remote_fmi2EnterInitializationMode(fmi2Component c) { return r_simple(c, CALL_ENTER_INIT); }
static fmi2Status remote_fmi2ExitInitializationMode(fmi2Component c) { return r_simple(c, CALL_EXIT_INIT); }
static fmi2Status remote_fmi2Terminate(fmi2Component c) { return r_simple(c, CALL_TERMINATE); }
static fmi2Status remote_fmi2Reset(fmi2Component c) { return r_simple(c, CALL_RESET); }
static fmi2Status remote_fmi2CancelStep(fmi2Component c) { return r_simple(c, CALL_CANCEL_STEP); }

/* An answer's array of `n` values of `size` bytes into `v` when the call succeeded: the status, or
 * fmi2Error when the answer does not hold them (or `v` is NULL for n > 0). */
static fmi2Status take_values(IpcBuf *a, fmi2Status s, void *v, size_t n, size_t size)
{
    if (s > fmi2Warning) return s;
    const void *q = ipc_take_array(a, n, size);
    if (!q || (n && !v)) return fmi2Error;
    if (n) memcpy(v, q, n * size);
    return s;
}

static fmi2Status r_get(fmi2Component c, uint32_t call, const fmi2ValueReference vr[], size_t n, void *v,
                        size_t size, const char *fn)
{
    R_ENTER
    if (call == CALL_GET_REAL && !r->dead && getpid() == r->owner && batch_get(&r->batch, vr, n, (fmi2Real *)v))
        return fmi2OK;
    ipc_u64(&b, n);
    ipc_put_array(&b, vr, n, sizeof *vr);
    R_SEND(call, fn)
    s = take_values(&a, s, v, n, size);
    batch_learn(&r->batch, call, s, r->logged, vr, n);
    return s;
}

static fmi2Status remote_fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[])
{
    return r_get(c, CALL_GET_REAL, vr, n, v, sizeof *v, "fmi2GetReal");
}
static fmi2Status remote_fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[])
{
    return r_get(c, CALL_GET_INTEGER, vr, n, v, sizeof *v, "fmi2GetInteger");
}
static fmi2Status remote_fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[])
{
    return r_get(c, CALL_GET_BOOLEAN, vr, n, v, sizeof *v, "fmi2GetBoolean");
}

/* Copy `n` strings of the answer into the instance's string store; they stay valid until the next
 * call that returns strings. */
static int keep_strings(Remote *r, IpcBuf *a, size_t n, fmi2String out[])
{
    size_t start = a->pos, total = 0, len;
    for (size_t i = 0; i < n; i++) {
        ipc_get_str(a, &len);
        total += len + 1;
    }
    if (a->bad) return -1;
    a->pos = start;
    char *text = (char *)malloc(total ? total : 1);
    fmi2String *ptrs = (fmi2String *)malloc((n ? n : 1) * sizeof *ptrs);
    if (!text || !ptrs) { free(text); free(ptrs); return -1; }
    char *q = text;
    for (size_t i = 0; i < n; i++) {
        const char *p = ipc_get_str(a, &len);
        memcpy(q, p ? p : "", len);
        q[len] = 0;
        ptrs[i] = p ? q : NULL;
        q += len + 1;
    }
    free(r->strings);
    free(r->string_ptrs);
    r->strings = text;
    r->string_ptrs = ptrs;
    for (size_t i = 0; i < n; i++) out[i] = ptrs[i] ? ptrs[i] : "";
    return 0;
}

static fmi2Status remote_fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[])
{
    R_ENTER
    ipc_u64(&b, n);
    ipc_put_array(&b, vr, n, sizeof *vr);
    R_SEND(CALL_GET_STRING, "fmi2GetString")
    if (s <= fmi2Warning && keep_strings(r, &a, n, v) != 0) return fmi2Error;
    return s;
}

static fmi2Status r_set(fmi2Component c, uint32_t call, const fmi2ValueReference vr[], size_t n, const void *v,
                        size_t size, const char *fn)
{
    R_ENTER
    if (call == CALL_SET_REAL && !r->dead && getpid() == r->owner
        && batch_defer_set(&r->batch, ipc_data(r->base), vr, n, (const fmi2Real *)v))
        return fmi2OK;
    ipc_u64(&b, n);
    ipc_put_array(&b, vr, n, sizeof *vr);
    ipc_put_array(&b, v, n, size);
    R_SEND(call, fn)
    batch_learn(&r->batch, call, s, r->logged, vr, n);
    return s;
}

static fmi2Status remote_fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[])
{
    return r_set(c, CALL_SET_REAL, vr, n, v, sizeof *v, "fmi2SetReal");
}
static fmi2Status remote_fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[])
{
    return r_set(c, CALL_SET_INTEGER, vr, n, v, sizeof *v, "fmi2SetInteger");
}
static fmi2Status remote_fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[])
{
    return r_set(c, CALL_SET_BOOLEAN, vr, n, v, sizeof *v, "fmi2SetBoolean");
}

static fmi2Status remote_fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[])
{
    R_ENTER
    ipc_u64(&b, n);
    ipc_put_array(&b, vr, n, sizeof *vr);
    for (size_t i = 0; i < n; i++) ipc_str(&b, v[i]);
    R_SEND(CALL_SET_STRING, "fmi2SetString")
    return s;
}

/* *p = a new handle of the model process's state `id`: the call's status s, or fmi2Error (no memory). */
static fmi2Status new_state(Remote *r, uint64_t id, fmi2FMUstate *p, fmi2Status s)
{
    RState *st = (RState *)calloc(1, sizeof *st);
    if (!st) return fmi2Error;
    *st = (RState){RSTATE_MAGIC, r, id};
    *p = st;
    return s;
}

static RState *valid_state(Remote *r, fmi2FMUstate p)
{
    RState *st = (RState *)p;
    return (st && st->magic == RSTATE_MAGIC && st->owner == r) ? st : NULL;
}

static fmi2Status remote_fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *p)
{
    R_ENTER
    if (!p) { sayf(r, fmi2Error, "fmi2GetFMUstate: FMUstate is NULL"); return fmi2Error; }
    RState *old = *p ? valid_state(r, *p) : NULL;
    if (*p && !old) { sayf(r, fmi2Error, "fmi2GetFMUstate: *FMUstate is not a state of this instance"); return fmi2Error; }
    ipc_u64(&b, old ? old->id : 0);
    R_SEND(CALL_GET_STATE, "fmi2GetFMUstate")
    uint64_t id = ipc_get_u64(&a);
    if (s > fmi2Warning || a.bad || !id) return s > fmi2Warning ? s : fmi2Error;
    if (old) { old->id = id; return s; }
    return new_state(r, id, p, s);
}

static fmi2Status remote_fmi2SetFMUstate(fmi2Component c, fmi2FMUstate p)
{
    R_ENTER
    RState *st = valid_state(r, p);
    ipc_u64(&b, st ? st->id : 0);
    R_SEND(CALL_SET_STATE, "fmi2SetFMUstate")
    return s;
}

static fmi2Status remote_fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *p)
{
    R_ENTER
    if (!p || !*p) return fmi2OK;
    RState *st = valid_state(r, *p);
    if (!st) { sayf(r, fmi2Error, "fmi2FreeFMUstate: not a state of this instance"); return fmi2Error; }
    ipc_u64(&b, st->id);
    fmi2Status s = r->dead ? fmi2OK : roundtrip(r, CALL_FREE_STATE, b.pos, &a);
    if (s <= fmi2Warning) {
        st->magic = 0;
        free(st);
        *p = NULL;
    }
    return s;
}

static fmi2Status remote_fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate p, size_t *n)
{
    R_ENTER
    RState *st = valid_state(r, p);
    ipc_u64(&b, st ? st->id : 0);
    R_SEND(CALL_STATE_SIZE, "fmi2SerializedFMUstateSize")
    uint64_t size = ipc_get_u64(&a);
    if (s <= fmi2Warning && n) *n = (size_t)size;
    return s;
}

static fmi2Status remote_fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate p, fmi2Byte out[], size_t n)
{
    R_ENTER
    RState *st = valid_state(r, p);
    ipc_u64(&b, st ? st->id : 0);
    ipc_u64(&b, n);
    R_SEND(CALL_SERIALIZE, "fmi2SerializeFMUstate")
    if (s <= fmi2Warning) {
        const void *q = ipc_take_array(&a, n, 1);
        if (!q || !out) return fmi2Error;
        memcpy(out, q, n);
    }
    return s;
}

static fmi2Status remote_fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte in[], size_t n, fmi2FMUstate *p)
{
    R_ENTER
    if (!p) { sayf(r, fmi2Error, "fmi2DeSerializeFMUstate: FMUstate is NULL"); return fmi2Error; }
    ipc_u64(&b, n);
    ipc_put_array(&b, in, n, 1);
    R_SEND(CALL_DESERIALIZE, "fmi2DeSerializeFMUstate")
    uint64_t id = ipc_get_u64(&a);
    if (s > fmi2Warning || a.bad || !id) return s > fmi2Warning ? s : fmi2Error;
    return new_state(r, id, p, s);
}

static fmi2Status remote_fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                                      const fmi2ValueReference z[], size_t nz, const fmi2Real du[],
                                                      fmi2Real dz[])
{
    R_ENTER
    ipc_u64(&b, nu);
    ipc_put_array(&b, u, nu, sizeof *u);
    ipc_u64(&b, nz);
    ipc_put_array(&b, z, nz, sizeof *z);
    ipc_put_array(&b, du, nu, sizeof *du);
    R_SEND(CALL_DIRECTIONAL_DERIVATIVE, "fmi2GetDirectionalDerivative")
    return take_values(&a, s, dz, nz, sizeof *dz);
}

static fmi2Status remote_fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                                     const fmi2Integer o[], const fmi2Real v[])
{
    R_ENTER
    ipc_u64(&b, n);
    ipc_put_array(&b, vr, n, sizeof *vr);
    ipc_put_array(&b, o, n, sizeof *o);
    ipc_put_array(&b, v, n, sizeof *v);
    R_SEND(CALL_SET_INPUT_DERIVATIVES, "fmi2SetRealInputDerivatives")
    return s;
}

static fmi2Status remote_fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                                      const fmi2Integer o[], fmi2Real v[])
{
    R_ENTER
    ipc_u64(&b, n);
    ipc_put_array(&b, vr, n, sizeof *vr);
    ipc_put_array(&b, o, n, sizeof *o);
    R_SEND(CALL_GET_OUTPUT_DERIVATIVES, "fmi2GetRealOutputDerivatives")
    return take_values(&a, s, v, n, sizeof *v);
}

/* fmi2DoStep (end NULL) or spurdiffDoStepEarly; the answer brings back the values fmi2GetReal
 * asked for after the earlier steps (fmi2_remote_batch.c). */
static fmi2Status r_step(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean nsp, fmi2Real *end)
{
    R_ENTER
    ipc_f64(&b, t);
    ipc_f64(&b, h);
    ipc_i32(&b, nsp);
    batch_put_want(&r->batch, &b);
    R_SEND(end ? CALL_DO_STEP_EARLY : CALL_DO_STEP, "fmi2DoStep")
    if (s > fmi2Discard) return s;   /* (no answer when the process is lost) */
    double e = end ? ipc_get_f64(&a) : t;
    if (end) *end = a.bad ? t : e;
    batch_take_values(&r->batch, &a);
    return s;
}

static fmi2Status remote_fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean nsp)
{
    return r_step(c, t, h, nsp, NULL);
}

fmi2Status remote_do_step_early(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean nsp, fmi2Real *end)
{
    fmi2Real e = t;
    fmi2Status s = r_step(c, t, h, nsp, &e);
    if (end) *end = e;
    return s;
}

int remote_native_export(fmi2Component c, unsigned char **bytes, size_t *len, fmi2Status *status)
{
    *bytes = NULL;
    *len = 0;
    *status = fmi2OK;
    Remote *r = valid(c);
    if (!r || r->dead || getpid() != r->owner) return -1;   /* (the step's own call says why) */
    IpcBuf b = request(r), a;
    fmi2Status s = *status = roundtrip(r, CALL_NATIVE_EXPORT, b.pos, &a);
    if (s > fmi2Warning) return -1;
    int32_t kind = ipc_get_i32(&a);
    uint64_t n = ipc_get_u64(&a);
    const void *q = kind == 1 ? ipc_take_array(&a, (size_t)n, 1) : NULL;
    if (a.bad || kind < -1 || kind > 1) return -1;
    if (kind != 1) return kind;
    if (!q || !(*bytes = (unsigned char *)malloc(n ? (size_t)n : 1))) return -1;
    memcpy(*bytes, q, (size_t)n);
    *len = (size_t)n;
    return 1;
}

int remote_start_snapshot(fmi2Component c, const unsigned char *sets, size_t n, unsigned char **bytes, size_t *len)
{
    *bytes = NULL;
    *len = 0;
    Remote *r = valid(c);
    if (!r || r->dead || getpid() != r->owner) return -1;
    IpcBuf b = request(r), a;
    ipc_u64(&b, n);
    ipc_put_array(&b, sets, n, 1);
    if (b.bad || roundtrip(r, CALL_START_SNAPSHOT, b.pos, &a) > fmi2Warning) return -1;
    int32_t kind = ipc_get_i32(&a);
    uint64_t m = ipc_get_u64(&a);
    const void *q = kind == 1 ? ipc_take_array(&a, (size_t)m, 1) : NULL;
    if (kind != 1 || !q || a.bad) return a.bad ? -1 : 0;
    if (!(*bytes = (unsigned char *)malloc(m ? (size_t)m : 1))) return -1;
    memcpy(*bytes, q, (size_t)m);
    *len = (size_t)m;
    return 1;
}

fmi2Status remote_native_import(fmi2Component c, const double *arrays, size_t n, double time, int bad, long steps)
{
    R_ENTER
    ipc_u64(&b, n);
    ipc_put_array(&b, arrays, n, sizeof *arrays);
    ipc_f64(&b, time);
    ipc_i32(&b, bad);
    ipc_u64(&b, (uint64_t)steps);
    R_SEND(CALL_NATIVE_IMPORT, "giving the step back to the model's process")
    return s;
}

static fmi2Status r_status(fmi2Component c, uint32_t call, fmi2StatusKind k, IpcBuf *answer, Remote **out)
{
    R_ENTER
    ipc_i32(&b, (int32_t)k);
    R_SEND(call, "fmi2Get*Status")
    *answer = a;
    *out = r;
    return s;
}

/* the status getters of a number: the answer's one value, read by `get` */
#define R_STATUS_GETTER(fn, ctype, call, get)                                                      \
    static fmi2Status fn(fmi2Component c, const fmi2StatusKind k, ctype *v)                        \
    {                                                                                              \
        IpcBuf a; Remote *r;                                                                       \
        fmi2Status s = r_status(c, call, k, &a, &r);                                               \
        if (s <= fmi2Warning && v) *v = (ctype)get(&a);                                            \
        return s;                                                                                  \
    }
R_STATUS_GETTER(remote_fmi2GetStatus, fmi2Status, CALL_GET_STATUS, ipc_get_i32)
R_STATUS_GETTER(remote_fmi2GetRealStatus, fmi2Real, CALL_GET_REAL_STATUS, ipc_get_f64)
R_STATUS_GETTER(remote_fmi2GetIntegerStatus, fmi2Integer, CALL_GET_INTEGER_STATUS, ipc_get_i32)
R_STATUS_GETTER(remote_fmi2GetBooleanStatus, fmi2Boolean, CALL_GET_BOOLEAN_STATUS, ipc_get_i32)
#undef R_STATUS_GETTER
static fmi2Status remote_fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind k, fmi2String *v)
{
    IpcBuf a; Remote *r = NULL;
    fmi2Status s = r_status(c, CALL_GET_STRING_STATUS, k, &a, &r);
    if (s <= fmi2Warning && v && keep_strings(r, &a, 1, v) != 0) return fmi2Error;
    return s;
}

static fmi2Component remote_fmi2Instantiate_unused(fmi2String a, fmi2Type b, fmi2String c, fmi2String d,
                                                    const fmi2CallbackFunctions *e, fmi2Boolean f, fmi2Boolean g)
{
    (void)a; (void)b; (void)c; (void)d; (void)e; (void)f; (void)g;
    return NULL;   /* remote instances start with remote_instantiate */
}

const Fmi2Table REMOTE_TABLE = {
    remote_fmi2Instantiate_unused,
    remote_free,
    remote_fmi2GetString,
#define X_REMOTE(name, params, args) remote_##name,
    FMI2_FORWARDED(X_REMOTE)
#undef X_REMOTE
};
