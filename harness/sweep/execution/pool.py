"""FMU instances reused across the runs of a worker process.

pythonfmu FMUs run inside the worker's own interpreter, so every worker process keeps a pool of
:class:`harness.fmi.instance.Instance` objects keyed by (FMU file, instance name): a run checks
an instance out, calls ``fmi2Reset`` (pythonfmu re-runs the model's constructor, so every
parameter is back at its start value), sets the run's parameters, initializes and steps, then
``fmi2Terminate`` and checks it back in. An instance whose reset fails is freed and replaced.
Instances are checked out, not shared between concurrent runs (threads would give no speed-up
with pythonfmu anyway: every call holds the GIL).
"""
from __future__ import annotations

import os
import threading
import time
from pathlib import Path

from harness.fmi.instance import Instance
from harness.fmi.instance3 import open_instance
from harness.run.master import Master, RunFailure
from harness.scene.spec import Scene, SceneError
from harness.sweep.jobs import FmuRef

class InstancePool:
    """Per-process pool of FMU instances, checked out for one run and back in after it."""

    def __init__(self):
        self._free: dict[tuple[str, str], list[Instance]] = {}
        self._builds: dict[str, str] = {}     # FMU name -> digest loaded in this process
        self._lock = threading.Lock()
        self.created = 0
        self.reused = 0

    def check_build(self, ref: FmuRef) -> None:
        """pythonfmu FMUs share one sys.modules per process: two builds of one FMU cannot coexist."""
        with self._lock:
            seen = self._builds.setdefault(ref.name, ref.digest)
        if seen != ref.digest:
            raise SceneError(f"this worker process (pid {os.getpid()}) already loaded another build of {ref.name}; "
                             "restart the workers after rebuilding an FMU (Client.restart())")

    def acquire(self, name: str, path: Path) -> Instance:
        key = (str(path), name)
        while True:
            with self._lock:
                inst = self._free.get(key, []).pop() if self._free.get(key) else None
            if inst is None:
                self.created += 1
                inst = open_instance(name, path)  # FMI 2.0 or 3.0; its own log callback: messages reach this instance only
                self._free_at_exit()
                return inst
            inst.messages.clear()          # the logger callback appends to this very list
            try:
                inst.slave.reset()
            except Exception:
                inst.close()               # cannot be reused: drop it, try the next one
                continue
            self.reused += 1
            return inst

    def _free_at_exit(self) -> None:
        # free the pooled instances before the interpreter finalizes: processes that exited with
        # pythonfmu instances alive aborted at exit ("corrupted double-linked list") in about 6 % of
        # trials here, about 1 % with this (registered after harness.run.master's cache clean-up, so it
        # runs before it)
        if not getattr(self, "_atexit", False):
            import atexit
            atexit.register(self.clear)
            self._atexit = True

    def release(self, name: str, path: Path, inst: Instance) -> None:
        try:
            inst.slave.terminate()
        except Exception:
            pass  # terminate is refused in some error states; reset on the next checkout decides
        with self._lock:
            self._free.setdefault((str(path), name), []).append(inst)

    def clear(self) -> None:
        with self._lock:
            insts = [i for lst in self._free.values() for i in lst]
            self._free.clear()
        for inst in insts:
            inst.close()


POOL = InstancePool()


class RunTimeout(RunFailure):
    """The run exceeded the sweep's wall-time limit."""


class ReusingMaster(Master):
    """:class:`harness.run.master.Master` taking its FMU instances from the process pool."""

    def __init__(self, scene: Scene, fmu_files: dict[str, Path], pool: InstancePool = POOL,
                 timeout: float | None = None):
        self.pool = pool
        self._t0 = time.perf_counter()
        self._timeout = timeout
        super().__init__(scene, fmu_files, self._check_time if timeout else None)

    def _check_time(self, frac: float) -> None:  # Master calls this every 200 steps
        if frac < 1.0 and time.perf_counter() - self._t0 > self._timeout:
            t = frac * self.scene.duration
            raise RunTimeout("sweep", t, f"timeout: over {self._timeout:g} s of wall time at t = {t:.6g} s")

    def _instantiate(self) -> None:
        for spec in self.scene.instances:
            if spec.fmu not in self.fmu_files:
                raise SceneError(f"{spec.name}: unknown FMU {spec.fmu!r}; allowed: {', '.join(sorted(self.fmu_files))}")
            self.instances[spec.name] = self.pool.acquire(spec.name, self.fmu_files[spec.fmu])

    def _free(self) -> None:
        for spec in self.scene.instances:
            inst = self.instances.get(spec.name)
            if inst is not None:
                self.pool.release(spec.name, self.fmu_files[spec.fmu], inst)
