/* The shared-memory protocol between the loader (in the host process) and the model's own
 * process (fmi2_server.c), used when the host cannot share its Python with the FMU's runtime
 * (another Python version), or when asked to (SPURDIFF_FMU_PROCESS=out).
 *
 * One memfd per instance, mapped by both: a header page, a log area, a data area. One call at a
 * time (FMI 2.0 allows one thread per instance at a time): the host writes the call and its
 * arguments into `data`, increments `req` and wakes the server; the server answers in `data`
 * (status first, then the results), appends the log records its model emitted to the log area,
 * sets `resp = req` and wakes the host. Both sides spin a short while before sleeping on a futex
 * (while spinning pays: IpcSpin), so a round trip costs microseconds. Values are in the host's
 * byte order.
 * Deferred calls (fmi2_remote_batch.c) stand at the start of `data` (`pre_len` bytes: records of
 * i32 call, then the call's arguments, each record 8-byte aligned), the call after them; the
 * server serves them first, in order.
 */
#ifndef SPURDIFF_IPC_H
#define SPURDIFF_IPC_H

#include <stdatomic.h>
#include <stdint.h>
#include <stddef.h>
#include <string.h>

#define IPC_MAGIC 0x53504950u     /* "SPIP" */
#define IPC_VERSION 5u
#define IPC_HEADER 4096u
#define IPC_LOG_CAP (1u << 20)
#define IPC_DATA_CAP ((size_t)63 << 20)
#define IPC_SIZE ((size_t)IPC_HEADER + IPC_LOG_CAP + IPC_DATA_CAP)
#define IPC_SHM_FD 3              /* the server's inherited descriptors */
#define IPC_PIPE_FD 4             /* read end: end of file when the host process is gone */
#define ZYGOTE_SOCK_FD 3          /* the zygote's (fmi2_server.c --zygote): its socket to the loader */

enum {
    CALL_INSTANTIATE = 1, CALL_FREE, CALL_SET_DEBUG_LOGGING, CALL_SETUP_EXPERIMENT, CALL_ENTER_INIT,
    CALL_EXIT_INIT, CALL_TERMINATE, CALL_RESET, CALL_GET_REAL, CALL_GET_INTEGER, CALL_GET_BOOLEAN,
    CALL_GET_STRING, CALL_SET_REAL, CALL_SET_INTEGER, CALL_SET_BOOLEAN, CALL_SET_STRING,
    CALL_GET_STATE, CALL_SET_STATE, CALL_FREE_STATE, CALL_STATE_SIZE, CALL_SERIALIZE, CALL_DESERIALIZE,
    CALL_DIRECTIONAL_DERIVATIVE, CALL_SET_INPUT_DERIVATIVES, CALL_GET_OUTPUT_DERIVATIVES, CALL_DO_STEP,
    CALL_CANCEL_STEP, CALL_GET_STATUS, CALL_GET_REAL_STATUS, CALL_GET_INTEGER_STATUS,
    CALL_GET_BOOLEAN_STATUS, CALL_GET_STRING_STATUS, CALL_PING,
    CALL_DO_STEP_EARLY,   /* the bridge's FMI 3.0 extension spurdiffDoStepEarly */
    CALL_NATIVE_EXPORT,   /* the hand-over of the native step to the host (fmi2_loader.c) and back */
    CALL_NATIVE_IMPORT,
    CALL_START_SNAPSHOT,  /* the model's native start of the values set (the start cache, fmi2_loader.c) */
    N_CALLS
};

typedef struct {
    uint32_t magic, version;
    _Atomic uint32_t req;            /* host: +1 after writing a call */
    _Atomic uint32_t resp;           /* server: = req after writing the answer */
    _Atomic uint32_t server_sleeps;  /* the server waits (or is about to) on req */
    _Atomic uint32_t host_sleeps;    /* the host waits (or is about to) on resp */
    uint32_t call;
    int32_t status;
    uint64_t len;                    /* bytes of the call, then of the answer, in data */
    uint64_t pre_len;                /* bytes of deferred calls before the call in data */
    uint64_t log_len;                /* bytes of log records in the log area */
    uint32_t log_dropped;            /* records that did not fit */
    _Atomic int32_t ended;           /* the zygote, once it reaped this instance's process: 1 */
    int32_t wait_status;             /* ... and that process's waitpid status */
} IpcHeader;

static inline unsigned char *ipc_log(void *base) { return (unsigned char *)base + IPC_HEADER; }
static inline unsigned char *ipc_data(void *base) { return (unsigned char *)base + IPC_HEADER + IPC_LOG_CAP; }

/* ---------------------------------------------------------------------------- (de)serializing */
typedef struct {
    unsigned char *p;
    size_t cap, pos;
    int bad;                         /* overflow or a malformed message */
} IpcBuf;

#define IPC_NULL_STR UINT64_MAX

static inline void ipc_put(IpcBuf *b, const void *v, size_t n)
{
    if (b->bad || n > b->cap - b->pos) { b->bad = 1; return; }
    if (n) memcpy(b->p + b->pos, v, n);
    b->pos += n;
}
static inline void ipc_u64(IpcBuf *b, uint64_t v) { ipc_put(b, &v, sizeof v); }
static inline void ipc_i32(IpcBuf *b, int32_t v) { ipc_put(b, &v, sizeof v); }
static inline void ipc_f64(IpcBuf *b, double v) { ipc_put(b, &v, sizeof v); }
static inline void ipc_str(IpcBuf *b, const char *s)
{
    if (!s) { ipc_u64(b, IPC_NULL_STR); return; }
    size_t n = strlen(s);
    ipc_u64(b, n);
    ipc_put(b, s, n);
}

static inline const void *ipc_take(IpcBuf *b, size_t n)
{
    if (b->bad || n > b->cap - b->pos) { b->bad = 1; return NULL; }
    const void *p = b->p + b->pos;
    b->pos += n;
    return p;
}
/* ipc_get_u64, ipc_get_i32, ipc_get_f64: the next value, or 0 (and `bad` set) past the end */
#define IPC_GETTER(name, type)                                                                     \
    static inline type name(IpcBuf *b)                                                             \
    {                                                                                              \
        type v = 0;                                                                                \
        const void *p = ipc_take(b, sizeof v);                                                     \
        if (p) memcpy(&v, p, sizeof v);                                                            \
        return v;                                                                                  \
    }
IPC_GETTER(ipc_get_u64, uint64_t)
IPC_GETTER(ipc_get_i32, int32_t)
IPC_GETTER(ipc_get_f64, double)
#undef IPC_GETTER
/* Arrays start at a multiple of 8 bytes, so the side that reads them gets aligned values. */
static inline void ipc_align(IpcBuf *b)
{
    static const unsigned char zero[8];
    size_t pad = (8 - (b->pos & 7)) & 7;
    if (pad) ipc_put(b, zero, pad);
}
static inline void ipc_put_array(IpcBuf *b, const void *v, size_t n, size_t size)
{
    ipc_align(b);
    if (n && !v) { b->bad = 1; return; }
    if (size && n > (SIZE_MAX / size)) { b->bad = 1; return; }
    ipc_put(b, v, n * size);
}
/* Past the padding ipc_align wrote (0, or -1 past the end). */
static inline int ipc_skip_align(IpcBuf *b)
{
    size_t pad = (8 - (b->pos & 7)) & 7;
    return (!ipc_take(b, pad) && pad) ? -1 : 0;
}
static inline const void *ipc_take_array(IpcBuf *b, size_t n, size_t size)
{
    if (ipc_skip_align(b) != 0) return NULL;
    if (size && n > (SIZE_MAX / size)) { b->bad = 1; return NULL; }
    return ipc_take(b, n * size);
}

/* A string as a pointer into the buffer and its length; NULL for a null string (len 0). The
 * bytes are not NUL-terminated: ipc_get_cstr copies. */
static inline const char *ipc_get_str(IpcBuf *b, size_t *len)
{
    uint64_t n = ipc_get_u64(b);
    *len = 0;
    if (b->bad || n == IPC_NULL_STR) return NULL;
    const char *p = (const char *)ipc_take(b, (size_t)n);
    if (p) *len = (size_t)n;
    return p;
}

/* ---------------------------------------------------------------------------- waiting */

#include <linux/futex.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

static inline long ipc_futex_wait(_Atomic uint32_t *addr, uint32_t expected, long timeout_ns)
{
    struct timespec ts = {timeout_ns / 1000000000L, timeout_ns % 1000000000L};
    return syscall(SYS_futex, (uint32_t *)addr, FUTEX_WAIT, expected, &ts, NULL, 0);
}
static inline void ipc_futex_wake(_Atomic uint32_t *addr)
{
    syscall(SYS_futex, (uint32_t *)addr, FUTEX_WAKE, 1, NULL, NULL, 0);
}
static inline uint64_t ipc_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}
static inline void ipc_pause(void)
{
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#elif defined(__aarch64__)
    __asm__ __volatile__("yield");
#endif
}

/* How long a side spins before it sleeps. Spinning saves the futex's wake-up when the other side
 * runs on another core, and takes a core the other side may be waiting for when the machine has
 * more runnable processes than cores: so the budget follows what it bought. A change seen while
 * spinning after w ns sets it to 4 w (at least 2 us, at most max_ns); a wait that had to sleep
 * leaves a quarter (none below 1 us); without one, every 64th wait spins max_ns / 2 to find out
 * whether spinning pays again. */
typedef struct {
    uint64_t max_ns, spin_ns;
    unsigned waits;
} IpcSpin;

/* Wait until *word != old: spin (see IpcSpin), then sleep on the futex (flag `sleeps` set while
 * asleep) in slices of `slice_ns`, calling `alive(ctx)` after each slice: it returns 0 to stop
 * waiting. Returns 0 when the word changed, -1 when alive() said stop. */
static inline int ipc_wait_change(_Atomic uint32_t *word, uint32_t old, _Atomic uint32_t *sleeps, IpcSpin *spin,
                                  long slice_ns, int (*alive)(void *), void *ctx)
{
    uint64_t budget = spin->spin_ns;
    if (!budget && (++spin->waits & 63) == 0) budget = spin->max_ns / 2;
    if (budget) {
        uint64_t start = ipc_now_ns();
        for (unsigned i = 1;; i++) {
            if (atomic_load_explicit(word, memory_order_acquire) != old) {
                uint64_t w = 4 * (ipc_now_ns() - start);
                spin->spin_ns = w < 2000 ? 2000 : w < spin->max_ns ? w : spin->max_ns;
                return 0;
            }
            ipc_pause();
            if ((i & 15) == 0 && ipc_now_ns() - start > budget) break;
        }
    }
    spin->spin_ns = budget / 4 >= 1000 ? budget / 4 : 0;
    for (;;) {
        atomic_store(sleeps, 1);
        if (atomic_load(word) != old) { atomic_store(sleeps, 0); return 0; }
        ipc_futex_wait(word, old, slice_ns);
        atomic_store(sleeps, 0);
        if (atomic_load_explicit(word, memory_order_acquire) != old) return 0;
        if (alive && !alive(ctx)) return -1;
    }
}

/* Publish a new value of *word and wake the other side if it sleeps. */
static inline void ipc_publish(_Atomic uint32_t *word, uint32_t value, _Atomic uint32_t *sleeps)
{
    atomic_store_explicit(word, value, memory_order_seq_cst);
    if (atomic_load(sleeps)) ipc_futex_wake(word);
}

#endif
