/* The round trips a host's step loop need not make to the model's own process: deferred
 * fmi2SetReal and fmi2GetReal answered from the values fmi2DoStep brought back (see
 * fmi2_remote_batch.c; fmi2_remote.c calls these). */
#ifndef SPURDIFF_FMI2_REMOTE_BATCH_H
#define SPURDIFF_FMI2_REMOTE_BATCH_H

#include <stddef.h>

/* not exported from the loader (a host's own symbol of the same name never takes its place) */
#define BATCH_INTERNAL __attribute__((visibility("hidden")))
#include <stdint.h>

#include "fmi2Functions.h"
#include "ipc.h"

#define BATCH_MAX_VRS 512                  /* value references known settable / brought back, each */
#define BATCH_PRE_CAP ((size_t)64 << 10)   /* bytes of deferred calls at the data area's start */

typedef struct {
    int stepping;         /* the model is known to be in Step Mode (no call since could change that) */
    int fresh;            /* a doStep answered, and no call since could change a value */
    int valid;            /* val holds the values of want as the last doStep left them */
    size_t pre_len;       /* bytes of deferred calls waiting at the data area's start */
    size_t n_settable, n_want, hint;
    fmi2ValueReference settable[BATCH_MAX_VRS];   /* sorted: fmi2SetReal took them in Step Mode, fmi2OK, silent */
    fmi2ValueReference want[BATCH_MAX_VRS];       /* fmi2GetReal asked for them after a doStep, fmi2OK, silent */
    fmi2Real val[BATCH_MAX_VRS];
} Batch;

/* fmi2SetReal deferred to the next call (written at the data area's start): 1, or 0 when it must
 * be sent now (not in Step Mode, a reference not known settable, no room). */
BATCH_INTERNAL int batch_defer_set(Batch *b, unsigned char *data, const fmi2ValueReference vr[], size_t n,
                                   const fmi2Real v[]);
/* fmi2GetReal from the values the last doStep brought back: 1, or 0 when it must be sent. */
BATCH_INTERNAL int batch_get(Batch *b, const fmi2ValueReference vr[], size_t n, fmi2Real v[]);
/* After a sent fmi2SetReal / fmi2GetReal (status s, `logged`: the model's process sent messages
 * with the answer): remember references that can be deferred / brought back. */
BATCH_INTERNAL void batch_learn(Batch *b, uint32_t call, fmi2Status s, int logged, const fmi2ValueReference vr[],
                                size_t n);
/* After any round trip: what the call may have changed (the values, Step Mode). */
BATCH_INTERNAL void batch_answered(Batch *b, uint32_t call, fmi2Status s);
/* fmi2DoStep's request: the references to bring back; its answer: their values (when the model's
 * process could read them: the step ended with at most fmi2Discard, the read was fmi2OK and silent). */
BATCH_INTERNAL void batch_put_want(const Batch *b, IpcBuf *req);
BATCH_INTERNAL void batch_take_values(Batch *b, IpcBuf *ans);

#endif
