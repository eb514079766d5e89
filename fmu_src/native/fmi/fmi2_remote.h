/* The model in its own process (fmi2_server.c), seen from the host: see fmi2_remote.c. */
#ifndef SPURDIFF_FMI2_REMOTE_H
#define SPURDIFF_FMI2_REMOTE_H

#include <stddef.h>

#include "fmi2_table.h"

/* Start the server for one instance and instantiate there. NULL on failure: `err` says why when
 * the process could not start, and is empty when the model's process logged the reason itself. */
fmi2Component remote_instantiate(fmi2String name, fmi2Type type, fmi2String guid, const char *resources,
                                 const char *bindir, const fmi2CallbackFunctions *cb, fmi2Boolean visible,
                                 fmi2Boolean logging, char *err, size_t errsize);

/* Every other function, on the fmi2Component remote_instantiate returned (fmi2Instantiate unused). */
extern const Fmi2Table REMOTE_TABLE;

/* The bridge's FMI 3.0 extension spurdiffDoStepEarly (fmi2_inproc.h) in the model's process. */
fmi2Status remote_do_step_early(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean nsp, fmi2Real *end);

/* The hand-over (fmi2_loader.c): the model's stepping state as bytes for ns_open_live (*bytes
 * malloc'd, *len): 1; 0 not now; -1 never for this model, or the call failed. *status: the round
 * trip's (the host's deferred fmi2SetReal calls are served first: worse than fmi2Warning, and the
 * step they went with must not be taken). */
int remote_native_export(fmi2Component c, unsigned char **bytes, size_t *len, fmi2Status *status);
/* The state back (ns_live_state's arrays, time, bad, steps) into the model: its status. */
fmi2Status remote_native_import(fmi2Component c, const double *arrays, size_t n, double time, int bad, long steps);
/* The start cache (fmi2_loader.c): the model's native start of the values `sets` (ns_cache_want's
 * encoding): 1 and *bytes (malloc'd, *len); else 0 (none) or -1 (the call failed; nothing logged). */
int remote_start_snapshot(fmi2Component c, const unsigned char *sets, size_t n, unsigned char **bytes, size_t *len);

#endif
