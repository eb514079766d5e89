/* The native start (native_start.c): an instance answered without Python while its host keeps the
 * FMU's defaults, from resources/native_start.bin (spurdiff/fmi/native_start.py writes it at build
 * time). The loader (fmi2_loader.c) asks it first; NS_PYTHON from any call means "start the model
 * now": the loader starts it, replays the tape (ns_replay: the calls before the first step, then the
 * native step's state) and passes the call on. The same code
 * steps an instance whose model runs in its own process here, in the host's (ns_open_live). */
#ifndef SPURDIFF_NATIVE_START_H
#define SPURDIFF_NATIVE_START_H

#include <stddef.h>

#include "fmi2_table.h"

#define NS_FILE "native_start.bin"
#define NS_PYTHON (-1)     /* a call the native start does not answer: the model's Python must */

typedef struct NsInst NsInst;

/* The native start of an instance: 1 and *out, 0 none (no file: the FMU has none), -1 with the
 * reason in `err` (a damaged file, a kernel that does not load or fails its check). Messages go to
 * `cb`'s logger under `name` as the model's bridge sends them. */
int ns_open(const char *resources, const char *name, const fmi2CallbackFunctions *cb, int logging_on,
            NsInst **out, char *err, size_t errsize);
void ns_free(NsInst *I);

/* the calls: a status, or NS_PYTHON (nothing changed) */
int ns_set_debug_logging(NsInst *I, fmi2Boolean on, size_t n);
int ns_setup_experiment(NsInst *I, fmi2Boolean td, fmi2Real tol, fmi2Real t0, fmi2Boolean sd, fmi2Real t1);
int ns_enter_initialization_mode(NsInst *I);
int ns_exit_initialization_mode(NsInst *I);
int ns_terminate(NsInst *I);
int ns_get_real(NsInst *I, const fmi2ValueReference vr[], size_t n, fmi2Real v[]);
int ns_get_integer(NsInst *I, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]);
int ns_get_boolean(NsInst *I, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]);
int ns_get_string(NsInst *I, const fmi2ValueReference vr[], size_t n, fmi2String v[]);
int ns_set_real(NsInst *I, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]);
int ns_set_integer(NsInst *I, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]);
int ns_set_boolean(NsInst *I, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]);
int ns_set_string(NsInst *I, const fmi2ValueReference vr[], size_t n, const fmi2String v[]);
/* early: the host allows the step to end early (FMI 3.0); *end the time reached */
int ns_do_step(NsInst *I, fmi2Real t, fmi2Real h, fmi2Boolean nsp, int early, fmi2Real *end);
long ns_steps(const NsInst *I);

/* The model's side of a hand-over, wherever the model runs: `take` asks its fmi2_native_export (1 and
 * the bytes it made, malloc'd; 0 not now; -1 never), `give` its fmi2_native_import (the arrays as
 * ns_live_state makes them). */
typedef struct {
    int (*take)(fmi2Component c, unsigned char **bytes, size_t *len);
    fmi2Status (*give)(fmi2Component c, const double *arrays, size_t n, double time, int bad, long steps);
} NsHandOver;

/* The tape into the started model `c` (its functions `t`): every call the native start answered before
 * it stepped, in order, and where it began to step, the native step's state as it is now handed to
 * the model by `ho` (the calls after it on the tape, fmi2Terminate, follow); then the model's outputs
 * compared with the native ones. 0, or -1 with the reason in `err` (a call answered otherwise, a state
 * not taken, an output that differs). */
int ns_replay(const NsInst *I, const Fmi2Table *t, fmi2Component c, const NsHandOver *ho, char *err,
              size_t errsize);

/* The start cache (native_start.c): sets to other values before the model's build are taken, and the
 * build then uses the cache file of exactly those values in `dir` (made by the loader with
 * ns_cache_store from the model's own snapshot of them) or starts the Python. dir NULL: off. 0, or -1
 * (no memory: off). */
int ns_start_cache(NsInst *I, const char *dir, const char *guid, const char *resources);
/* Values were set: 1 with the cache file's `path` and the values (a new array of *len bytes: each kind
 * u32, value reference u32, then a double, or a String's u32 length and bytes) for the model's snapshot;
 * else 0. */
int ns_cache_want(const NsInst *I, char *path, size_t size, unsigned char **sets, size_t *len);
/* `bytes` as the cache file `path` (its folder made with the missing ones above it, 0700, and checked
 * this user's and private; written to a temporary file there, then renamed): 0, or -1. */
int ns_cache_store(const char *path, const void *bytes, size_t len);

/* The hand-over (the model in its own process, fmi2_loader.c): a stepping instance answered here from
 * `len` bytes its model's process wrote (spurdiff/fmi/native_start.py: live; copied, not kept), with
 * the native start's rules for a stepping instance but no tape: NS_PYTHON from any call means "give
 * the state back" (ns_live_state, then the model's process takes it). fmi2Terminate is the model's
 * too. 1 and *out, or -1 with the reason in `err`. */
int ns_open_live(const void *bytes, size_t len, const char *resources, const char *name,
                 const fmi2CallbackFunctions *cb, NsInst **out, char *err, size_t errsize);
int ns_is_live(const NsInst *I);
/* The state to give back: a new array (free it) of v then every array of the step's context in the
 * file's order (*n doubles), the FMU's time, whether an input outside its range was stored since,
 * the steps taken here. 0, or -1 (no memory). */
int ns_live_state(const NsInst *I, double **arrays, size_t *n, double *time, int *bad, long *steps);

#endif
