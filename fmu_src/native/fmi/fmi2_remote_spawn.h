/* Starting and ending the model's own process (fmi2_remote_spawn.c). */
#ifndef SPURDIFF_FMI2_REMOTE_SPAWN_H
#define SPURDIFF_FMI2_REMOTE_SPAWN_H

#include <stddef.h>

/* not exported from the loader (a host's own symbol of the same name never takes its place) */
#define SPAWN_INTERNAL __attribute__((visibility("hidden")))
#include <sys/types.h>

/* Make the shared memory (*shm_fd, mapped at *base, its header written) and the pipe (*pipe_w the
 * host's end), start the server for `resources` and `bindir`: directly for the first instance of
 * the folder in this host process, forked by the folder's zygote (*forked 1) while another lives
 * (SPURDIFF_FMU_ZYGOTE=0: always directly). *folder is the handle for release_server. 0, or -1
 * with the reason in `err` (what was made so far is in the out arguments, for the caller to close). */
SPAWN_INTERNAL int spawn_server(const char *resources, const char *bindir, int *shm_fd, void **base, int *pipe_w,
                                pid_t *pid, void **folder, int *forked, char *err, size_t errsize);
/* A process's scheduling state letter and CPU time (ns) from /proc/<pid>/stat: 0, or -1 (not readable). */
SPAWN_INTERNAL int proc_state(pid_t pid, char *state, long long *cpu_ns);
/* The process `pid` has ended and waits to be reaped (Z or X): a zygote's whose zygote is gone. */
SPAWN_INTERNAL int proc_ended(pid_t pid);
/* Wait up to `ms` for the server `pid` to exit (a zygote's: to be reaped by it); SIGKILL after that
 * (nothing for pid <= 0). */
SPAWN_INTERNAL void reap_server(pid_t pid, int ms);
/* The instance of a server from spawn_server is gone (after reap_server): a zygote ends with the
 * last instance it forked. */
SPAWN_INTERNAL void release_server(void *folder, int forked);

#endif
