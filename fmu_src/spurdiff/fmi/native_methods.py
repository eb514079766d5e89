"""The bridge's native step (``fmu_src/native/fmi/fmi2_pybridge.c``): a model with a compiled whole
step (``model.native_step()``, :mod:`spurdiff.native_step`) steps without Python while the host
only steps it and sets and gets its Real inputs and outputs; the bridge hands the state back before
any other call reaches the instance. A mixin of :class:`spurdiff.fmi.adapter.ModelFmu`: it uses the
adapter's state machine (``phase``, ``time``, the stop time, ``_inputs_ok``, the value table and the
step's bindings)."""
from __future__ import annotations

import operator

from spurdiff.fmi import native_start
from spurdiff.fmi.binding import slot_names
from spurdiff.fmi.state import OK


class NativeMethods:
    """``fmi2_native_enter`` and ``fmi2_native_leave``, the bridge's two calls, and the hand-over of the
    native step to the host's process (``fmi2_native_export``, ``fmi2_native_import``)."""

    _native_key: tuple | None = None   # (model, plan) the tuple below is of
    _native_tuple: tuple | None = None  # the plan as the bridge takes it

    def fmi2_native_enter(self):
        """False: this instance has no native step (the model has none, e.g. ``solver.kernel =
        python; the bridge does not ask again). None: not now (not stepping, or inputs stored since
        their last check: :meth:`fmi2_do_step` checks them first). Else the model's inputs as the
        value table has them and its state are in the plan's array, and the answer is (time,
        stop time, its tolerance's first term, (function, constants, array, names, n_in, parameter
        names, integers, early), parameter values): the addresses, the value-table name of each input
        and output slot (None where the FMU has no variable for it), the number of input slots, the
        Real parameters (constant while stepping: a host reads them there), the Integer outputs the
        array holds as (value reference, slot) pairs, 1 when the model may end a step early (FMI
        3.0's early return: the bridge then takes that step in Python), and the parameters' values."""
        model = self.model
        native_step = getattr(model, "native_step", None)
        if native_step is None:
            return False
        if self.phase != "stepping" or not self._inputs_ok:
            return None
        plan = native_step()
        if plan is None:
            return False
        if self._native_key is None or self._native_key[0] is not model or self._native_key[1] is not plan:
            slots = slot_names(self.VARIABLES, plan)
            params = tuple(v.name for v in self.VARIABLES
                           if v.kind == "Real" and v.causality in ("parameter", "calculatedParameter"))
            int_vr = {name: vr for vr, name in self._get["Integer"].items()}
            ints = tuple(x for v in self.VARIABLES if v.kind == "Integer" and v.causality == "output"
                         and v.bind in plan.integers for x in (int_vr[v.name], plan.integers[v.bind]))
            self._native_tuple = (*plan.addresses, slots, len(plan.inputs), params, ints,
                                  1 if self.might_return_early else 0)
            self._native_params = operator.itemgetter(*params) if len(params) > 1 else (
                lambda d, _p=params: tuple(d[n] for n in _p))
            self._native_key = (model, plan)
        values, v, slots = self.values, plan.v, self._native_tuple[3]
        if plan.load(model) is False:
            return None
        for i in range(len(plan.inputs)):    # the inputs of the coming step, as the value table has them
            if slots[i] is not None:
                v[i] = values[slots[i]]
        return self.time, self._stop, self._stop_tol, self._native_tuple, self._native_params(values)

    def fmi2_native_leave(self, time: float, bad: int, steps: int) -> None:
        """The state after ``steps`` native steps back from the plan's array: into the model, its
        outputs into the value table (the bindings' pull) with the inputs stored since; the FMU's
        time. ``bad``: an input outside its declared range was stored (the next step checks them
        all and refuses naming it)."""
        model, plan = self._native_key
        plan.store(model)
        values, v, slots = self.values, plan.v, self._native_tuple[3]
        for i in range(len(plan.inputs)):
            if slots[i] is not None:
                values[slots[i]] = v[i]
        self._io.io(model)[1](model, values)
        self.time = time
        if steps:
            self.last_step_status = OK
            self.step_failed = False
        if bad:
            self._inputs_ok = False

    def fmi2_native_export(self):
        """The hand-over to the host's process (the model in its own process): the bytes
        :func:`spurdiff.fmi.native_start.live` makes, False (never for this model: the loader stops
        asking until an fmi2Reset or fmi2SetFMUstate), or None (not now). The state is in the plan's
        arrays until :meth:`fmi2_native_import`. Inputs stored since their last check are checked
        here as :meth:`fmi2_do_step` checks them (one outside its range: not now, the step in Python
        refuses naming it)."""
        if self.phase == "stepping" and not self._inputs_ok:
            if self._in_ranges(self._input_values(self.values)):
                self._inputs_ok = True
        return native_start.live(self)

    def fmi2_start_snapshot(self, data: bytes):
        """The start cache (``fmu_src/native/fmi/fmi2_loader.c``: keep_start): the native start of this
        FMU's class with the values ``data`` set (:func:`spurdiff.fmi.native_start.decode_sets`), made in
        fresh instances as the build makes ``native_start.bin``; None when it has none."""
        try:
            return native_start.snapshot(type(self), native_start.decode_sets(data))
        except (native_start.NoSnapshot, ValueError):
            return None

    def fmi2_native_import(self, data: bytes, time: float, bad: int, steps: int) -> int:
        """The state back from the host after ``steps`` steps there: the arrays (``data``, see
        :func:`spurdiff.fmi.native_start.restore`) into the plan, then :meth:`fmi2_native_leave`."""
        native_start.restore(self, data)
        self.fmi2_native_leave(time, bad, steps)
        return 0


__all__ = ["NativeMethods"]
