/* The round trips a host's step loop need not make to the model's own process (fmi2_remote.c):
 * a master's communication step is fmi2SetReal (inputs), fmi2DoStep, fmi2GetReal (outputs), three
 * wake-ups of the other process, and on a machine with more runnable processes than cores each
 * waits for the scheduler. Here the three become one, and nothing a host can see changes:
 *
 * - fmi2SetReal is deferred when the model is in Step Mode and every reference is one the model
 *   took with fmi2OK and no message in Step Mode before (an input or a tunable parameter: it
 *   stores the value and answers fmi2OK, whatever the value; an input out of its range is refused
 *   by the next fmi2DoStep naming it, in this process as in the host's). The call is written at the
 *   start of the shared data area and goes with the next call of any kind, which the model's
 *   process serves after it (fmi2_server.c); should it fail there after all, that call reports it
 *   through the logger naming the value references, with its status.
 * - fmi2DoStep's request names the Real references fmi2GetReal asked for after earlier steps, and
 *   its answer carries their values read right after the step; fmi2GetReal of those answers from
 *   them until any call that may change a value (a setter, a step, fmi2Reset, fmi2SetFMUstate,
 *   initialization, fmi2Terminate...). Any other reference is asked for as before.
 * What is learned is only what the model answered fmi2OK without a message, so a call that would
 * fail or log in the host's process is still sent and fails or logs at that call.
 */
#include <stdlib.h>
#include <string.h>

#include "fmi2_remote_batch.h"

static int cmp_vr(const void *a, const void *b)
{
    fmi2ValueReference x = *(const fmi2ValueReference *)a, y = *(const fmi2ValueReference *)b;
    return (x > y) - (x < y);
}

static int is_settable(const Batch *b, fmi2ValueReference vr)
{
    return bsearch(&vr, b->settable, b->n_settable, sizeof vr, cmp_vr) != NULL;
}

/* The position of vr among the references brought back, or -1 (starting at the hint: a host asks
 * in the same order every step). */
static long want_index(Batch *b, fmi2ValueReference vr)
{
    for (size_t k = 0; k < b->n_want; k++) {
        size_t i = (b->hint + k) % b->n_want;
        if (b->want[i] == vr) {
            b->hint = i + 1;
            return (long)i;
        }
    }
    return -1;
}

int batch_defer_set(Batch *b, unsigned char *data, const fmi2ValueReference vr[], size_t n, const fmi2Real v[])
{
    if (!b->stepping) return 0;
    for (size_t i = 0; i < n; i++)
        if (!is_settable(b, vr[i])) return 0;
    IpcBuf w = {data, BATCH_PRE_CAP, b->pre_len, 0};
    ipc_i32(&w, CALL_SET_REAL);
    ipc_u64(&w, n);
    ipc_put_array(&w, vr, n, sizeof *vr);
    ipc_put_array(&w, v, n, sizeof *v);
    ipc_align(&w);
    if (w.bad) return 0;   /* no room: sent now, with the ones before it */
    b->pre_len = w.pos;
    b->fresh = b->valid = 0;
    return 1;
}

int batch_get(Batch *b, const fmi2ValueReference vr[], size_t n, fmi2Real v[])
{
    if (!b->valid) return 0;
    for (size_t i = 0; i < n; i++) {
        long k = want_index(b, vr[i]);
        if (k < 0) return 0;
        v[i] = b->val[k];
    }
    return 1;
}

void batch_learn(Batch *b, uint32_t call, fmi2Status s, int logged, const fmi2ValueReference vr[], size_t n)
{
    if (s != fmi2OK || logged) return;
    if (call == CALL_SET_REAL && b->stepping) {
        for (size_t i = 0; i < n && b->n_settable < BATCH_MAX_VRS; i++) {
            if (is_settable(b, vr[i])) continue;
            b->settable[b->n_settable++] = vr[i];
            qsort(b->settable, b->n_settable, sizeof *b->settable, cmp_vr);
        }
    } else if (call == CALL_GET_REAL && b->fresh) {
        for (size_t i = 0; i < n && b->n_want < BATCH_MAX_VRS; i++) {
            size_t hint = b->hint;
            if (want_index(b, vr[i]) < 0) b->want[b->n_want++] = vr[i];
            b->hint = hint;
        }
    }
}

void batch_answered(Batch *b, uint32_t call, fmi2Status s)
{
    switch (call) {   /* the calls that change no value of the model */
    case CALL_GET_REAL: case CALL_GET_INTEGER: case CALL_GET_BOOLEAN: case CALL_GET_STRING:
    case CALL_GET_STATE: case CALL_FREE_STATE: case CALL_STATE_SIZE: case CALL_SERIALIZE: case CALL_DESERIALIZE:
    case CALL_GET_STATUS: case CALL_GET_REAL_STATUS: case CALL_GET_INTEGER_STATUS: case CALL_GET_BOOLEAN_STATUS:
    case CALL_GET_STRING_STATUS: case CALL_PING:
        break;
    default:
        b->fresh = b->valid = 0;
    }
    switch (call) {   /* Step Mode: entered, left, or not known any more */
    case CALL_EXIT_INIT:
        b->stepping = s <= fmi2Warning;
        break;
    case CALL_DO_STEP: case CALL_DO_STEP_EARLY:
        b->stepping = s <= fmi2Discard;   /* a step is refused with fmi2Error in any other mode */
        break;
    case CALL_INSTANTIATE: case CALL_FREE: case CALL_SETUP_EXPERIMENT: case CALL_ENTER_INIT: case CALL_TERMINATE:
    case CALL_RESET: case CALL_SET_STATE:
        b->stepping = 0;
        break;
    case CALL_SET_DEBUG_LOGGING:   /* the model may say more now: learn again */
        b->n_settable = b->n_want = b->hint = 0;
        break;
    default:
        if (s > fmi2Discard) b->stepping = 0;
    }
}

void batch_put_want(const Batch *b, IpcBuf *req)
{
    ipc_u64(req, b->n_want);
    ipc_put_array(req, b->want, b->n_want, sizeof *b->want);
}

void batch_take_values(Batch *b, IpcBuf *ans)
{
    int32_t got = ipc_get_i32(ans);
    const void *q = got ? ipc_take_array(ans, b->n_want, sizeof *b->val) : NULL;
    b->fresh = b->stepping;
    b->valid = 0;
    if (!q || !b->stepping) return;
    memcpy(b->val, q, b->n_want * sizeof *b->val);
    b->valid = 1;
}
