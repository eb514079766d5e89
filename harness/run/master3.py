"""The FMI 3.0 co-simulation features in the master: first-order hold with output derivatives and
early return (issue 28 item 2). :class:`Master3` runs a scene like :class:`harness.run.master.Master`
(the same wiring, initialization, recording and coupling-energy bookkeeping) with its own stepping
loop, in which both features are switches, so ZOH and FOH, with and without early return, are
timed on the same loop:

* ``hold = "foh"``: an FMU declaring ``maxOutputDerivativeOrder >= 1`` is asked, after each of
  its steps, for the first derivatives of its connected outputs that it gives (which ones: asked
  once after initialization, each alone; the others stay held). An input whose source's value is
  older than the step about to start (Jacobi, or a Gauss-Seidel back edge: the source steps after
  the consumer) is set to the first-order extrapolation at the middle of the step, ``y + y' (t + h/2
  - t_y)``: the FMU holds an input constant over its step (FMI 3.0 has no input derivatives), and
  the middle value is the step mean of the extrapolated line. A value the source computed for this
  step (a Gauss-Seidel forward edge) is passed as it is: nothing to extrapolate.
* ``early_return = True`` (Gauss-Seidel only): FMUs declaring ``mightReturnEarlyFromDoStep`` are
  instantiated with ``earlyReturnAllowed``. When one returns early at ``t_x`` (a stick/slip switch
  of the differential), the FMUs before it in the order are set back to the step's start with the
  FMU state taken there (``fmi3GetFMUState`` before each step, when such an FMU follows them) and
  stepped to ``t_x`` with the same inputs; the FMUs after it step to ``t_x`` with its outputs
  there; the step then goes on from ``t_x`` to the grid point (more switches: more pieces). The
  results are recorded on the grid as with the plain master.

``stats`` counts the early returns, the pieces, the rollbacks and the derivative reads.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Callable

from harness.fmi.instance3 import Instance3, open_instance
from harness.common.interrupt import STOP, Interrupted
from harness.run.master import Master, RunFailure
from harness.run.result import Result
from harness.scene.spec import Scene, SceneError

HOLDS = ("zoh", "foh")


class Master3(Master):
    """:class:`~harness.run.master.Master` with the FMI 3.0 features as switches (see the module docstring)."""

    def __init__(self, scene: Scene, fmu_files: dict[str, Path], hold: str = "zoh", early_return: bool = False,
                 progress: Callable[[float], None] | None = None, sink: Callable[[list[float]], None] | None = None):
        if hold not in HOLDS:
            raise SceneError(f"hold = {hold!r}: allowed {', '.join(HOLDS)}")
        if early_return and scene.algorithm == "jacobi":
            raise SceneError("early return: Gauss-Seidel scenes only (algorithm = jacobi given)")
        super().__init__(scene, fmu_files, progress, sink)
        self.hold, self.early_return = hold, early_return
        self.stats = {"early_returns": 0, "pieces": 0, "rollbacks": 0, "derivative_reads": 0}

    # ------------------------------------------------------------------ setup
    def _instantiate(self) -> None:
        for spec in self.scene.instances:
            if spec.fmu not in self.fmu_files:
                raise SceneError(f"{spec.name}: unknown FMU {spec.fmu!r}; allowed: {', '.join(sorted(self.fmu_files))}")
            probe = open_instance(spec.name, self.fmu_files[spec.fmu], instantiate=False)
            early = self.early_return and isinstance(probe, Instance3) and probe.might_return_early
            probe.close()
            self.instances[spec.name] = open_instance(spec.name, self.fmu_files[spec.fmu],
                                                      **({"early_return": True} if early else {}))

    def _start(self) -> None:
        super()._start()
        self._early = {n for n, inst in self.instances.items()
                       if self.early_return and isinstance(inst, Instance3) and inst.might_return_early}
        if len(self._early) > 1:
            raise SceneError(f"early return: one FMU that may return early per scene ({', '.join(sorted(self._early))})")
        # the instances before an early-returning one: their state is kept at each step's start
        first = min((self._order.index(n) for n in self._early), default=len(self._order))
        self._rollback = self._order[:first] if self._early else []
        # first derivatives: per source instance, the connected outputs it gives them for
        self._deriv: dict[str, tuple[list, Callable[[], list]]] = {}
        self._dval: dict[str, dict] = {}
        self._vtime: dict[str, float] = {n: 0.0 for n in self.instances}
        if self.hold == "foh":
            wanted: dict[str, list] = {}
            for _, srcs in self._links.values():
                for src, key in srcs:
                    if key not in wanted.setdefault(src, []):
                        wanted[src].append(key)
            for src, keys in wanted.items():
                inst = self.instances[src]
                if not (isinstance(inst, Instance3) and inst.max_output_derivative_order >= 1):
                    continue
                given = []
                for key in keys:   # asked one by one: an output without a derivative is refused alone
                    try:
                        inst.output_derivatives([key[1]])()
                        given.append(key)
                    except Exception:
                        pass
                inst.messages.clear()   # the refusals of the probe are not the run's messages
                if given:
                    self._deriv[src] = (given, inst.output_derivatives([k[1] for k in given],
                                                                       fail=self._fail_of(src)))
                    self._dval[src] = dict(zip(given, self._deriv[src][1]()))

    def _fail_of(self, name: str) -> Callable[[str], None]:
        def fail(reason: str):
            raise RunFailure(name, self._vtime.get(name, math.nan), reason)
        return fail

    # ------------------------------------------------------------------ stepping
    def _set_inputs(self, name: str, t: float, h: float) -> None:
        """Connections of ``name`` for its step [t, t + h]: held, or extrapolated to its middle."""
        links = self._links[name]
        if not links[0]:
            return
        values, dval, vtime = self._values, self._dval, self._vtime
        out = []
        for src, key in links[1]:
            y = values[src][key]
            d = dval.get(src)
            if d is not None and key in d and vtime[src] <= t + 1e-12:
                y = y + d[key] * (t + 0.5 * h - vtime[src])
            out.append(y)
        self._set_port[name].set(out, t)

    def _step_one(self, name: str, t: float, h: float) -> float:
        """Step ``name`` from t by h (inputs set first); its outputs read. Returns the time reached."""
        self._set_inputs(name, t, h)
        inst = self.instances[name]
        status = self._do_step[name](inst.component, t, h, 1)
        if status > 1:
            raise RunFailure(name, t, inst.last_messages() or f"fmi3DoStep returned status {status}")
        reached = t + h
        if name in self._early and inst.last_step[2]:   # earlyReturn
            reached = inst.last_step[3]
        self._read_step(name, t)
        self._vtime[name] = reached
        if name in self._deriv:
            keys, read = self._deriv[name]
            self._dval[name] = dict(zip(keys, read()))
            self.stats["derivative_reads"] += 1
        return reached

    def _piece(self, t: float, dt: float) -> float:
        """One Gauss-Seidel pass from t by dt (the step as the plain master passes it: the same
        arithmetic); returns the time all instances reached (t + dt, or an early return's)."""
        self._apply_profiles(t)
        saved = {}
        if self._rollback:
            for n in self._rollback:
                saved[n] = (self.instances[n].slave.getFMUState(), dict(self._values[n]), self._dval.get(n),
                            self._vtime[n])
        try:
            target = t + dt
            for i, name in enumerate(self._order):
                reached = self._step_one(name, t, dt)
                if reached < target - 1e-12 * max(1.0, abs(target)):
                    self.stats["early_returns"] += 1
                    target, dt = reached, reached - t
                    # the instances before it: back to t, then to the switch with the same inputs
                    for n in self._order[:i]:
                        inst = self.instances[n]
                        state, vals, dv, vt = saved[n]
                        inst.slave.setFMUState(state)
                        self._values[n].clear()
                        self._values[n].update(vals)
                        if dv is not None:
                            self._dval[n] = dv
                        self._vtime[n] = vt
                        for port in (self._set_port[n], self._profile_port[n]):
                            if port is not None:
                                port.forget()
                        self.stats["rollbacks"] += 1
                    self._apply_profiles(t)
                    for n in self._order[:i]:
                        self._step_one(n, t, dt)
            self.stats["pieces"] += 1
            return target
        finally:
            for n, (state, *_rest) in saved.items():
                self.instances[n].slave.freeFMUState(state)

    def _gauss_seidel(self, n_steps: int, h: float, rec_every: int, energy: dict, prev_power: dict,
                      record: Callable[[list], None], done: list) -> None:
        for k in range(n_steps):
            t, t_end = k * h, (k + 1) * h
            if STOP.is_set():
                raise Interrupted(t)
            while t < t_end - 1e-12 * max(1.0, t_end):
                t_next = self._piece(t, h if t == k * h else t_end - t)
                prev_power = self._add_work(energy, prev_power, t_next - t)
                t = t_next
            done[0] = k + 1
            if (k + 1) % rec_every == 0 or k + 1 == n_steps:
                for name in self._order:
                    self._read_outputs(name, self._rec_ports)
                record(self._sample(t_end))
            if self.progress is not None and k % 200 == 0:
                self.progress((k + 1) / n_steps)

    def _communication_step(self, t: float, h: float, order: list[str], jacobi: bool) -> None:
        if not jacobi:
            self._piece(t, h)
            return
        self._apply_profiles(t)
        for name in order:
            self._set_inputs(name, t, h)
        for name in order:
            inst = self.instances[name]
            status = self._do_step[name](inst.component, t, h, 1)
            if status > 1:
                raise RunFailure(name, t, inst.last_messages() or f"fmi3DoStep returned status {status}")
        for name in order:
            self._read_step(name, t)
            self._vtime[name] = t + h
            if name in self._deriv:
                keys, read = self._deriv[name]
                self._dval[name] = dict(zip(keys, read()))
                self.stats["derivative_reads"] += 1


def run_scene3(scene: Scene, fmu_files: dict[str, Path], hold: str = "zoh", early_return: bool = False,
               progress=None, sink=None) -> tuple[Result, dict]:
    """Run a scene on :class:`Master3`; (result, stats)."""
    m = Master3(scene, fmu_files, hold, early_return, progress, sink)
    return m.run(), m.stats
