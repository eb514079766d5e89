"""Fixed-step co-simulation master on the harness's FMU wrapper (:mod:`harness.fmi.instance`, fmpy's FMU2Slave).

The master talks to the FMUs only through FMI: it instantiates every FMU instance of a scene,
sets parameters, initializes, then at each communication step sets inputs (profiles and
connections) and calls doStep, in Gauss-Seidel order (each FMU sees the outputs its predecessors
produced in the same step) or Jacobi (every FMU sees the outputs of the previous step).

Every FMI status is handled: a call that fails (fmpy raises for any status above warning) ends the
run cleanly with a :class:`RunFailure` naming the FMU instance, the time and the messages the FMU
logged; the results recorded so far are kept in the :class:`Result`.

Power over each declared coupling (a torque and the speeds on both sides) is integrated, so the
energy residual of the coupling (the work one side gives minus the work the other receives) shows
when the communication step is too coarse.

(Over 400 lines: one class, the co-simulation loop and its initialization, recording and
coupling-energy bookkeeping, which share the planned step; :func:`run_scene` wraps it.)
"""
from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Callable

import numpy as np
from fmpy.fmi1 import FMICallException

from harness.fmi.instance3 import open_instance
from harness.fmi.instance import FmuCache, Instance, Port, RealPort, fmu_cache, make_logger as _make_logger  # noqa: F401
from harness.common.interrupt import STOP, Interrupted, stop_on_sigint  # noqa: F401
from harness.scene.recording import check_recording, recording_size  # noqa: F401
from harness.run.result import Result
from harness.scene.spec import Scene, SceneError


class RunFailure(RuntimeError):
    """An FMU refused a call; the run stopped at ``time``."""

    def __init__(self, instance: str, time_: float, reason: str):
        self.instance, self.time, self.reason = instance, time_, reason
        super().__init__(f"{instance} failed at t = {time_:.6g} s: {reason}")


class Master:
    """Runs one scene. ``fmu_files`` maps FMU names (e.g. 'SpurDifferential') to .fmu paths."""

    def __init__(self, scene: Scene, fmu_files: dict[str, Path], progress: Callable[[float], None] | None = None,
                 sink: Callable[[list[float]], None] | None = None):
        self.scene = scene
        self.fmu_files = fmu_files
        self.progress = progress
        self.sink = sink        # called with each recorded row as it is recorded (results streamed to disk)
        self.instances: dict[str, Instance] = {}

    # ------------------------------------------------------------------ setup
    def _instantiate(self) -> None:
        for spec in self.scene.instances:
            if spec.fmu not in self.fmu_files:
                raise SceneError(f"{spec.name}: unknown FMU {spec.fmu!r}; allowed: {', '.join(sorted(self.fmu_files))}")
            self.instances[spec.name] = open_instance(spec.name, self.fmu_files[spec.fmu])   # FMI 2.0 or 3.0

    def _initialize(self) -> None:
        sc = self.scene
        for spec in sc.instances:
            inst = self.instances[spec.name]
            inst.slave.setupExperiment(startTime=0.0, stopTime=sc.duration)
            inst.slave.enterInitializationMode()
            for name, value in sc.parameters_of(spec.name).items():   # checked by Scene.check_wiring
                inst.set_value(name, value)
        # inputs at t = 0: the profiles, then the connections propagated in Initialization Mode,
        # where every FMU computes its outputs from what it was given (FMI 2.0 section 3.2.3):
        # one Jacobi sweep per instance, so a value travels through a chain of N instances.
        # libcosim initializes the same way, so both masters start from the same state.
        self._apply_profiles(0.0)
        for _ in range(len(sc.instances)):
            sources = {name: [self._initial_output(src, key[1]) for src, key in srcs]
                       for name, (_, srcs) in self._links.items()}
            for name, (vrs, _) in self._links.items():
                if vrs:
                    self.instances[name].slave.setReal(vrs, sources[name])
        for spec in sc.instances:
            inst = self.instances[spec.name]
            try:
                inst.slave.exitInitializationMode()
            except FMICallException as e:   # fmi2Error: the FMU logged why (an invalid parameter)
                raise RunFailure(spec.name, 0.0, (inst.errors() or [str(e)])[-1]) from None
            errs = inst.errors()
            if errs:
                raise RunFailure(spec.name, 0.0, errs[-1])

    def _initial_output(self, name: str, vr: int) -> float:
        inst = self.instances[name]
        try:
            return inst.slave.getReal([vr])[0]
        except FMICallException as e:   # the FMU cannot compute its initial outputs (it logged why)
            raise RunFailure(name, 0.0, (inst.errors() or [str(e)])[-1]) from None

    # ------------------------------------------------------------------ wiring
    def _compile(self) -> None:
        sc = self.scene
        links = sc.check_wiring({n: inst.vars for n, inst in self.instances.items()})
        self._do_step = {n: inst.c_function("fmi2DoStep") for n, inst in self.instances.items()}
        self._profiles: dict[str, list[tuple[int, Callable]]] = {n: [] for n in self.instances}
        for ref, prof in sc.inputs.items():
            inst, var = ref.split(".", 1)
            self._profiles[inst].append((self.instances[inst].var(var).valueReference, prof))
        # connections grouped by destination instance: (dest vrs, [(src inst, src vr)])
        self._links: dict[str, tuple[list[int], list[tuple[str, int]]]] = {n: ([], []) for n in self.instances}
        for ti, tvar, fi, fvar in links:
            self._links[ti][0].append(tvar.valueReference)
            self._links[ti][1].append((fi, ("Real", fvar.valueReference)))
        # outputs each instance must publish, keyed by (type, value reference): value references
        # are unique per type only. Connections and couplings need theirs after every step;
        # what is only recorded is read at the recording instants.
        every_step: dict[str, set[tuple[str, int]]] = {n: set() for n in self.instances}
        for fi, key in (s for _, srcs in self._links.values() for s in srcs):
            every_step[fi].add(key)
        self._couplings = []
        for c in sc.couplings:
            refs = []
            for k in ("torque", "w_from", "w_to"):
                i, v = c[k].split(".", 1)
                key = self._key(i, v)
                every_step[i].add(key)
                refs.append((i, key))
            self._couplings.append((c["name"], refs, float(c.get("sign", 1.0))))
        needed = {n: set(keys) for n, keys in every_step.items()}
        self._record: list[tuple[str, tuple[str, int]]] = []
        for ref in sc.record:
            i, v = ref.split(".", 1)
            key = self._key(i, v)
            self._record.append((i, key))
            needed[i].add(key)
        if int(round(sc.output_interval / sc.step)) <= 1:
            # recording every step: the step's own read takes the recorded Reals too (one fmi2GetReal
            # per instance and step, not two; the recording instant then reads only other types)
            for n, keys in every_step.items():
                if all(t == "Real" for t, _ in keys):
                    keys |= {k for k in needed[n] if k[0] == "Real"}
        self._out_vrs = {}
        for n, keys in needed.items():
            by_type = {}
            for t in ("Real", "Integer", "Boolean"):
                vrs = sorted(vr for tt, vr in keys if tt == t)
                by_type[t] = (vrs, [(t, vr) for vr in vrs])
            self._out_vrs[n] = by_type
        # the reads of _read_outputs (everything published) and of a recording instant (what the
        # step's own read did not just read), as ports with their C arrays allocated once
        self._all_ports = {n: self._read_ports(n, keys) for n, keys in needed.items()}
        self._rec_ports = {n: self._read_ports(n, keys if any(t != "Real" for t, _ in every_step[n])
                                               else keys - every_step[n])
                           for n, keys in needed.items()}
        self._values: dict[str, dict[tuple[str, int], float]] = {n: {} for n in self.instances}
        # per step: a Real port on exactly those outputs; None: nothing to read; "all": a coupling
        # quantity is not Real, read everything like at a recording instant
        self._step_read: dict[str, tuple[Port, list] | str | None] = {}
        for n, keys in every_step.items():
            if any(t != "Real" for t, _ in keys):
                self._step_read[n] = "all"
            elif keys:
                reals = sorted(vr for _, vr in keys)
                self._step_read[n] = (self._port(n, reals, False), [("Real", vr) for vr in reals])
            else:
                self._step_read[n] = None
        self._set_port = {n: self._port(n, links[0], True) if links[0] else None
                          for n, links in self._links.items()}
        self._profile_port = {n: self._port(n, [vr for vr, _ in profs], True) if profs else None
                              for n, profs in self._profiles.items()}
        # Gauss-Seidel in scene order, per instance in one tuple: its input port with the sources
        # of the values, its fmi2DoStep and component, its per-step read
        self._order = [s.name for s in sc.instances]
        self._plan = []
        for n in self._order:
            read = self._step_read[n]
            self._plan.append((n, self._set_port[n], self._links[n][1], self._do_step[n],
                               self.instances[n].component, read))

    def _read_ports(self, name: str, keys) -> list:
        """Ports reading the outputs ``keys`` of instance ``name``: (port, keys, as float)."""
        ports = []
        for t in ("Real", "Integer", "Boolean"):
            vrs = sorted(vr for tt, vr in keys if tt == t)
            if vrs:
                port = self._port(name, vrs, False, t)
                ports.append((port, [(t, vr) for vr in vrs], t != "Real"))
        return ports

    def _port(self, name: str, vrs: list[int], write: bool, kind: str = "Real") -> Port:
        """A port on instance ``name`` whose refused call ends the run (:class:`RunFailure`)."""
        def fail(reason: str, t: float):
            raise RunFailure(name, t, reason)
        return Port(self.instances[name], vrs, write, fail, kind)

    def _key(self, inst: str, var: str) -> tuple[str, int]:
        v = self.instances[inst].var(var)
        if v.type not in ("Real", "Integer", "Boolean", "Enumeration"):
            raise SceneError(f"{inst}.{var} is a {v.type}: only numeric variables can be recorded")
        return ("Integer" if v.type == "Enumeration" else v.type, v.valueReference)

    def _apply_profiles(self, t: float) -> None:
        for name, profs in getattr(self, "_profiles", {}).items():
            if profs:
                self._profile_port[name].set([p(t) for _, p in profs], t)

    def _communication_step(self, t: float, h: float, order: list[str], jacobi: bool) -> None:
        """One communication step of every instance from t to t + h: the profiles at t, then Jacobi
        (every instance sees the outputs of the last step) or Gauss-Seidel (in scene order, each
        sees the outputs its predecessors just computed)."""
        self._apply_profiles(t)
        if not jacobi and order == self._order:
            values = self._values   # (looked up per step: the variable-step master replaces its dicts)
            for name, sport, srcs, do, comp, read in self._plan:
                if sport is not None:
                    sport.set([values[s][k] for s, k in srcs], t)
                status = do(comp, t, h, 1)   # noSetFMUStatePriorToCurrentPoint
                if status > 1:   # discard, error, fatal
                    inst = self.instances[name]
                    raise RunFailure(name, t, inst.last_messages() or f"fmi2DoStep returned status {status}")
                if read is not None:
                    if read == "all":
                        self._read_outputs(name)
                    else:
                        values[name].update(zip(read[1], read[0].get(t)))
            return
        if jacobi:
            for name in order:
                self._apply_connections(name, t=t)
            for name in order:
                self._step(name, t, h)
            for name in order:
                self._read_step(name, t)
        else:
            for name in order:
                self._apply_connections(name, t=t)
                self._step(name, t, h)
                self._read_step(name, t)

    def _apply_connections(self, name: str, t: float = math.nan) -> None:
        links = getattr(self, "_links", {}).get(name)
        if not links or not links[0]:
            return
        values = self._values
        self._set_port[name].set([values[src][key] for src, key in links[1]], t)

    def _read_step(self, name: str, t: float) -> None:
        """The outputs connections and couplings need, after a step of ``name``."""
        port = self._step_read[name]
        if port == "all":
            self._read_outputs(name)
        elif port is not None:
            self._values[name].update(zip(port[1], port[0].get(t)))

    def _read_outputs(self, name: str, ports: dict | None = None) -> None:
        """Read every output of ``name`` the run needs (``ports``: the recording's ports instead)."""
        d = self._values[name]
        for port, keys, conv in (ports or self._all_ports)[name]:
            values = port.get()
            d.update(zip(keys, map(float, values) if conv else values))

    # ------------------------------------------------------------------ run
    def run(self) -> Result:
        sc = self.scene
        t_wall = time.perf_counter()
        t_setup = 0.0
        failure = None
        check_recording(sc)
        n_steps, n_samples, width = recording_size(sc)
        store = np.empty((n_samples, width))   # pages are committed as rows are written
        rows = 0
        steps = 0
        energy = {}
        t = 0.0
        sink_time = 0.0   # s spent in the sink (writing results), not counted as stepping

        pending: list[list[float]] = []   # rows recorded, not yet in the store (written in blocks)

        def flush() -> None:
            nonlocal rows
            if pending:
                store[rows:rows + len(pending)] = pending   # one numpy conversion per block
                rows += len(pending)
                pending.clear()

        def record(row: list[float]) -> None:
            nonlocal sink_time
            pending.append(row)
            if len(pending) >= 64:
                flush()
            if self.sink is not None:
                t0 = time.perf_counter()
                self.sink(row)
                sink_time += time.perf_counter() - t0

        try:
            self._start()
            t_setup = time.perf_counter() - t_wall
            t_wall = time.perf_counter()
            rec_every = max(1, int(round(sc.output_interval / sc.step)))
            record(self._sample(0.0))
            energy = {c[0]: {"work_from": 0.0, "work_to": 0.0} for c in self._couplings}
            prev_power = self._coupling_power()
            order = [s.name for s in sc.instances]
            jacobi = sc.algorithm == "jacobi"
            h = sc.step
            t = 0.0
            if not jacobi:   # Gauss-Seidel in scene order: the loop below, the same calls
                done = [0]
                try:
                    self._gauss_seidel(n_steps, h, rec_every, energy, prev_power, record, done)
                finally:
                    steps = done[0]
            for k in range(n_steps if jacobi else 0):
                t = k * h
                if STOP.is_set():
                    raise Interrupted(t)
                self._communication_step(t, h, order, jacobi)
                steps += 1
                prev_power = self._add_work(energy, prev_power, h)
                if (k + 1) % rec_every == 0 or k + 1 == n_steps:
                    for name in order:
                        self._read_outputs(name, self._rec_ports)
                    record(self._sample((k + 1) * h))
                if self.progress is not None and k % 200 == 0:
                    self.progress((k + 1) / n_steps)
        except RunFailure as e:
            failure = e
        except Interrupted as e:   # Ctrl-C under stop_on_sigint: stopped between two steps
            failure = e
        finally:
            flush()
            self._free()
        if self.progress is not None and not isinstance(failure, Interrupted):
            self.progress(1.0)
        data = store[:rows].copy() if rows < len(store) // 2 else store[:rows]
        wall = time.perf_counter() - t_wall - sink_time
        return Result(sc, list(sc.record), data, wall, steps, failure, energy, self._messages(), setup_time=t_setup)

    def _gauss_seidel(self, n_steps: int, h: float, rec_every: int, energy: dict, prev_power: dict,
                      record: Callable[[list], None], done: list) -> None:
        """The fixed-step Gauss-Seidel loop of :meth:`run`: what :meth:`_communication_step`,
        :meth:`_add_work`, the recording reads and :meth:`_sample` do, the same FMI calls in the
        same order and the same arithmetic, with every lookup made once. Per instance: its input
        port with where its sources' values are, its fmi2DoStep with converted arguments, its
        per-step read port. The values a step read publishes live in one list per instance for the
        loop (copied out of the port's C array in one call, read by index; the value tables keyed
        by (type, value reference) cost a tuple hash per value), written back into the master's
        tables when the loop ends. ``record`` takes each recorded row, ``done[0]`` counts the
        steps done."""
        from ctypes import c_double

        values = self._values
        tt, hh = c_double(0.0), c_double(h)
        # the step reads: instance -> (keys, the list of their values, key -> index)
        step_lists: dict[str, tuple[tuple, list, dict]] = {}
        for name, _, _, _, _, read in self._plan:
            if read is not None and read != "all":
                keys = tuple(read[1])
                step_lists[name] = (keys, [values[name][k] for k in keys], {k: i for i, k in enumerate(keys)})

        def where(inst: str, key) -> tuple:
            """(container, index) of a published value: its step list, else the instance's table."""
            sl = step_lists.get(inst)
            if sl is not None and key in sl[2]:
                return sl[1], sl[2][key]
            return values[inst], key

        profiles = [(self._profile_port[n], tuple(p for _, p in profs)) for n, profs in self._profiles.items() if profs]
        plan = []
        for name, sport, srcs, _, _, read in self._plan:
            # fmi2DoStep with its arguments converted once (the time and step as c_double objects
            # set once per step, see Instance.fast_function)
            do, comp = self.instances[name].fast_function("fmi2DoStep"), self.instances[name].c_component
            src = tuple(where(s, k) for s, k in srcs)
            if name in step_lists:
                port = read[0]
                view = memoryview(port.val).cast("B").cast("d")   # the C array's doubles, as floats in one call
                plan.append((name, sport, src, do, comp, port.fn, port.args, port._failed, view, step_lists[name][1],
                             False))
            else:
                plan.append((name, sport, src, do, comp, None, None, None, None, None, read == "all"))
        couplings = [(energy[cname], *where(ti, tv), sign, *where(fi, fv), *where(oi, ov))
                     for cname, ((ti, tv), (fi, fv), (oi, ov)), sign in self._couplings]
        prev = [prev_power[c[0]] for c in self._couplings]
        rec_reads = [n for n in self._order if self._rec_ports[n]]
        recorded = [where(i, key) for i, key in self._record]
        progress, is_set = self.progress, STOP.is_set
        try:
            for k in range(n_steps):
                t = k * h
                if is_set():
                    raise Interrupted(t)
                tt.value = t
                for port, profs in profiles:
                    port.set([p(t) for p in profs], t)
                for name, sport, src, do, comp, rfn, rargs, rfail, view, out, read_all in plan:
                    if sport is not None:
                        sport.set([c[i] for c, i in src], t)
                    status = do(comp, tt, hh, 1)   # noSetFMUStatePriorToCurrentPoint
                    if status > 1:   # discard, error, fatal
                        raise RunFailure(name, t, self.instances[name].last_messages()
                                         or f"fmi2DoStep returned status {status}")
                    if rfn is not None:
                        status = rfn(*rargs)
                        if status > 1:
                            rfail(status, t)   # raises RunFailure(name, t, ...)
                        out[:] = view.tolist()
                    elif read_all:
                        self._read_outputs(name)
                done[0] = k + 1
                # the work over each coupling (trapezoidal rule), as _add_work computes it
                for j, (e, ct, it, sign, cf, i_f, co, io) in enumerate(couplings):
                    tau = sign * ct[it]
                    p_from, p_to = tau * cf[i_f], tau * co[io]
                    p0 = prev[j]
                    e["work_from"] += 0.5 * (p_from + p0[0]) * h
                    e["work_to"] += 0.5 * (p_to + p0[1]) * h
                    prev[j] = (p_from, p_to)
                if (k + 1) % rec_every == 0 or k + 1 == n_steps:
                    for name in rec_reads:
                        self._read_outputs(name, self._rec_ports)
                    row = [(k + 1) * h]
                    row += [c[i] for c, i in recorded]
                    record(row)
                if progress is not None and k % 200 == 0:
                    progress((k + 1) / n_steps)
        finally:
            for name, (keys, out, _) in step_lists.items():
                values[name].update(zip(keys, out))

    def _start(self) -> None:
        """Load, wire and initialize every instance, and read all it publishes."""
        self._instantiate()
        self._compile()
        self._initialize()
        for name in self.instances:
            self._read_outputs(name)

    def _add_work(self, energy: dict[str, dict[str, float]], prev_power: dict, h: float) -> dict:
        """Add a step of length ``h`` to the work over each coupling (trapezoidal rule, from the
        power before it); returns the power now."""
        power = self._coupling_power()
        for cname, (p_from, p_to) in power.items():
            e = energy[cname]
            e["work_from"] += 0.5 * (p_from + prev_power[cname][0]) * h
            e["work_to"] += 0.5 * (p_to + prev_power[cname][1]) * h
        return power

    def _messages(self) -> list[str]:
        """What the FMUs logged at fmi2Warning or worse, as 'instance: message'."""
        return [f"{n}: {m}" for n, inst in self.instances.items() for s, m in inst.messages if s >= 1]

    def _step(self, name: str, t: float, h: float) -> None:
        inst = self.instances[name]
        status = self._do_step[name](inst.component, t, h, 1)   # noSetFMUStatePriorToCurrentPoint
        if status > 1:   # discard, error, fatal
            raise RunFailure(name, t, inst.last_messages() or f"fmi2DoStep returned status {status}")

    def _sample(self, t: float) -> list[float]:
        row = [t]
        for inst, vr in self._record:
            row.append(self._values[inst][vr])
        return row

    def _coupling_power(self) -> dict[str, tuple[float, float]]:
        out = {}
        for cname, refs, sign in self._couplings:
            (ti, tv), (fi, fv), (oi, ov) = refs
            tau = sign * self._values[ti][tv]
            out[cname] = (tau * self._values[fi][fv], tau * self._values[oi][ov])
        return out

    def _free(self) -> None:
        for inst in self.instances.values():
            inst.close()


def run_scene(scene: Scene, fmu_files: dict[str, Path], progress=None, sink=None) -> Result:
    """Run a scene once; the result carries a failure instead of raising for FMU errors (and an
    :class:`Interrupted` failure after Ctrl-C under :func:`stop_on_sigint`). ``sink`` receives each
    recorded row as it is recorded."""
    return Master(scene, fmu_files, progress, sink).run()

