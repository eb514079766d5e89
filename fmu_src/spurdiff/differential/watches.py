"""Watches on a differential model's run: components that look at the model after each
communication step, keep their own outputs (attributes) and state, and report a finding once.

In the manner of the Modelica Standard Library's effects, each watch is a component of its own on
one base (:class:`Watch`), and a model carries them in ``model.watches`` (:func:`attach`):

* :class:`CapacityWatch`: the gear set rated at a carrier torque (ISO 6336 safety factors,
  :mod:`spurdiff.gears.capacity`), then the run's largest contact and root stresses from the mesh
  forces, and one warning when they exceed the material's static strength;
* :class:`OverspeedWatch`: ``indicator`` 1 while the differential speed ``|w_A - w_c|`` is above
  a limit (0: the pin bushings' sliding-speed limit, :mod:`spurdiff.differential.bushing`), and one
  warning the first time (the paper scenes' constant torques above break-away run away).

The step hook is :class:`Watched`, the mixin of the model's watched class: its ``do_step`` steps
the model, then the watches (their messages go to the logger ``log_to`` gave, as warnings); its
``get_state`` / ``set_state`` carry the watches' state under their ``key`` in the model's state.
Only the outermost model is watched: the inner model of a
:class:`spurdiff.differential.shafts.ShaftedDifferential` is stepped several times per step by
the half-shaft solve, and keeps its class (no cost there).
"""
from __future__ import annotations

import math

from spurdiff.bounds import Bound, check_fields
from spurdiff.differential.bushing import bushing
from spurdiff.gears import capacity as cap

INFO, WARNING = 0, 1     # the levels of the logger ``log_to`` gives: log(message, level)


class Watch:
    """The base of the watches: what a :class:`Watched` model calls."""

    name = "watch"            # the model's attribute that holds it (its outputs: model.<name>.<output>)
    key: str | None = None    # the entry of the model's state that carries this watch's (None: none)

    def after_step(self, model, t: float, h: float) -> str | None:
        """Look at ``model`` after its step from ``t`` to ``t + h``; a finding to log as a warning, or None."""
        return None

    def start_message(self) -> str | None:
        """What to log (as information) once the logger is given, or None."""
        return None

    def get_state(self):
        """This watch's state (JSON values; with a ``key`` only)."""
        return None

    def set_state(self, s, model=None) -> None:
        """Take the state ``s`` (None: the model's state had no entry for it), after ``model``'s own."""


class CapacityWatch(cap.StressWatch, Watch):
    """The load capacity: the rating at ``params.T0`` (``report``, the safety factors; ``T0``) and
    the stress watch of :class:`spurdiff.gears.capacity.StressWatch` over the run (outputs
    ``sigma_H_max``, ``sigma_F_max``, ``exceeded_indicator``)."""

    name, key = "capacity_watch", "capacity"
    _FRESH = (0.0, 0.0, False, (0.0, 0.0, 0.0))    # before any step (a state without the entry)

    def __init__(self, model, params: cap.CapacityParams):
        check_fields(params, "capacity.")
        self.T0 = float(params.T0)
        mat = cap.material(params.material)
        wall = params.bushingWall
        bores = cap.pin_bores(model.params.r_collar, wall)   # the planets turn on journals (Y_B)
        forces = cap.nominal_mesh_forces(model.geometry, self.T0)
        self.report = cap.capacity_report(model.geometry, forces, mat, None, bores)
        super().__init__(model.geometry, forces, mat, self.report.conditions, bores)

    def after_step(self, model, t: float, h: float) -> str | None:
        f = model.mesh_forces
        return self.update(f.F_A1, f.F_B2, f.F_12)

    def start_message(self) -> str | None:
        rep = self.report
        if not rep.findings:
            return None
        n_err = sum(f.level == "error" for f in rep.findings)
        first = next((f for f in rep.findings if f.level == "error"), rep.findings[0])
        return (f"load capacity at capacity.T0 = {self.T0:g} N m ({self.mat.name}): smallest safety factors S_H "
                f"{rep.S_H:.3f} (static {rep.S_H_static:.3f}), S_F {rep.S_F:.3f} (static {rep.S_F_static:.3f}); "
                f"{n_err} errors, {len(rep.findings) - n_err} warnings, first: {first}")

    def set_state(self, s, model=None) -> None:
        super().set_state(self._FRESH if s is None else s)


# overspeedLimit's range (spurdiff.bounds: the watch's check and the FMU's min/max)
OVERSPEED_LIMIT = Bound(0.0, allowed=">= 0 rad/s (0: from the pin bushings)")


class OverspeedWatch(Watch):
    """``indicator`` 1.0 while ``|w_A - w_c|`` is above ``limit`` (rad/s), else 0.0; one warning the
    first time. ``limit`` 0: the pin bushings' sliding-speed limit (``pin_bushing.toml``, C93200
    bronze 3.81 m/s) over the journal radius ``r_collar`` and the planets' spin ratio ``rho``
    (z_sun / z_planet, the larger side); no pins: no limit. Not in the model's state: the indicator
    follows the model's, and the warning is once per instance."""

    name = "overspeed_watch"

    def __init__(self, model, limit: float = 0.0):
        OVERSPEED_LIMIT.check("overspeedLimit", limit)
        t = model.geometry.table
        self.rho = max(t.sunA.z / t.planet1.z, t.sunB.z / t.planet2.z)
        r_j = model.params.r_collar
        if limit == 0.0:
            limit = bushing("bronze").vMax / (r_j * self.rho) if r_j > 0.0 else math.inf
        self.limit = limit
        self.warned = False
        self.set_state(None, model)      # the indicator of the model's present state

    def after_step(self, model, t: float, h: float) -> str | None:
        wd = abs(model.wd)
        over = wd > self.limit
        self.indicator = 1.0 if over else 0.0
        if over and not self.warned:
            self.warned = True
            return (f"overspeed, |w_A - w_c| = {wd:.4g} rad/s > overspeedLimit = {self.limit:.4g} rad/s (planets at "
                    f"{self.rho * wd:.4g} rad/s on their pins): the differential runs away; the results past this "
                    f"point are no longer of rated hardware")
        return None

    def set_state(self, s, model=None) -> None:
        self.indicator = 1.0 if abs(model.wd) > self.limit else 0.0


class Watched:
    """The step hook of a watched model (the mixin of :func:`watched_class`): ``watches`` looked at
    after each step, their state in the model's, their messages to the logger of :meth:`log_to`."""

    watches: tuple = ()
    _kept: tuple = ()          # the watches with a state (a key)
    _log = None
    _plain: type               # the model's own class (the methods stepped and extended here)

    def log_to(self, log) -> None:
        """Log through ``log(message, level)`` from now on; the watches' start messages now."""
        self._log = log
        for w in self.watches:
            msg = w.start_message()
            if msg is not None:
                log(msg, INFO)

    def do_step(self, t: float, h: float) -> None:
        self._plain.do_step(self, t, h)
        for w in self.watches:
            msg = w.after_step(self, t, h)
            if msg is not None and self._log is not None:
                self._log(f"t = {t + h:g} s: {msg}", WARNING)

    def get_state(self) -> dict:
        s = self._plain.get_state(self)
        for w in self._kept:
            s[w.key] = w.get_state()
        return s

    def set_state(self, state: dict) -> None:
        self._plain.set_state(self, state)
        for w in self.watches:
            w.set_state(state.get(w.key) if w.key is not None else None, self)


_WATCHED: dict[type, type] = {}


def watched_class(cls: type) -> type:
    """The watched variant of the model class ``cls``: one per class (the FMU's bindings compile per
    class), made at the first model and then a name of this module (``WatchedRigidDifferential``...:
    found by name like any class, e.g. in an FMU's copy of the package by harness.measure.bench.core.fmu_copies)."""
    c = _WATCHED.get(cls)
    if c is None:
        c = _WATCHED[cls] = type(f"Watched{cls.__name__}", (Watched, cls),
                                 {"_plain": cls, "__module__": __name__, "__doc__": f"{cls.__name__} with watches."})
        globals()[c.__name__] = c
    return c


def attach(model, watches) -> None:
    """Give the initialized outermost ``model`` its ``watches`` (in the order they look at a step),
    each also as ``model.<watch.name>``: the model becomes an instance of its watched class
    (:func:`watched_class`)."""
    model.__class__ = watched_class(model.__class__)
    for w in watches:
        setattr(model, w.name, w)
    model.watches = tuple(watches)
    model._kept = tuple(w for w in model.watches if w.key is not None)


__all__ = ["Watch", "CapacityWatch", "OverspeedWatch", "Watched", "watched_class", "attach", "INFO", "WARNING"]
