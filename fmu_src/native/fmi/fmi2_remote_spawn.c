/* Starting and ending the model's own process (binaries/<platform>/spurdiff_fmu_server) for
 * fmi2_remote.c: posix_spawn in its own process group (a terminal's Ctrl-C reaches the host, which
 * decides), through the dynamic loader when the extracted file lost its execute bit, with the
 * shared memory (ipc.h) on fd IPC_SHM_FD and the read end of a pipe only the host writes on
 * IPC_PIPE_FD; nothing else of the host's is inherited, stdin is /dev/null. */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include "fmi2_remote_spawn.h"
#include "ipc.h"

#define SERVER_FILE "spurdiff_fmu_server"
#if defined(__x86_64__)
#define DYNAMIC_LOADER "/lib64/ld-linux-x86-64.so.2"
#elif defined(__aarch64__)
#define DYNAMIC_LOADER "/lib/ld-linux-aarch64.so.1"
#else
#define DYNAMIC_LOADER ""
#endif

static int move_up(int fd)
{
    if (fd < 0 || fd > 10) return fd;
    int up = fcntl(fd, F_DUPFD_CLOEXEC, 10);
    close(fd);
    return up;
}

void reap_server(pid_t pid, int ms)
{
    if (pid <= 0) return;
    for (int i = 0; i < ms; i++) {
        pid_t w = waitpid(pid, NULL, WNOHANG);
        if (w == pid || (w < 0 && errno == ECHILD)) return;
        usleep(1000);
    }
    kill(pid, SIGKILL);
    waitpid(pid, NULL, 0);
}

int spawn_server(const char *resources, const char *bindir, int *shm_fd, void **base, int *pipe_w, pid_t *pid,
                 char *err, size_t errsize)
{
    char server[PATH_MAX];
    if (snprintf(server, sizeof server, "%s/%s", bindir, SERVER_FILE) >= (int)sizeof server) {
        snprintf(err, errsize, "the FMU's path is too long");
        return -1;
    }
    if (access(server, R_OK) != 0) {
        snprintf(err, errsize, "cannot read %s: %s (the FMU was not extracted completely)", server, strerror(errno));
        return -1;
    }
    *shm_fd = move_up(memfd_create("spurdiff-fmu", MFD_CLOEXEC));
    if (*shm_fd < 0 || ftruncate(*shm_fd, (off_t)IPC_SIZE) != 0) {
        snprintf(err, errsize, "cannot make the shared memory for the model's process: %s", strerror(errno));
        return -1;
    }
    *base = mmap(NULL, IPC_SIZE, PROT_READ | PROT_WRITE, MAP_SHARED, *shm_fd, 0);
    if (*base == MAP_FAILED) {
        snprintf(err, errsize, "cannot map the shared memory: %s", strerror(errno));
        return -1;
    }
    IpcHeader *h = (IpcHeader *)*base;
    h->magic = IPC_MAGIC;
    h->version = IPC_VERSION;
    int p[2];
    if (pipe2(p, O_CLOEXEC) != 0) {
        snprintf(err, errsize, "cannot make a pipe for the model's process: %s", strerror(errno));
        return -1;
    }
    int pipe_r = move_up(p[0]);
    *pipe_w = move_up(p[1]);
    posix_spawn_file_actions_t fa;
    posix_spawnattr_t at;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, *shm_fd, IPC_SHM_FD);
    posix_spawn_file_actions_adddup2(&fa, pipe_r, IPC_PIPE_FD);
    posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addclosefrom_np(&fa, IPC_PIPE_FD + 1);
    posix_spawnattr_init(&at);
    sigset_t none, all;
    sigemptyset(&none);
    sigfillset(&all);
    posix_spawnattr_setsigmask(&at, &none);
    posix_spawnattr_setsigdefault(&at, &all);
    posix_spawnattr_setpgroup(&at, 0);
    posix_spawnattr_setflags(&at, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETPGROUP);
    /* a bare environment: the locale, and where the user's caches are (the runtime's unpacked
     * folder, numpy's: runtime_unpack.h, spurdiff/numpy_archive.py), as the host has them */
    static const char *const PASSED[] = {"HOME", "XDG_CACHE_HOME", "TMPDIR", "SPURDIFF_FMU_RUNTIME_DIR"};
    char *envp[2 + sizeof PASSED / sizeof *PASSED] = {"LC_ALL=C.UTF-8"};
    char passed[sizeof PASSED / sizeof *PASSED][4200];
    int n_env = 1;
    for (size_t i = 0; i < sizeof PASSED / sizeof *PASSED; i++) {
        const char *v = getenv(PASSED[i]);
        int k = v ? snprintf(passed[i], sizeof passed[i], "%s=%s", PASSED[i], v) : -1;
        if (k > 0 && (size_t)k < sizeof passed[i]) envp[n_env++] = passed[i];
    }
    envp[n_env] = NULL;
    int rc;
    if (access(server, X_OK) == 0) {
        char *argv[] = {server, (char *)resources, (char *)bindir, NULL};
        rc = posix_spawn(pid, server, &fa, &at, argv, envp);
    } else {
        /* unpacked without its execute bit (most hosts' unzip): run it through the dynamic loader */
        char *argv[] = {DYNAMIC_LOADER, server, (char *)resources, (char *)bindir, NULL};
        rc = *DYNAMIC_LOADER ? posix_spawn(pid, DYNAMIC_LOADER, &fa, &at, argv, envp) : EACCES;
    }
    posix_spawn_file_actions_destroy(&fa);
    posix_spawnattr_destroy(&at);
    close(pipe_r);
    if (rc != 0) {
        *pid = 0;
        snprintf(err, errsize, "cannot start the model's process %s: %s", server, strerror(rc));
        return -1;
    }
    return 0;
}
