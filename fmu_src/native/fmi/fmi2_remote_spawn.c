/* Starting and ending the model's own process (binaries/<platform>/spurdiff_fmu_server) for
 * fmi2_remote.c. Every process is started with posix_spawn in its own process group (a terminal's
 * Ctrl-C reaches the host, which decides), through the dynamic loader when the extracted file lost
 * its execute bit, with two descriptors and nothing else of the host's, stdin /dev/null, a bare
 * environment. An instance's process gets its shared memory (ipc.h) on fd IPC_SHM_FD and the read
 * end of a pipe only the host writes on IPC_PIPE_FD. The first instance of an FMU folder in a host
 * process gets its process started directly; one made while another lives is forked by the
 * folder's zygote (`spurdiff_fmu_server --zygote`, fmi2_server.c: the runtime started and the
 * package imported once, so its instances share that memory), which is started then (a socket on
 * fd ZYGOTE_SOCK_FD: the instance's two descriptors in, the pid out) and ends with the last
 * instance it forked. SPURDIFF_FMU_ZYGOTE=0, or a zygote that failed, starts every process
 * directly. */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <poll.h>
#include <pthread.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/socket.h>
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

/* A process's scheduling state and CPU time (ns) from /proc/<pid>/stat: 0, or -1 (not readable). */
int proc_state(pid_t pid, char *state, long long *cpu_ns)
{
    char path[64], buf[1024];
    snprintf(path, sizeof path, "/proc/%d/stat", (int)pid);
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) return -1;
    ssize_t n = read(fd, buf, sizeof buf - 1);
    close(fd);
    if (n <= 0) return -1;
    buf[n] = 0;
    char *p = strrchr(buf, ')');     /* after the command's name, which may hold anything */
    unsigned long long ut = 0, st = 0;
    if (!p || sscanf(p + 1, " %c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %llu %llu", state, &ut, &st) != 3) return -1;
    long hz = sysconf(_SC_CLK_TCK);
    *cpu_ns = (long long)(ut + st) * (1000000000LL / (hz > 0 ? hz : 100));
    return 0;
}

int proc_ended(pid_t pid)
{
    char state = '?';
    long long cpu;
    return proc_state(pid, &state, &cpu) == 0 && (state == 'Z' || state == 'X');
}

void reap_server(pid_t pid, int ms)
{
    if (pid <= 0) return;
    for (int i = 0; i < ms; i++) {
        pid_t w = waitpid(pid, NULL, WNOHANG);
        if (w == pid) return;
        if (w < 0 && errno == ECHILD && kill(pid, 0) != 0) return;   /* a zygote's: reaped by it */
        usleep(1000);
    }
    kill(pid, SIGKILL);
    waitpid(pid, NULL, 0);
}

/* Start `server` (with `mode`, "--zygote" or NULL, before its arguments) on the descriptors fd3 and
 * fd4: 0 and *pid, or an errno. */
static int start_process(const char *server, const char *mode, const char *resources, const char *bindir, int fd3,
                         int fd4, pid_t *pid)
{
    posix_spawn_file_actions_t fa;
    posix_spawnattr_t at;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, fd3, IPC_SHM_FD);
    posix_spawn_file_actions_adddup2(&fa, fd4, IPC_PIPE_FD);
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
     * folder: runtime_unpack.h), as the host has them */
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
    char *argv[6];
    int a = 0, rc;
    int direct = access(server, X_OK) == 0;
    if (!direct) argv[a++] = (char *)DYNAMIC_LOADER;   /* unpacked without its execute bit (most hosts' unzip) */
    argv[a++] = (char *)server;
    if (mode) argv[a++] = (char *)mode;
    argv[a++] = (char *)resources;
    argv[a++] = (char *)bindir;
    argv[a] = NULL;
    if (direct) rc = posix_spawn(pid, server, &fa, &at, argv, envp);
    else rc = *DYNAMIC_LOADER ? posix_spawn(pid, DYNAMIC_LOADER, &fa, &at, argv, envp) : EACCES;
    posix_spawn_file_actions_destroy(&fa);
    posix_spawnattr_destroy(&at);
    if (rc != 0) *pid = 0;
    return rc;
}

/* ---------------------------------------------------------------------------- the zygotes
 * Per host process and FMU folder: the instances whose process was started directly and those a
 * zygote forked. The first instance's process is started directly (a lone instance needs no
 * zygote, which would cost it 5 MB); an instance made while another of the folder lives is forked
 * by the folder's zygote, started then, and ended with the last instance it forked. */
typedef struct Folder {
    struct Folder *next;
    char *resources, *bindir;
    pid_t owner;               /* the host process (a fork of it keeps its own) */
    int direct, forked;        /* live instances of each kind */
    pid_t zpid;                /* the zygote (0: none) */
    int sock, pipe_w;          /* our end of its socket; the write end of its pipe (end of file: the host is gone) */
    int broken;                /* it failed: no more forks of it */
} Folder;
static Folder *FOLDERS;
static pthread_mutex_t FLOCK = PTHREAD_MUTEX_INITIALIZER;
#define ZYGOTE_ANSWER_MS 120000   /* its first answer waits for the runtime's start (and unpack) */
#define ZYGOTE_STOPPED_MS 1000

/* End the folder's zygote, if any (end of file on its socket: it ends; reaped). */
static void zygote_end(Folder *f)
{
    if (f->sock >= 0) close(f->sock);
    if (f->pipe_w >= 0) close(f->pipe_w);
    f->sock = f->pipe_w = -1;
    reap_server(f->zpid, 2000);
    f->zpid = 0;
    f->broken = 0;
}

/* This process's record of the folder, made when there is none (FLOCK held); NULL: no memory. */
static Folder *folder_for(const char *resources, const char *bindir)
{
    for (Folder *f = FOLDERS; f; f = f->next)
        if (f->owner == getpid() && !strcmp(f->resources, resources) && !strcmp(f->bindir, bindir)) return f;
    Folder *f = (Folder *)calloc(1, sizeof *f);
    if (!f) return NULL;
    f->resources = strdup(resources);
    f->bindir = strdup(bindir);
    f->owner = getpid();
    f->sock = f->pipe_w = -1;
    if (!f->resources || !f->bindir) { free(f->resources); free(f->bindir); free(f); return NULL; }
    f->next = FOLDERS;
    FOLDERS = f;
    return f;
}

/* The record goes once no instance of the folder lives (FLOCK held). */
static void folder_done(Folder *f)
{
    if (f->forked <= 0 && f->zpid) zygote_end(f);
    if (f->direct > 0 || f->forked > 0) return;
    for (Folder **p = &FOLDERS; *p; p = &(*p)->next)
        if (*p == f) { *p = f->next; break; }
    free(f->resources);
    free(f->bindir);
    free(f);
}

/* Start the folder's zygote: 0, or -1. */
static int zygote_start(Folder *f, const char *server)
{
    int sv[2], p[2];
    if (socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, sv) != 0) return -1;
    if (pipe2(p, O_CLOEXEC) != 0) { close(sv[0]); close(sv[1]); return -1; }
    f->sock = move_up(sv[0]);
    f->pipe_w = move_up(p[1]);
    int theirs = move_up(sv[1]), pipe_r = move_up(p[0]);
    int rc = start_process(server, "--zygote", f->resources, f->bindir, theirs, pipe_r, &f->zpid);
    close(theirs);
    close(pipe_r);
    if (rc != 0) { zygote_end(f); return -1; }
    return 0;
}

/* Ask the zygote to fork an instance's process on (shm_fd, pipe_r): 0 and *pid, or -1 (gone,
 * stopped for 1 s, or no answer within ZYGOTE_ANSWER_MS). */
static int zygote_fork(Folder *f, int shm_fd, int pipe_r, pid_t *pid)
{
    char byte = 'f';
    struct iovec io = {&byte, 1};
    union { struct cmsghdr align; char buf[CMSG_SPACE(2 * sizeof(int))]; } u;
    memset(&u, 0, sizeof u);
    struct msghdr m = {0};
    m.msg_iov = &io;
    m.msg_iovlen = 1;
    m.msg_control = u.buf;
    m.msg_controllen = sizeof u.buf;
    struct cmsghdr *c = CMSG_FIRSTHDR(&m);
    c->cmsg_level = SOL_SOCKET;
    c->cmsg_type = SCM_RIGHTS;
    c->cmsg_len = CMSG_LEN(2 * sizeof(int));
    int fds[2] = {shm_fd, pipe_r};
    memcpy(CMSG_DATA(c), fds, sizeof fds);
    if (sendmsg(f->sock, &m, MSG_NOSIGNAL) != 1) return -1;
    int stopped = 0;
    for (int waited = 0; waited < ZYGOTE_ANSWER_MS; waited += 100) {
        struct pollfd pf = {f->sock, POLLIN, 0};
        int r = poll(&pf, 1, 100);
        if (r > 0) {
            int32_t answer;
            if (recv(f->sock, &answer, sizeof answer, 0) != (ssize_t)sizeof answer || answer <= 0) return -1;
            *pid = (pid_t)answer;
            return 0;
        }
        if (r < 0 && errno != EINTR) return -1;
        if (waitpid(f->zpid, NULL, WNOHANG) != 0) { f->zpid = 0; return -1; }   /* it ended */
        char st = '?';
        long long cpu;
        stopped = proc_state(f->zpid, &st, &cpu) == 0 && (st == 'T' || st == 't') ? stopped + 100 : 0;
        if (stopped >= ZYGOTE_STOPPED_MS) return -1;
    }
    return -1;
}

void release_server(void *folder, int forked)
{
    Folder *f = (Folder *)folder;
    if (!f) return;
    pthread_mutex_lock(&FLOCK);
    if (f->owner == getpid()) {
        if (forked) f->forked--;
        else f->direct--;
        folder_done(f);
    }
    pthread_mutex_unlock(&FLOCK);
}

/* The loader unloaded (dlclose): this process's zygotes end (their processes with them). */
__attribute__((destructor)) static void zygotes_end(void)
{
    pthread_mutex_lock(&FLOCK);
    for (Folder *f = FOLDERS; f; f = f->next)
        if (f->owner == getpid() && f->zpid) zygote_end(f);
    pthread_mutex_unlock(&FLOCK);
}

static int zygote_wanted(void)
{
    const char *e = getenv("SPURDIFF_FMU_ZYGOTE");
    return !(e && strcmp(e, "0") == 0);
}

int spawn_server(const char *resources, const char *bindir, int *shm_fd, void **base, int *pipe_w, pid_t *pid,
                 void **folder, int *forked, char *err, size_t errsize)
{
    char server[PATH_MAX];
    *folder = NULL;
    *forked = 0;
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
    pthread_mutex_lock(&FLOCK);
    Folder *f = folder_for(resources, bindir);
    int ok = 0;
    if (f && zygote_wanted() && f->direct + f->forked > 0 && !f->broken) {   /* another instance lives: fork */
        ok = (f->zpid || zygote_start(f, server) == 0) && zygote_fork(f, *shm_fd, pipe_r, pid) == 0;
        if (ok) f->forked++;
        else if (f->forked > 0) f->broken = 1;   /* (ended with the last instance it forked) */
        else zygote_end(f);
    }
    int rc = 0;
    if (!ok) {
        rc = start_process(server, NULL, resources, bindir, *shm_fd, pipe_r, pid);
        if (rc == 0 && f) f->direct++;
    }
    if (rc == 0 && f) {
        *folder = f;
        *forked = ok;
    } else if (f) {
        folder_done(f);
    }
    pthread_mutex_unlock(&FLOCK);
    close(pipe_r);
    if (rc != 0) {
        snprintf(err, errsize, "cannot start the model's process %s: %s", server, strerror(rc));
        return -1;
    }
    return 0;
}
