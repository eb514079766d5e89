"""Watches on a differential model's run: components that look at the model after each
communication step, keep their own outputs (attributes) and state, and report a finding once.

In the manner of the Modelica Standard Library's effects, each watch is a component of its own on
one base (:class:`Watch`), and a model carries them in ``model.watches`` (:func:`attach`):

* :class:`CapacityWatch`: the gear set rated at a carrier torque (ISO 6336 safety factors,
  :mod:`spurdiff.gears.capacity`) with the locked split at break-away (:func:`rating_forces`), the
  load-sharing factor and K_v at the run's pitch-line speed, the limited life over the duty cycle,
  then the run's largest contact and root stresses from the mesh forces, and one warning when they
  exceed the material's static strength;
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

from spurdiff.errors import Bound, check_fields
from spurdiff.differential.bushing import bushing
from spurdiff.differential.locking import breakaway, dynamic_pin_model, pin_friction
from spurdiff.errors import ParameterError, require_positive
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


def rating_forces(geo, mu: float, r_d: float, T0: float, law: str = "pinFriction", *pin_model) -> dict[str, float]:
    """The mesh forces (N, mean per pair) a limited-slip differential is rated at under the carrier
    torque ``T0`` (N m): the locked split at break-away (:func:`spurdiff.differential.locking.breakaway`,
    pin lever ``mu r_d``, the locking law ``law`` and ``pin_model`` (pinModel, pairHandedness,
    pinContactFactor: :func:`spurdiff.differential.locking.pin_friction`'s defaults when not given)),
    each mesh's largest over drive and coast and
    either sun running ahead; the equal split without pin friction. The sun meshes carry up to
    ``(1 + K) / 2`` of the torque, mesh 12 follows planet 1's moment balance."""
    F = cap.nominal_mesh_forces(geo, T0)
    if not (mu > 0.0 and r_d > 0.0 and T0 != 0.0):
        return F
    pf = pin_friction(geo, mu, r_d, 0.0, law, *pin_model)
    for sign in (1.0, -1.0):
        for s in (1.0, -1.0):
            b = breakaway(pf, sign * abs(T0), s)
            F = {"A1": max(F["A1"], abs(b.F_A1)), "B2": max(F["B2"], abs(b.F_B2)), "12": max(F["12"], abs(b.F_12))}
    return F


class CapacityWatch(cap.StressWatch, Watch):
    """The load capacity: the rating at ``params.T0`` (``report``, the safety factors; ``T0``) with
    the locked split at break-away (:func:`rating_forces`), the load-sharing factor
    ``params.K_gamma`` (0: the default for nPairs) and K_v at the pitch-line speed of the model's
    state at initialization (``v``); the limited life over the bundled duty cycle (``life``); and the
    stress watch of :class:`spurdiff.gears.capacity.StressWatch` over the run (outputs
    ``sigma_H_max``, ``sigma_F_max``, ``exceeded_indicator``)."""

    name, key = "capacity_watch", "capacity"
    _FRESH = (0.0, 0.0, False, (0.0, 0.0, 0.0))    # before any step (a state without the entry)

    def __init__(self, model, params: cap.CapacityParams):
        check_fields(params, "capacity.")
        self.T0 = float(params.T0)
        mat = cap.material(params.material)
        wall = params.bushingWall
        p, geo = model.params, model.geometry
        bores = cap.pin_bores(p.r_collar, wall)   # the planets turn on journals (Y_B)
        cond = cap.conditions(K_gamma=params.K_gamma)
        forces = rating_forces(geo, p.mu_pin, p.r_collar, self.T0, p.lockingLaw, *dynamic_pin_model(p))
        v = cap.pitch_line_speed(geo, model.wd)
        self.report = cap.capacity_report(geo, forces, mat, cond, bores, v=v)
        self.life = cap.life_report(geo, cap.scaled(forces, 1.0 / self.T0), mat=mat, cond=cond, bores=bores)
        super().__init__(geo, forces, mat, cond, bores, v=v, report=self.report)   # (the same rating)

    def after_step(self, model, t: float, h: float) -> str | None:
        f = model.mesh_forces
        return self.update(f.F_A1, f.F_B2, f.F_12)

    def start_message(self) -> str | None:
        rep = self.report
        found = rep.findings + self.life.findings
        if not found:
            return None
        n_err = sum(f.level == "error" for f in found)
        first = next((f for f in found if f.level == "error"), found[0])
        return (f"load capacity at capacity.T0 = {self.T0:g} N m, locked split, K_gamma "
                f"{rep.meshes[0].K_gamma:g}, pitch-line speed {self.v:.3g} m/s ({self.mat.name}): static safety "
                f"S_H {rep.S_H_static:.3f}, S_F {rep.S_F_static:.3f}; limited life over the duty cycle "
                f"{self.life.S:.3f}; {n_err} errors, {len(found) - n_err} warnings, first: {first}")

    def set_state(self, s, model=None) -> None:
        super().set_state(self._FRESH if s is None else s)


# overspeedLimit's range (spurdiff.errors: the watch's check and the FMU's min/max)
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


__all__ = ["Watch", "CapacityWatch", "rating_forces", "OverspeedWatch", "Watched", "watched_class", "attach", "INFO", "WARNING"]
