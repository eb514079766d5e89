"""fmpy's logger proxy has one process-wide target (fmpy/logging: ``addLoggerProxy``): a run with a
logger of its own leaves it pointing at a callback freed after the run, and the next FMU logging
through fmpy's default callbacks crashed the process (SIGSEGV/SIGFPE in ``logMessage``; the
crash of the first session's suite ordering). harness/fmi/fmpy_logging.py restores the default;
the harness does it when an instance that used the proxy is freed, the tests after each test.
Each case runs in a process of its own (a crash must not take the test run with it)."""
from __future__ import annotations

import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent("""
    import sys
    from fmpy import simulate_fmu
    from harness.fmi import fmpy_logging
    from harness.fmi.instance import Instance
    f = sys.argv[1]
    if sys.argv[2] == "simulate_fmu":
        simulate_fmu(f, stop_time=0.01, logger=lambda *a: None, debug_logging=True)
        fmpy_logging.restore_default()
    else:                                   # the kit's way: an Instance formatting its messages
        inst = Instance("kit", f, instantiate=False)
        inst.instantiate(format_messages=True)
        inst.close()
    import gc; gc.collect()
    try:    # logs an error at start-up through fmpy's default callbacks
        simulate_fmu(f, stop_time=0.01, start_values={"wheel.J": -1.0})
    except Exception as e:
        print("refused:", type(e).__name__)
    print("survived")
""")


def _run(fmu, how: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", SCRIPT, str(fmu), how], capture_output=True, text=True,
                          timeout=300)


def test_a_run_with_its_own_logger_leaves_fmpy_logging_safely(fmu_files):
    r = _run(fmu_files["WheelLoad"], "simulate_fmu")
    assert r.returncode == 0 and "survived" in r.stdout, (r.returncode, r.stdout[-1000:], r.stderr[-2000:])
    assert "refused: FMICallException" in r.stdout
    assert "wheel.J = -1.0 is invalid" in r.stdout + r.stderr     # printed by fmpy's default logger


def test_an_instance_formatting_its_messages_leaves_fmpy_logging_safely(fmu_files):
    r = _run(fmu_files["WheelLoad"], "instance")
    assert r.returncode == 0 and "survived" in r.stdout, (r.returncode, r.stdout[-1000:], r.stderr[-2000:])
