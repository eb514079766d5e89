/* The model in this process: the runtime's Python (or the host's of the same version) and the
 * bridge. Used by the loader (a host that can share) and by the server (the model's own process). */
#ifndef SPURDIFF_FMI2_INPROC_H
#define SPURDIFF_FMI2_INPROC_H

#include <stddef.h>

#include "fmi2_table.h"
#include "runtime_cfg.h"

/* Which Python the process runs, seen from the runtime description:
 * INPROC_NONE: none; INPROC_SAME: one of the runtime's major.minor (the bridge uses it);
 * INPROC_OTHER: another version (`version` gets it): the model must run in its own process. */
enum { INPROC_NONE, INPROC_SAME, INPROC_OTHER };
int inproc_host_python(const RuntimeCfg *cfg, char *version, size_t size);

/* Make the Python symbols global (the process's own Python of the same version, else the
 * runtime's libpython after its preloads), then load <bindir>/fmi2_pybridge.so and fill its
 * table. Thread-safe; loads once per process. 0, or -1 with the reason in `err`. */
int inproc_load(const RuntimeCfg *cfg, const char *resources, const char *bindir, const Fmi2Table **table,
                char *err, size_t errsize);

/* The bridge's FMI 3.0 extension (fmi2_pybridge.c): fmi2DoStep that may end early at a stick/slip
 * transition, with the time reached in *end (the FMI 3.0 binary's fmi3DoStep with earlyReturnAllowed). */
typedef fmi2Status spurdiffDoStepEarlyTYPE(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean nsp, fmi2Real *end);
fmi2Status inproc_do_step_early(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean nsp, fmi2Real *end);

/* The bridge's hand-over of the native step (fmi2_pybridge_native.c, used by the model's own process):
 * export: 1 and *bytes (malloc'd, *len), 0 not now, -1 never; import: the arrays back, a status. */
typedef int spurdiffNativeExportTYPE(fmi2Component c, unsigned char **bytes, size_t *len);
typedef fmi2Status spurdiffNativeImportTYPE(fmi2Component c, const double *arrays, size_t n, double time, int bad,
                                            long steps);
/* The bridge's native start of the values set (the start cache; spurdiffStartSnapshot): 1 and *bytes
 * (malloc'd, *len), 0 none, -1 failed (nothing logged). */
typedef int spurdiffStartSnapshotTYPE(fmi2Component c, const unsigned char *sets, size_t n, unsigned char **bytes,
                                      size_t *len);
/* The bridge's fork for the model processes' zygote (spurdiffFork, POSIX only): the child's pid, 0 in
 * the child, -1 on failure. */
typedef long spurdiffForkTYPE(void);
long inproc_fork(void);
int inproc_start_snapshot(fmi2Component c, const unsigned char *sets, size_t n, unsigned char **bytes, size_t *len);
int inproc_native_export(fmi2Component c, unsigned char **bytes, size_t *len);
fmi2Status inproc_native_import(fmi2Component c, const double *arrays, size_t n, double time, int bad, long steps);

#endif
