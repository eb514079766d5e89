"""ChkDaemonInStep: ChkGood whose first ``do_step`` leaves a daemon behind (fork, setsid, the
inherited stdout and stderr kept open) and then hangs.

Used for the timeout of ``spurdiff check`` (issue 14, item 3): the check must end at its timeout,
and the daemon must be gone. The daemon writes its process id to the file named by the environment
variable CHK_DAEMON_PIDFILE (when set), so the test can tell.
"""
import os
import time

from ChkGood import ChkGood


class ChkDaemonInStep(ChkGood):
    description = "Leaves a daemon behind and hangs in do_step (compliance-checker test FMU)"

    def do_step(self, current_time, step_size):
        if os.fork() == 0:
            os.setsid()
            if os.fork() == 0:  # the grandchild: a daemon, in its own session
                path = os.environ.get("CHK_DAEMON_PIDFILE")
                if path:
                    with open(path, "w") as f:
                        # its pid as /proc sees it (the kit may run it in a PID namespace of its own)
                        f.write(os.readlink("/proc/self") if os.path.islink("/proc/self") else str(os.getpid()))
                time.sleep(3600.0)
            os._exit(0)
        time.sleep(3600.0)
        return True
