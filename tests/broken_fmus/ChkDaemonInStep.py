"""ChkDaemonInStep: its first ``do_step`` leaves a daemon behind (fork, setsid, the inherited stdout and
stderr kept open) and then hangs.

Used for the timeout of ``spurdiff check`` (issue 14, item 3): the check must end at its timeout,
and the daemon must be gone. The daemon writes its process id to the file named by the environment
variable CHK_DAEMON_PIDFILE (when set), so the test can tell.
"""
import os
import time

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.default_experiment import DefaultExperiment


class ChkDaemonInStep(Fmi2Slave):
    description = "Leaves a daemon behind and hangs in do_step (compliance-checker test FMU)"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=0.1, step_size=0.01)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.y = 0.0
        self.register_variable(Real("y", causality=Fmi2Causality.output,
                                    variability=Fmi2Variability.continuous, description="constant zero"))

    def do_step(self, current_time, step_size):
        if os.fork() == 0:
            os.setsid()
            if os.fork() == 0:  # the grandchild: a daemon, in its own session
                path = os.environ.get("CHK_DAEMON_PIDFILE")
                if path:
                    with open(path, "w") as f:
                        f.write(str(os.getpid()))
                time.sleep(3600.0)
            os._exit(0)
        time.sleep(3600.0)
        return True
