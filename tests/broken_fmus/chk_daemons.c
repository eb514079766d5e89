/* Hostile addition to chkc.c (issue 45, item 3): linked into a ChkC binary, it starts daemons the
   moment the binary is loaded (a constructor), in every process that loads it (the kit's worker,
   the bare C host). Each daemon writes its process id to a file in CHK_DAEMON_DIR (a macro: the
   environment is emptied before the exec) and then execs `sleep 299.<CHK_DAEMON_TAG>` with an EMPTY
   environment, so no marker of the run survives; a daemon that does not exec names itself
   chkd<CHK_DAEMON_TAG> (prctl PR_SET_NAME). The pid is the one in the daemon's own PID namespace:
   the test finds survivors by that name and that command line. The cases:
     1 double fork, setsid (a classic daemon, its own session)
     2 fork, setpgid(0, 0) (leaves the process group, stays in the session)
     3 double fork, setsid, then itself a child subreaper with a child of its own
     4 a spawner: double fork, setsid, and a new child every 20 ms for 3 s (each execs sleep)
     5 SIGKILL to its parent process (the kit's reaper, or what stands for it), then case 1
   CHK_DAEMON_CASES (a macro, default "1234") picks the cases. The constructor returns only once
   each case's daemon has written its pid (a byte on a close-on-exec pipe, waited for up to 10 s):
   a check that ends quickly cannot end before the daemons exist, which would prove nothing. */
#define _GNU_SOURCE
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/types.h>
#include <unistd.h>

#ifndef CHK_DAEMON_DIR
#error "CHK_DAEMON_DIR must name the folder the daemons write their pids to"
#endif
#ifndef CHK_DAEMON_TAG
#define CHK_DAEMON_TAG "000000"
#endif
#ifndef CHK_DAEMON_CASES
#define CHK_DAEMON_CASES "1234"
#endif

static int ready_fd = -1;   /* write end of the pipe the loading process waits on; -1 once used */

static void note_pid(void) {
    char path[512];
    int fd;
    prctl(PR_SET_NAME, "chkd" CHK_DAEMON_TAG, 0, 0, 0);
    snprintf(path, sizeof path, "%s/%d", CHK_DAEMON_DIR, (int)getpid());
    fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) close(fd);
    if (ready_fd >= 0) {   /* once per daemon tree: later writers would meet a closed pipe (SIGPIPE) */
        ssize_t n = write(ready_fd, "r", 1);
        (void)n;
        close(ready_fd);
        ready_fd = -1;
    }
}

static void become_sleep(void) {
    char *argv[] = {"sleep", "299." CHK_DAEMON_TAG, NULL};
    char *envp[] = {NULL};
    note_pid();
    execve("/bin/sleep", argv, envp);
    execve("/usr/bin/sleep", argv, envp);
    _exit(0);
}

static void daemon_case(char which) {
    pid_t p;
    int fds[2];
    if (which == '5') {
        kill(getppid(), SIGKILL);
        which = '1';
    }
    if (pipe2(fds, O_CLOEXEC) != 0) fds[0] = fds[1] = -1;
    p = fork();
    if (p != 0) {
        if (fds[1] >= 0) close(fds[1]);
        if (fds[0] >= 0) {
            struct pollfd w = {fds[0], POLLIN, 0};
            char c;
            if (p > 0 && poll(&w, 1, 10000) > 0) {
                ssize_t n = read(fds[0], &c, 1);
                (void)n;
            }
            close(fds[0]);
        }
        return;
    }
    if (fds[0] >= 0) close(fds[0]);
    ready_fd = fds[1];
    switch (which) {
    case '1':
        setsid();
        if (fork() == 0) become_sleep();
        _exit(0);
    case '2':
        setpgid(0, 0);
        become_sleep();
        break;
    case '3':
        setsid();
        if (fork() == 0) {
            prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0);
            note_pid();
            if (fork() == 0) {
                if (fork() == 0) become_sleep();
                _exit(0);
            }
            for (;;) pause();
        }
        _exit(0);
    case '4':
        setsid();
        if (fork() == 0) {
            int i;
            note_pid();
            for (i = 0; i < 150; i++) {
                if (fork() == 0) become_sleep();
                usleep(20000);
            }
            for (;;) pause();
        }
        _exit(0);
    }
    _exit(0);
}

__attribute__((constructor)) static void chk_start_daemons(void) {
    const char *c;
    for (c = CHK_DAEMON_CASES; *c; c++) daemon_case(*c);
}
