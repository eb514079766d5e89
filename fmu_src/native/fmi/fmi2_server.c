/* The model's own process: binaries/<platform>/spurdiff_fmu_server RESOURCES BINDIR.
 *
 * Started by the loader (fmi2_remote.c) when the host cannot share its Python with the FMU's
 * runtime: forked by the zygote of the host process and FMU folder (`--zygote`, below), or started
 * directly (SPURDIFF_FMU_ZYGOTE=0, or a zygote that failed). It inherits the shared memory (fd 3, see ipc.h) and the read end of a pipe whose write
 * end only the host holds (fd 4), loads the runtime and the bridge in this process
 * (fmi2_inproc.c, the same code a C host runs in process), and serves one instance's FMI calls
 * until fmi2FreeInstance, or until the host process is gone (the pipe reads end of file: the
 * host exited, failed or was killed), whichever comes first. It never outlives its host.
 * The host's deferred fmi2SetReal calls come before the call they go with, and are served first
 * (serve_deferred); fmi2DoStep's answer carries the values of the Real references the host named
 * with it, read right after the step (bring_back), so that its fmi2GetReal needs no round trip.
 * The loader may take the model's compiled step into the host's process (CALL_NATIVE_EXPORT: the
 * arrays of the step, fmi2_loader.c) and give it back before any other call (CALL_NATIVE_IMPORT).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <poll.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include "fmi2_inproc.h"
#include "ipc.h"

static IpcHeader *H;
static void *BASE;
static const Fmi2Table *T;
static fmi2Component C;
static fmi2FMUstate *states;     /* id - 1 -> the bridge's state */
static size_t n_states, cap_states;

/* ---------------------------------------------------------------------------- the host's side */
static pid_t HOST_PID;          /* the parent that started this process: the host */

static int host_alive(void *ctx)
{
    (void)ctx;
    if (getppid() != HOST_PID) return 0;   /* the host died (a fork of it may still hold the pipe) */
    struct pollfd p = {IPC_PIPE_FD, POLLIN, 0};
    int r = poll(&p, 1, 0);
    if (r < 0) return errno == EINTR;
    if (r == 0) return 1;
    char c;
    return !(p.revents & (POLLHUP | POLLERR | POLLNVAL)) && read(IPC_PIPE_FD, &c, 1) > 0;
}

/* The model's log records, passed to the host with the answer (see fmi2_remote.c: replay). */
static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...)
{
    (void)env; (void)name;
    char text[16384];
    va_list ap;
    va_start(ap, message);
    vsnprintf(text, sizeof text, message ? message : "", ap);
    va_end(ap);
    IpcBuf b = {ipc_log(BASE), IPC_LOG_CAP, (size_t)H->log_len, 0};
    ipc_i32(&b, (int32_t)status);
    ipc_str(&b, category ? category : "logAll");
    ipc_str(&b, text);
    if (b.bad) H->log_dropped++;
    else H->log_len = b.pos;
}

static const fmi2CallbackFunctions CALLBACKS = {logger, calloc, free, NULL, NULL};

/* ---------------------------------------------------------------------------- states */
static uint64_t state_id(fmi2FMUstate s)
{
    for (size_t i = 0; i < n_states; i++)
        if (states[i] == s) return i + 1;
    for (size_t i = 0; i < n_states; i++)
        if (!states[i]) { states[i] = s; return i + 1; }
    if (n_states == cap_states) {
        size_t cap = cap_states ? 2 * cap_states : 16;
        fmi2FMUstate *more = (fmi2FMUstate *)realloc(states, cap * sizeof *more);
        if (!more) return 0;
        states = more;
        cap_states = cap;
    }
    states[n_states++] = s;
    return n_states;
}

static fmi2FMUstate state_of(uint64_t id) { return (id >= 1 && id <= n_states) ? states[id - 1] : NULL; }

/* ---------------------------------------------------------------------------- one call */
static void *scratch;
static size_t scratch_cap;

static void *scratch_for(size_t n)
{
    if (n > scratch_cap) {
        void *p = realloc(scratch, n);
        if (!p) return NULL;
        scratch = p;
        scratch_cap = n;
    }
    return scratch;
}

static void free_strings(char **v, size_t n)
{
    for (size_t i = 0; v && i < n; i++) free(v[i]);
    free(v);
}

/* n strings of the request (each NULL or a copy), or NULL (no memory, or the request ended) */
static char **take_strings(IpcBuf *in, size_t n)
{
    char **v = (char **)calloc(n ? n : 1, sizeof *v);
    for (size_t i = 0, len; v && i < n; i++) {
        const char *p = ipc_get_str(in, &len);
        v[i] = p ? strndup(p, len) : NULL;
    }
    if (v && in->bad) { free_strings(v, n); v = NULL; }
    return v;
}

/* After a step: the values of the `n` Real references the host will ask for (fmi2_remote_batch.c)
 * as i32 1 and the array, when the step ended with at most fmi2Discard and reading them was
 * fmi2OK and silent; else i32 0 (the read's messages dropped: the host asks, and hears them, then). */
static void bring_back(fmi2Status step, const fmi2ValueReference *vr, size_t n, IpcBuf *out)
{
    uint64_t log_len = H->log_len;
    uint32_t dropped = H->log_dropped;
    fmi2Real *v = step <= fmi2Discard ? (fmi2Real *)scratch_for(n * sizeof *v + 8) : NULL;
    int ok = v && (!n || T->fmi2GetReal(C, vr, n, v) == fmi2OK) && H->log_len == log_len && H->log_dropped == dropped;
    if (!ok) { H->log_len = log_len; H->log_dropped = dropped; }
    ipc_i32(out, ok);
    if (ok) ipc_put_array(out, v, n, sizeof *v);
}

/* An answer of bytes the bridge made (kind 1, freed here), or none (kind 0 / -1): i32 kind, u64 length,
 * the bytes. */
static void put_bytes(IpcBuf *out, int kind, unsigned char *bytes, size_t n)
{
    ipc_i32(out, kind);
    ipc_u64(out, kind == 1 ? n : 0);
    if (kind == 1) ipc_put_array(out, bytes, n, 1);
    free(bytes);
}

/* Serve the call in `in` (a private copy of the request); the answer goes to the shared data
 * area `out`. Its status; *bye = 1 after fmi2FreeInstance (the server then exits). */
static fmi2Status serve(uint32_t call, IpcBuf *in, IpcBuf *out, int *bye)
{
    fmi2Status s = fmi2Error;
    size_t n, len;
    if (!C && call != CALL_INSTANTIATE && call != CALL_PING && call != CALL_FREE) {
        logger(NULL, "", fmi2Error, "logStatusError", "the model's process has no instance");
        return fmi2Error;
    }
    switch (call) {
    case CALL_PING:
        s = fmi2OK;
        break;
    case CALL_INSTANTIATE: {
        char name[4096], guid[4096], res[PATH_MAX];
        const char *p;
        p = ipc_get_str(in, &len); snprintf(name, sizeof name, "%.*s", (int)len, p ? p : "");
        int32_t type = ipc_get_i32(in);
        p = ipc_get_str(in, &len); snprintf(guid, sizeof guid, "%.*s", (int)len, p ? p : "");
        p = ipc_get_str(in, &len); snprintf(res, sizeof res, "%.*s", (int)len, p ? p : "");
        int32_t visible = ipc_get_i32(in), logging = ipc_get_i32(in);
        if (in->bad || C) break;
        C = T->fmi2Instantiate(name, (fmi2Type)type, guid, res, &CALLBACKS, visible, logging);
        s = C ? fmi2OK : fmi2Error;
        break;
    }
    case CALL_FREE:
        if (C) T->fmi2FreeInstance(C);
        C = NULL;
        s = fmi2OK;
        *bye = 1;
        break;
    case CALL_SET_DEBUG_LOGGING: {
        int32_t on = ipc_get_i32(in);
        n = (size_t)ipc_get_u64(in);
        if (in->bad || n > 4096) break;
        char **cats = take_strings(in, n);
        if (cats) s = T->fmi2SetDebugLogging(C, on, n, (const fmi2String *)cats);
        free_strings(cats, n);
        break;
    }
    case CALL_SETUP_EXPERIMENT: {
        int32_t td = ipc_get_i32(in);
        double tol = ipc_get_f64(in), t0 = ipc_get_f64(in);
        int32_t sd = ipc_get_i32(in);
        double t1 = ipc_get_f64(in);
        if (!in->bad) s = T->fmi2SetupExperiment(C, td, tol, t0, sd, t1);
        break;
    }
    case CALL_ENTER_INIT: s = T->fmi2EnterInitializationMode(C); break;
    case CALL_EXIT_INIT: s = T->fmi2ExitInitializationMode(C); break;
    case CALL_TERMINATE: s = T->fmi2Terminate(C); break;
    case CALL_RESET: s = T->fmi2Reset(C); break;
    case CALL_CANCEL_STEP: s = T->fmi2CancelStep(C); break;
    case CALL_GET_REAL: case CALL_GET_INTEGER: case CALL_GET_BOOLEAN: {
        n = (size_t)ipc_get_u64(in);
        const fmi2ValueReference *vr = (const fmi2ValueReference *)ipc_take_array(in, n, sizeof *vr);
        if (in->bad) break;
        size_t size = call == CALL_GET_REAL ? sizeof(fmi2Real) : sizeof(fmi2Integer);
        void *v = scratch_for(n * size + 8);
        if (!v) break;
        s = call == CALL_GET_REAL ? T->fmi2GetReal(C, vr, n, (fmi2Real *)v)
          : call == CALL_GET_INTEGER ? T->fmi2GetInteger(C, vr, n, (fmi2Integer *)v)
          : T->fmi2GetBoolean(C, vr, n, (fmi2Boolean *)v);
        if (s <= fmi2Warning) ipc_put_array(out, v, n, size);
        break;
    }
    case CALL_GET_STRING: {
        n = (size_t)ipc_get_u64(in);
        const fmi2ValueReference *vr = (const fmi2ValueReference *)ipc_take_array(in, n, sizeof *vr);
        if (in->bad) break;
        fmi2String *v = (fmi2String *)scratch_for(n * sizeof *v + 8);
        if (!v) break;
        s = T->fmi2GetString(C, vr, n, v);
        if (s <= fmi2Warning)
            for (size_t i = 0; i < n; i++) ipc_str(out, v[i]);
        break;
    }
    case CALL_SET_REAL: case CALL_SET_INTEGER: case CALL_SET_BOOLEAN: {
        n = (size_t)ipc_get_u64(in);
        const fmi2ValueReference *vr = (const fmi2ValueReference *)ipc_take_array(in, n, sizeof *vr);
        size_t size = call == CALL_SET_REAL ? sizeof(fmi2Real) : sizeof(fmi2Integer);
        const void *v = ipc_take_array(in, n, size);
        if (in->bad) break;
        s = call == CALL_SET_REAL ? T->fmi2SetReal(C, vr, n, (const fmi2Real *)v)
          : call == CALL_SET_INTEGER ? T->fmi2SetInteger(C, vr, n, (const fmi2Integer *)v)
          : T->fmi2SetBoolean(C, vr, n, (const fmi2Boolean *)v);
        break;
    }
    case CALL_SET_STRING: {
        n = (size_t)ipc_get_u64(in);
        const fmi2ValueReference *vr = (const fmi2ValueReference *)ipc_take_array(in, n, sizeof *vr);
        if (in->bad || n > IPC_DATA_CAP / 8) break;
        char **v = take_strings(in, n);
        if (v) s = T->fmi2SetString(C, vr, n, (const fmi2String *)v);
        free_strings(v, n);
        break;
    }
    case CALL_GET_STATE: {
        fmi2FMUstate st = state_of(ipc_get_u64(in));
        if (in->bad) break;
        s = T->fmi2GetFMUstate(C, &st);
        uint64_t id = (s <= fmi2Warning && st) ? state_id(st) : 0;
        if (s <= fmi2Warning && !id) s = fmi2Error;
        ipc_u64(out, id);
        break;
    }
    case CALL_SET_STATE: {
        fmi2FMUstate st = state_of(ipc_get_u64(in));
        if (!in->bad) s = T->fmi2SetFMUstate(C, st);
        break;
    }
    case CALL_FREE_STATE: {
        uint64_t id = ipc_get_u64(in);
        fmi2FMUstate st = state_of(id);
        if (in->bad) break;
        s = T->fmi2FreeFMUstate(C, &st);
        if (s <= fmi2Warning && id >= 1 && id <= n_states) states[id - 1] = NULL;
        break;
    }
    case CALL_STATE_SIZE: {
        fmi2FMUstate st = state_of(ipc_get_u64(in));
        size_t size = 0;
        if (in->bad) break;
        s = T->fmi2SerializedFMUstateSize(C, st, &size);
        ipc_u64(out, size);
        break;
    }
    case CALL_SERIALIZE: {
        fmi2FMUstate st = state_of(ipc_get_u64(in));
        n = (size_t)ipc_get_u64(in);
        if (in->bad || n > IPC_DATA_CAP - 64) break;
        fmi2Byte *v = (fmi2Byte *)scratch_for(n + 8);
        if (!v) break;
        s = T->fmi2SerializeFMUstate(C, st, v, n);
        if (s <= fmi2Warning) ipc_put_array(out, v, n, 1);
        break;
    }
    case CALL_DESERIALIZE: {
        n = (size_t)ipc_get_u64(in);
        const fmi2Byte *v = (const fmi2Byte *)ipc_take_array(in, n, 1);
        fmi2FMUstate st = NULL;
        if (in->bad) break;
        s = T->fmi2DeSerializeFMUstate(C, v, n, &st);
        uint64_t id = (s <= fmi2Warning && st) ? state_id(st) : 0;
        if (s <= fmi2Warning && !id) s = fmi2Error;
        ipc_u64(out, id);
        break;
    }
    case CALL_DIRECTIONAL_DERIVATIVE: {
        size_t nu = (size_t)ipc_get_u64(in);
        const fmi2ValueReference *u = (const fmi2ValueReference *)ipc_take_array(in, nu, sizeof *u);
        size_t nz = (size_t)ipc_get_u64(in);
        const fmi2ValueReference *z = (const fmi2ValueReference *)ipc_take_array(in, nz, sizeof *z);
        const fmi2Real *du = (const fmi2Real *)ipc_take_array(in, nu, sizeof *du);
        if (in->bad) break;
        fmi2Real *dz = (fmi2Real *)scratch_for(nz * sizeof *dz + 8);
        if (!dz) break;
        s = T->fmi2GetDirectionalDerivative(C, u, nu, z, nz, du, dz);
        if (s <= fmi2Warning) ipc_put_array(out, dz, nz, sizeof *dz);
        break;
    }
    case CALL_SET_INPUT_DERIVATIVES: case CALL_GET_OUTPUT_DERIVATIVES: {
        n = (size_t)ipc_get_u64(in);
        const fmi2ValueReference *vr = (const fmi2ValueReference *)ipc_take_array(in, n, sizeof *vr);
        const fmi2Integer *order = (const fmi2Integer *)ipc_take_array(in, n, sizeof *order);
        if (call == CALL_SET_INPUT_DERIVATIVES) {
            const fmi2Real *v = (const fmi2Real *)ipc_take_array(in, n, sizeof *v);
            if (!in->bad) s = T->fmi2SetRealInputDerivatives(C, vr, n, order, v);
        } else if (!in->bad) {
            fmi2Real *v = (fmi2Real *)scratch_for(n * sizeof *v + 8);
            if (!v) break;
            s = T->fmi2GetRealOutputDerivatives(C, vr, n, order, v);
            if (s <= fmi2Warning) ipc_put_array(out, v, n, sizeof *v);
        }
        break;
    }
    case CALL_DO_STEP: case CALL_DO_STEP_EARLY: {   /* then the references to bring back */
        double t = ipc_get_f64(in), h = ipc_get_f64(in);
        int32_t nsp = ipc_get_i32(in);
        n = (size_t)ipc_get_u64(in);
        const fmi2ValueReference *vr = (const fmi2ValueReference *)ipc_take_array(in, n, sizeof *vr);
        fmi2Real end = t;
        if (in->bad) break;
        s = call == CALL_DO_STEP ? T->fmi2DoStep(C, t, h, nsp) : inproc_do_step_early(C, t, h, nsp, &end);
        if (call == CALL_DO_STEP_EARLY) ipc_f64(out, end);
        bring_back(s, vr, n, out);
        break;
    }
    case CALL_NATIVE_EXPORT: {   /* i32 1 and the bytes, or i32 0 (not now) / -1 (never), u64 0 */
        unsigned char *bytes = NULL;
        size_t nb = 0;
        int kind = inproc_native_export(C, &bytes, &nb);   /* (before the arguments below are read) */
        put_bytes(out, kind, bytes, nb);
        s = fmi2OK;
        break;
    }
    case CALL_START_SNAPSHOT: {   /* i32 1, u64 length and the bytes; or i32 0 / -1, u64 0 */
        n = (size_t)ipc_get_u64(in);
        const unsigned char *sets = (const unsigned char *)ipc_take_array(in, n, 1);
        if (in->bad) break;
        unsigned char *bytes = NULL;
        size_t nb = 0;
        int kind = inproc_start_snapshot(C, sets, n, &bytes, &nb);
        put_bytes(out, kind, bytes, nb);
        s = fmi2OK;
        break;
    }
    case CALL_NATIVE_IMPORT: {
        n = (size_t)ipc_get_u64(in);
        const double *v = (const double *)ipc_take_array(in, n, sizeof *v);
        double time = ipc_get_f64(in);
        int32_t bad = ipc_get_i32(in);
        uint64_t steps = ipc_get_u64(in);
        if (in->bad) break;
        s = inproc_native_import(C, v, n, time, bad, (long)steps);
        break;
    }
    case CALL_GET_STATUS: case CALL_GET_REAL_STATUS: case CALL_GET_INTEGER_STATUS:
    case CALL_GET_BOOLEAN_STATUS: case CALL_GET_STRING_STATUS: {
        fmi2StatusKind k = (fmi2StatusKind)ipc_get_i32(in);
        if (in->bad) break;
        if (call == CALL_GET_STATUS) { fmi2Status v = fmi2OK; s = T->fmi2GetStatus(C, k, &v); ipc_i32(out, v); }
        else if (call == CALL_GET_REAL_STATUS) { fmi2Real v = 0; s = T->fmi2GetRealStatus(C, k, &v); ipc_f64(out, v); }
        else if (call == CALL_GET_INTEGER_STATUS) { fmi2Integer v = 0; s = T->fmi2GetIntegerStatus(C, k, &v); ipc_i32(out, v); }
        else if (call == CALL_GET_BOOLEAN_STATUS) { fmi2Boolean v = 0; s = T->fmi2GetBooleanStatus(C, k, &v); ipc_i32(out, v); }
        else { fmi2String v = NULL; s = T->fmi2GetStringStatus(C, k, &v); ipc_str(out, s <= fmi2Warning ? v : NULL); }
        break;
    }
    default:
        logger(NULL, "", fmi2Error, "logStatusError", "the model's process got an unknown call");
        break;
    }
    if (in->bad && s == fmi2Error)
        logger(NULL, "", fmi2Error, "logStatusError", "the model's process got a malformed call");
    if (out->bad) {   /* the answer did not fit */
        logger(NULL, "", fmi2Error, "logStatusError", "the answer is larger than the shared memory's data area");
        s = fmi2Error;
        out->pos = 0;
        out->bad = 0;
    }
    return s;
}

static const char *status_name(fmi2Status s)
{
    static const char *names[] = {"fmi2OK", "fmi2Warning", "fmi2Discard", "fmi2Error", "fmi2Fatal", "fmi2Pending"};
    return s <= fmi2Pending ? names[s] : "an unknown status";
}

/* The host's deferred calls (fmi2SetReal only), in order, until one fails: the worst status. One
 * that did not answer fmi2OK is named with its value references; after one worse than fmi2Warning
 * the call they went with is not made (the host's call returns that status). */
static fmi2Status serve_deferred(IpcBuf *pre, uint32_t then)
{
    fmi2Status worst = fmi2OK;
    while (pre->pos < pre->cap && worst <= fmi2Warning) {
        if (ipc_get_i32(pre) != CALL_SET_REAL) pre->bad = 1;
        IpcBuf peek = *pre;
        size_t n = pre->bad ? 0 : (size_t)ipc_get_u64(&peek);
        const fmi2ValueReference *vr = (const fmi2ValueReference *)ipc_take_array(&peek, n, sizeof *vr);
        IpcBuf none = {NULL, 0, 0, 0};
        int bye = 0;
        fmi2Status s = pre->bad || peek.bad ? fmi2Error : serve(CALL_SET_REAL, pre, &none, &bye);
        if (pre->bad || ipc_skip_align(pre) != 0) {
            logger(NULL, "", fmi2Error, "logStatusError", "the model's process got a malformed deferred call");
            return fmi2Error;
        }
        if (s != fmi2OK) {
            char refs[256];
            size_t k = 0;
            for (size_t i = 0; i < n && k < sizeof refs - 16; i++)
                k += (size_t)snprintf(refs + k, sizeof refs - k, "%s%u", i ? ", " : "", vr[i]);
            char msg[512];
            snprintf(msg, sizeof msg, "fmi2SetReal of value reference%s %s%s (deferred by the loader to the next "
                     "call) returned %s%s", n == 1 ? "" : "s", refs, k < sizeof refs - 16 ? "" : ", ...",
                     status_name(s), s > fmi2Warning ? (then == CALL_FREE ? "" : "; the call after it is not made")
                     : "");
            logger(NULL, "", s, s > fmi2Warning ? "logStatusError" : "logStatusWarning", msg);
        }
        if (s > worst) worst = s;
    }
    return worst;
}

/* Serve one instance on the inherited shared memory and pipe (IPC_SHM_FD, IPC_PIPE_FD) until
 * fmi2FreeInstance or the host's end; `loaded` 0: every call answers `err`. The exit status. */
static int serve_instance(int loaded, const char *err)
{
    BASE = mmap(NULL, IPC_SIZE, PROT_READ | PROT_WRITE, MAP_SHARED, IPC_SHM_FD, 0);
    if (BASE == MAP_FAILED) {
        fprintf(stderr, "spurdiff_fmu_server: no shared memory on fd %d: %s\n", IPC_SHM_FD, strerror(errno));
        return 2;
    }
    H = (IpcHeader *)BASE;
    if (H->magic != IPC_MAGIC || H->version != IPC_VERSION) {
        fprintf(stderr, "spurdiff_fmu_server: the shared memory is not this protocol's\n");
        return 2;
    }
    uint32_t seen = 0;
    IpcSpin spin = {50000, 50000, 0};   /* up to 50 us for the host's next call (while it pays) */
    for (;;) {
        if (ipc_wait_change(&H->req, seen, &H->server_sleeps, &spin, 100000000L, host_alive, NULL) != 0)
            return 0;   /* the host is gone */
        seen = atomic_load_explicit(&H->req, memory_order_acquire);
        int fits = H->pre_len <= IPC_DATA_CAP && H->len <= IPC_DATA_CAP - H->pre_len;
        size_t pre = fits ? (size_t)H->pre_len : 0, len = fits ? (size_t)H->len : 0;
        unsigned char *copy = pre + len ? (unsigned char *)malloc(pre + len) : NULL;
        if (pre + len && copy) memcpy(copy, ipc_data(BASE), pre + len);
        int bad = (pre + len && !copy) || !fits;
        IpcBuf deferred = {copy, copy ? pre : 0, 0, bad};
        IpcBuf in = {copy ? copy + pre : NULL, copy ? len : 0, 0, bad};
        IpcBuf out = {ipc_data(BASE), IPC_DATA_CAP, 0, 0};
        H->log_len = 0;
        H->log_dropped = 0;
        int bye = 0;
        if (!loaded) {
            logger(NULL, "", fmi2Error, "logStatusError", err);
            H->status = fmi2Error;
            bye = H->call == CALL_FREE;
        } else {
            fmi2Status s = pre ? serve_deferred(&deferred, H->call) : fmi2OK;
            if (s <= fmi2Warning || H->call == CALL_FREE) {
                fmi2Status m = serve(H->call, &in, &out, &bye);
                if (m > s) s = m;
            }
            H->status = (int32_t)s;
        }
        free(copy);
        H->len = out.pos;
        ipc_publish(&H->resp, seen, &H->host_sleeps);
        if (bye) return 0;
    }
}

/* ---------------------------------------------------------------------------- the zygote
 * spurdiff_fmu_server --zygote RESOURCES BINDIR: the model processes of one host process and FMU
 * folder, forked from one that started the runtime and imported the package once (an instance
 * made and freed: what every instance imports), so that the imported modules' memory is shared
 * between them (gc.freeze in the bridge's fork keeps it so) and a second instance starts without
 * importing anything. Started by the loader (fmi2_remote_spawn.c) with a socket on ZYGOTE_SOCK_FD
 * and the read end of a pipe only the host writes on IPC_PIPE_FD. Each request: one byte with an
 * instance's shared memory and pipe (SCM_RIGHTS); the answer: the forked process's pid (int32, or
 * -errno). The zygote reaps its processes and writes each one's wait status into its shared
 * memory's header (ended, wait_status: what the loader says when a process is gone). It ends when
 * the loader closes the socket (its last instance freed, or the loader unloaded) or the host is
 * gone; its processes then end too (their parent changed: host_alive). */
typedef struct { pid_t pid; IpcHeader *h; } Child;
static Child *children;
static size_t n_children, cap_children;
static int chld_pipe[2] = {-1, -1};

static void on_chld(int sig)
{
    (void)sig;
    int e = errno;
    if (chld_pipe[1] >= 0) { ssize_t w = write(chld_pipe[1], "c", 1); (void)w; }
    errno = e;
}

/* Reap the ended processes; each one's status goes to its header (the loader reads it). */
static void reap_children(void)
{
    int st;
    pid_t pid;
    while ((pid = waitpid(-1, &st, WNOHANG)) > 0) {
        for (size_t i = 0; i < n_children; i++) {
            if (children[i].pid != pid) continue;
            if (children[i].h) {
                children[i].h->wait_status = st;
                atomic_store(&children[i].h->ended, 1);
                munmap(children[i].h, IPC_HEADER);
            }
            children[i] = children[--n_children];
            break;
        }
    }
}

/* One request's two descriptors (shared memory, pipe): 1, 0 at end of file, -1 on error. */
static int take_request(int fds[2])
{
    char byte;
    struct iovec io = {&byte, 1};
    union { struct cmsghdr align; char buf[CMSG_SPACE(2 * sizeof(int))]; } u;
    struct msghdr m = {0};
    m.msg_iov = &io;
    m.msg_iovlen = 1;
    m.msg_control = u.buf;
    m.msg_controllen = sizeof u.buf;
    ssize_t n = recvmsg(ZYGOTE_SOCK_FD, &m, MSG_CMSG_CLOEXEC);
    if (n == 0) return 0;
    if (n < 0) return errno == EINTR || errno == EAGAIN ? -2 : -1;
    struct cmsghdr *c = CMSG_FIRSTHDR(&m);
    if (!c || c->cmsg_level != SOL_SOCKET || c->cmsg_type != SCM_RIGHTS || c->cmsg_len != CMSG_LEN(2 * sizeof(int)))
        return -1;
    memcpy(fds, CMSG_DATA(c), 2 * sizeof(int));
    return 1;
}

static void quiet(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                  fmi2String message, ...)
{
    (void)env; (void)name; (void)status; (void)category; (void)message;
}

static const fmi2CallbackFunctions QUIET = {quiet, calloc, free, NULL, NULL};

static int zygote(const char *resources, const char *bindir)
{
    char err[8192];
    RuntimeCfg cfg;
    HOST_PID = getppid();
    int have_cfg = cfg_read(resources, &cfg, err, sizeof err) == 0;
    int loaded = have_cfg && inproc_load(&cfg, resources, bindir, &T, err, sizeof err) == 0;
    if (loaded) {   /* what every instance imports, imported once (a failure is the instance's to say) */
        fmi2Component c = T->fmi2Instantiate("zygote", fmi2CoSimulation, cfg.guid, resources, &QUIET, fmi2False,
                                             fmi2False);
        if (c) T->fmi2FreeInstance(c);
    }
    if (pipe2(chld_pipe, O_CLOEXEC | O_NONBLOCK) != 0) return 2;
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_chld;
    sa.sa_flags = SA_RESTART | SA_NOCLDSTOP;
    sigaction(SIGCHLD, &sa, NULL);
    for (;;) {
        struct pollfd p[3] = {{ZYGOTE_SOCK_FD, POLLIN, 0}, {IPC_PIPE_FD, POLLIN, 0}, {chld_pipe[0], POLLIN, 0}};
        int r = poll(p, 3, 100);
        if (r < 0 && errno != EINTR) break;
        char drain[64];
        while (read(chld_pipe[0], drain, sizeof drain) > 0) {}
        reap_children();
        if (getppid() != HOST_PID) break;   /* the host is gone */
        if (r > 0 && (p[1].revents & (POLLHUP | POLLERR | POLLNVAL | POLLIN))) {
            char c;
            if (read(IPC_PIPE_FD, &c, 1) <= 0) break;   /* end of file: the host is gone */
        }
        if (r <= 0 || !(p[0].revents & (POLLIN | POLLHUP | POLLERR))) continue;
        int fds[2];
        int t = take_request(fds);
        if (t == -2) continue;
        if (t <= 0) break;   /* the loader closed its end: no instance of this FMU left in the host */
        if (n_children == cap_children) {
            size_t cap = cap_children ? 2 * cap_children : 16;
            Child *more = (Child *)realloc(children, cap * sizeof *more);
            if (more) { children = more; cap_children = cap; }
        }
        void *head = mmap(NULL, IPC_HEADER, PROT_READ | PROT_WRITE, MAP_SHARED, fds[0], 0);
        long pid = n_children < cap_children ? (loaded ? inproc_fork() : (long)fork()) : -1;
        int32_t answer = pid < 0 ? -(int32_t)ENOMEM : (int32_t)pid;
        if (pid == 0) {   /* the instance's process */
            signal(SIGCHLD, SIG_DFL);
            close(chld_pipe[0]);
            close(chld_pipe[1]);
            if (head != MAP_FAILED) munmap(head, IPC_HEADER);
            for (size_t i = 0; i < n_children; i++) if (children[i].h) munmap(children[i].h, IPC_HEADER);
            free(children);
            children = NULL;
            n_children = cap_children = 0;
            if (dup2(fds[0], IPC_SHM_FD) < 0 || dup2(fds[1], IPC_PIPE_FD) < 0) _exit(2);
            close(fds[0]);
            close(fds[1]);
            HOST_PID = getppid();   /* the zygote: it ends with the host */
            if (have_cfg) cfg_free(&cfg);
            exit(serve_instance(loaded, err));   /* as the directly started server returns from main */
        }
        if (pid > 0) {
            children[n_children].pid = (pid_t)pid;
            children[n_children].h = head != MAP_FAILED ? (IpcHeader *)head : NULL;
            n_children++;
        } else if (head != MAP_FAILED) {
            munmap(head, IPC_HEADER);
        }
        close(fds[0]);
        close(fds[1]);
        if (send(ZYGOTE_SOCK_FD, &answer, sizeof answer, MSG_NOSIGNAL) != (ssize_t)sizeof answer) break;
    }
    if (have_cfg) cfg_free(&cfg);
    return 0;
}

int main(int argc, char **argv)
{
    char err[8192];
    RuntimeCfg cfg;
    signal(SIGPIPE, SIG_IGN);
    if (argc == 4 && strcmp(argv[1], "--zygote") == 0)
        return zygote(argv[2], argv[3]);
    HOST_PID = getppid();
    if (argc != 3) {
        fprintf(stderr, "usage: spurdiff_fmu_server [--zygote] RESOURCES BINDIR (started by the FMU's loader)\n");
        return 2;
    }
    /* the runtime and the bridge; a failure is the answer to the first call */
    int loaded = cfg_read(argv[1], &cfg, err, sizeof err) == 0 &&
                 inproc_load(&cfg, argv[1], argv[2], &T, err, sizeof err) == 0;
    return serve_instance(loaded, err);
}
