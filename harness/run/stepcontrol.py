"""Variable communication steps driven by the coupling energy residual (power bonds, ECCO-like).

After Sadjina, Kyllingstad, Skjong and Pedersen (2017), "Energy conservation and power bonds in
co-simulations: non-iterative adaptive step size control and error estimation": each power bond
of the scene (``[[couplings]]``: a torque and the speed on each side) exchanges a torque and a
speed held over the step, so the energy the two sides book differs by what the hold misses. Over
a step from t_k to t_k+1 this residual is estimated from the changes of the bond's torque and
the receiving side's speed::

    dE = h / 2 (|tau_k+1 - tau_k| |w_mean| + |tau_mean| |w_k+1 - w_k|)

and scaled by the tolerance ``atol + rtol |tau_mean w_mean| h`` (J). The error ``e`` is the
largest scaled residual of all bonds. A step with ``e > 1`` is rejected: every FMU is restored
with fmi2SetFMUstate to the state it had before the step (taken with fmi2GetFMUstate), and the
step is redone with a smaller h (``reject = False``: never redone, no state saved; the error
only sets the next step, the non-iterative form of the paper). Accepted steps set the next h by a PI controller
``h_new = h safety e^(-k_i) (e_prev / e)^(k_p)``, limited to ``[h_min, h_max]`` and to a change
of at most ``grow`` / ``shrink`` per step.

Used by ``spurdiff bench`` (fixed versus variable steps on tip-in-tip-out) and by
:func:`run_variable`. It reuses the master's wiring (connections, profiles, recording); only the
stepping loop differs. Recorded rows are those of the accepted steps (irregular times).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from harness.run.master import Interrupted, Master, RunFailure, STOP
from harness.run.result import Result
from harness.scene.schema import positive
from harness.scene.spec import Scene, SceneError


@dataclass
class StepControl:
    """Settings of the power-bond step controller (SI: s, J)."""

    h_min: float = 1e-4
    h_max: float = 2e-2
    h_start: float = 1e-3
    rtol: float = 1e-3
    atol: float = 1e-3
    safety: float = 0.9
    k_i: float = 0.3
    k_p: float = 0.2
    grow: float = 2.0
    shrink: float = 0.2
    max_rejects: int = 20
    # False: never redo a step (no FMU state saved per step; the error of a step only sets the next
    # one, as the non-iterative control of Sadjina et al.)
    reject: bool = True

    def validate(self) -> None:
        for name in ("h_min", "h_max", "h_start", "rtol", "safety", "grow"):
            positive(f"step control: {name}", getattr(self, name))
        if not self.h_min <= self.h_start <= self.h_max:
            raise SceneError(f"step control: h_start = {self.h_start} must lie in [h_min, h_max] = "
                             f"[{self.h_min}, {self.h_max}]")
        if not 0.0 < self.shrink < 1.0 or self.grow <= 1.0:
            raise SceneError("step control: shrink must lie in (0, 1) and grow above 1")
        if not self.atol >= 0.0:
            raise SceneError(f"step control: atol = {self.atol!r}; allowed: >= 0")


def bond_error(prev: dict, now: dict, h: float, ctl: StepControl) -> float:
    """Largest scaled energy residual of the bonds over one step. ``prev``/``now`` map a bond
    name to (torque, receiving speed) at the start and the end of the step."""
    e = 0.0
    for name, (tau1, w1) in now.items():
        tau0, w0 = prev[name]
        tm, wm = 0.5 * (tau0 + tau1), 0.5 * (w0 + w1)
        dE = 0.5 * h * (abs(tau1 - tau0) * abs(wm) + abs(tm) * abs(w1 - w0))
        e = max(e, dE / (ctl.atol + ctl.rtol * abs(tm * wm) * h))
    return e


class VariableStepMaster(Master):
    """The master's wiring with a variable, energy-controlled communication step."""

    def __init__(self, scene: Scene, fmu_files, control: StepControl | None = None):
        super().__init__(scene, fmu_files)
        self.control = control or StepControl()
        self.rejected = 0
        self.steps_taken: list[float] = []

    def _bonds(self) -> dict:
        out = {}
        for cname, refs, sign in self._couplings:
            (ti, tv), _, (oi, ov) = refs
            out[cname] = (sign * self._values[ti][tv], self._values[oi][ov])
        return out

    def _save(self):
        return ({n: inst.slave.getFMUState() for n, inst in self.instances.items()},
                {n: dict(v) for n, v in self._values.items()})

    def _restore(self, saved) -> None:
        states, values = saved
        for n, inst in self.instances.items():
            inst.slave.setFMUState(states[n])
        for n, v in values.items():
            self._values[n] = dict(v)
        # the restored FMUs hold the inputs of their saved state: send every input again
        for port in list(self._set_port.values()) + list(self._profile_port.values()):
            if port is not None:
                port.forget()

    def _free_states(self, saved) -> None:
        for n, s in saved[0].items():
            try:
                self.instances[n].slave.freeFMUState(s)
            except Exception:
                pass

    def run(self) -> Result:
        sc, ctl = self.scene, self.control
        ctl.validate()
        if not sc.couplings:
            raise SceneError(f"{sc.name}: variable steps need power bonds ([[couplings]]) to measure the residual")
        t_wall = time.perf_counter()
        rows, failure, energy, t, steps = [], None, {}, 0.0, 0
        try:
            self._start()
            t_setup = time.perf_counter() - t_wall
            t_wall = time.perf_counter()
            rows.append(self._sample(0.0))
            order = [s.name for s in sc.instances]
            jacobi = sc.algorithm == "jacobi"
            energy = {c[0]: {"work_from": 0.0, "work_to": 0.0} for c in self._couplings}
            h, e_prev = ctl.h_start, 1.0
            while t < sc.duration - 1e-12 * max(1.0, sc.duration):
                if STOP.is_set():
                    raise Interrupted(t)
                h = min(h, sc.duration - t)
                prev_bonds, prev_power = self._bonds(), self._coupling_power()
                if not ctl.reject:
                    self._communication_step(t, h, order, jacobi)
                    err = bond_error(prev_bonds, self._bonds(), h, ctl)
                else:
                    saved = self._save()
                    for attempt in range(ctl.max_rejects + 1):
                        self._communication_step(t, h, order, jacobi)
                        err = bond_error(prev_bonds, self._bonds(), h, ctl)
                        if err <= 1.0 or h <= ctl.h_min * (1.0 + 1e-12):
                            break
                        self.rejected += 1
                        self._restore(saved)
                        h = max(ctl.h_min, h * max(ctl.shrink, ctl.safety * err ** -0.5))
                    else:
                        raise RunFailure("step control", t, f"{ctl.max_rejects} rejected steps in a row")
                    self._free_states(saved)
                self._add_work(energy, prev_power, h)
                t += h
                steps += 1
                self.steps_taken.append(h)
                for name in order:
                    self._read_outputs(name)
                rows.append(self._sample(t))
                e = max(err, 1e-10)
                factor = ctl.safety * e ** -ctl.k_i * (e_prev / e) ** ctl.k_p
                h = min(ctl.h_max, max(ctl.h_min, h * min(ctl.grow, max(ctl.shrink, factor))))
                e_prev = e
        except (RunFailure, Interrupted) as exc:
            failure = exc
            t_setup = locals().get("t_setup", 0.0)
        finally:
            self._free()
        return Result(sc, list(sc.record), np.array(rows), time.perf_counter() - t_wall, steps, failure, energy,
                      self._messages(), setup_time=t_setup)


def run_variable(scene: Scene, fmu_files, control: StepControl | None = None) -> tuple[Result, VariableStepMaster]:
    """Run a scene with the energy-controlled variable step; returns the result and the master
    (its ``steps_taken`` and ``rejected`` counts)."""
    m = VariableStepMaster(scene, fmu_files, control)
    return m.run(), m
