"""Run a scene with the physics called directly in Python, without FMI.

Same scene, same coupling loop (Gauss-Seidel or Jacobi, same step, same recording) and the same
interface modules the FMUs use (``spurdiff.<name>_fmu``: VARIABLES and build_model), with the same
compiled bindings (:mod:`spurdiff.fmi.binding`: push the inputs, step, pull the outputs), so the only
difference from :mod:`harness.run.master` is the FMI layer (our C bridge and the adapter's checks,
fmpy's ctypes calls, value references). Used by the benchmark to measure what FMI
costs; scene runs for users go through the FMUs.
"""
from __future__ import annotations

import importlib
import operator
import time

import numpy as np

from spurdiff.fmi.binding import bindings, slot_names

from harness.build.fmu import FMUS as INTERFACES   # FMU name -> interface module (the FMUs' declarations)
from harness.run.master import RunFailure
from harness.run.result import Result
from harness.scene.spec import Scene, SceneError


class DirectInstance:
    def __init__(self, name: str, fmu: str, parameters: dict):
        if fmu not in INTERFACES:
            raise SceneError(f"{name}: no direct interface for FMU {fmu!r}; allowed: {', '.join(INTERFACES)}")
        self.name = name
        self.iface = importlib.import_module(INTERFACES[fmu])
        self.vars = {v.name: v for v in self.iface.VARIABLES}
        self.values = {v.name: v.start for v in self.iface.VARIABLES}
        for k, val in parameters.items():
            if k not in self.vars:
                raise SceneError(f"{name}: FMU has no variable {k!r}")
            self.values[k] = val
        self.io = bindings(self.iface.VARIABLES)
        self.model = None
        self.native = None          # the model's native step in use (spurdiff.native_step), or None
        self._native_in = ()        # (slot, variable) of the inputs it reads from the value table
        self._native_out = ()       # the variables of its output slots
        self._pick = None           # the output slots' values out of v[:n]
        self._native_n = 0
        self._loaded = False        # the model's state is in the native step's array

    def initialize(self) -> None:
        self.model = self.iface.build_model(self.values)
        self.io.pull(self.model, self.values)
        self.native = None
        self._loaded = False

    def use_native(self, read: set[str], written: set[str]) -> bool:
        """Step with the model's native step (its whole step in C, as the FMU's bridge does) when it
        has one whose slots cover the outputs the run reads (``read``) and the inputs it sets
        (``written``); else the Python step. True when it does."""
        get = getattr(self.model, "native_step", None)
        plan = get() if get is not None else None
        if plan is None:
            return False
        slots = list(enumerate(slot_names(self.iface.VARIABLES, plan)))
        ins, outs = slots[:len(plan.inputs)], slots[len(plan.inputs):]
        read = {n for n in read if self.vars[n].causality == "output"}       # (parameters stay)
        written = {n for n in written if self.vars[n].causality == "input"}  # (a push ignores the rest)
        if not (read <= {n for _, n in outs} and written <= {n for _, n in ins}):
            return False
        self.native = plan
        self._native_in = tuple((i, n) for i, n in ins if n is not None)
        named = [(i, n) for i, n in outs if n is not None]
        self._native_out = tuple(n for _, n in named)
        self._pick = operator.itemgetter(*(i for i, _ in named))
        self._native_n = len(ins) + len(outs)
        self._loaded = False
        return True

    def step(self, t: float, h: float) -> None:
        model, values = self.model, self.values
        push, pull = self.io.io_of.get(model.__class__) or self.io.io(model)
        plan = self.native
        if plan is not None:
            v = plan.v
            if not self._loaded:
                self._loaded = plan.load(model) is not False
            for i, name in self._native_in:
                v[i] = values[name]
            if self._loaded and plan.fn(plan.const, v, t, h) == 0:
                values.update(zip(self._native_out, self._pick(v[:self._native_n])))
                return
            if self._loaded:
                plan.store(model)   # not taken: the Python step takes it or says why not
            self._loaded = False
        push(model, values)
        model.do_step(t, h)
        pull(model, values)


def run_direct(scene: Scene, native: bool = True) -> Result:
    """Run ``scene`` with direct physics calls; returns a :class:`Result` like the master's.
    ``native``: the models' native steps where they have them (:meth:`DirectInstance.use_native`),
    as the FMUs' bridge runs them; False: every step in Python."""
    t0 = time.perf_counter()
    insts = {}
    for spec in scene.instances:
        insts[spec.name] = DirectInstance(spec.name, spec.fmu, scene.parameters_of(spec.name))
    profiles = [(ref.split(".", 1), prof) for ref, prof in scene.inputs.items()]
    links = [(to.split(".", 1), frm.split(".", 1)) for to, frm in scene.connections.items()]
    by_dest: dict[str, list] = {n: [] for n in insts}
    for (ti, tv), (fi, fv) in links:
        by_dest[ti].append((tv, fi, fv))
    record = [(insts[r.split(".", 1)[0]].values, r.split(".", 1)[1]) for r in scene.record]
    order = [s.name for s in scene.instances]

    def apply_profiles(t):
        for (i, v), prof in profiles:
            insts[i].values[v] = prof(t)

    def apply_links(name):
        vals = insts[name].values
        for tv, src, fv in by_dest[name]:
            vals[tv] = insts[src].values[fv]

    failure = None
    rows = []
    steps = 0
    try:
        # initialization as the master does it (FMI Initialization Mode): the connections
        # propagated in one Jacobi sweep per instance, every source's outputs computed from the
        # values it was given so far; then every instance built from its final values
        apply_profiles(0.0)
        sources = sorted({src for dests in by_dest.values() for _, src, _ in dests}, key=order.index)
        name = order[0] if order else ""
        try:
            for _ in range(len(order)):
                for name in sources:
                    insts[name].initialize()
                pending = [(insts[n].values, tv, insts[src].values[fv]) for n in order for tv, src, fv in by_dest[n]]
                for vals, tv, x in pending:
                    vals[tv] = x
            for name in order:
                insts[name].initialize()
        except Exception as e:
            raise RunFailure(name, 0.0, str(e)) from None
        if native:   # each model's native step where it covers what the run reads and sets
            read = {n: {fv for dests in by_dest.values() for _, src, fv in dests if src == n} for n in insts}
            written = {n: {tv for tv, _, _ in by_dest[n]} for n in insts}
            for (i, v), _ in profiles:
                written[i].add(v)
            for r in scene.record:
                i, v = r.split(".", 1)
                read[i].add(v)
            for name in order:
                insts[name].use_native(read[name], written[name])
        setup = time.perf_counter() - t0
        t_loop = time.perf_counter()
        rows.append([0.0] + [d[k] for d, k in record])
        h = scene.step
        n = int(round(scene.duration / h))
        every = max(1, int(round(scene.output_interval / h)))
        jacobi = scene.algorithm == "jacobi"
        for k in range(n):
            t = k * h
            apply_profiles(t)
            try:
                if jacobi:  # every instance sees the outputs of the previous step
                    pending = [(insts[name].values, tv, insts[src].values[fv])
                               for name in order for tv, src, fv in by_dest[name]]
                    for vals, tv, x in pending:
                        vals[tv] = x
                    for name in order:
                        insts[name].step(t, h)
                else:
                    for name in order:
                        apply_links(name)
                        insts[name].step(t, h)
            except RunFailure:
                raise
            except Exception as e:
                raise RunFailure(name, t, str(e)) from None
            steps += 1
            if (k + 1) % every == 0 or k + 1 == n:
                rows.append([(k + 1) * h] + [d[kk] for d, kk in record])
        wall = time.perf_counter() - t_loop
        for inst in insts.values():   # the models as the native steps left them (counters, state)
            if inst.native is not None and inst._loaded:
                inst.native.store(inst.model)
    except RunFailure as e:
        failure = e
        setup = time.perf_counter() - t0
        wall = 0.0
    data = np.array(rows, dtype=float) if rows else np.zeros((0, 1 + len(scene.record)))
    return Result(scene, list(scene.record), data, wall, steps, failure, setup_time=setup)

