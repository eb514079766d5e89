"""The native step: a model's whole communication step compiled, over one array of doubles, so that
a host steps it without entering Python.

A model that has one answers ``native_step()`` with a :class:`NativeStep`: the compiled function
``int64_t fn(const double *constants, double *v, double t, double h)``, its constants, and the array
``v`` whose first slots are the model's inputs and outputs (named by the model attributes the FMU
variables bind to), the rest its state and scratch. The function does what the model's ``do_step``
does (the input checks, the step, the outputs; the same operations, so the same numbers bit for
bit, the Python code staying the reference) and returns 0, or anything else for a step it does not
take (an input the model refuses, a non-finite result): then nothing but scratch changed, and the
caller runs the model's ``do_step``, which takes the step or raises saying why.

While a host steps natively, the state lives in ``v``: :meth:`NativeStep.load` puts the model's
state there and :meth:`NativeStep.store` takes it back into the model, before anything else reads
the model. The FMUs' bridge (``fmu_src/native/fmi/fmi2_pybridge.c``, with
:mod:`spurdiff.fmi.native_methods`) and the harness's direct runs (``harness/direct.py``) do so.
The models that have one: the car and the wheel (:mod:`spurdiff.vehicle.kernel`), the differential
owning its half-shafts at rigid with the FMU's watches (:mod:`spurdiff.differential.shaft_kernel`).
"""
from __future__ import annotations

import ctypes as C
from typing import Any, Sequence


class NativeStep:
    """One model's native step: the function, its constants, the array and the slots' names."""

    integers: dict[str, int] = {}     # Integer outputs the array holds: model attribute -> slot

    def __init__(self, fn: Any, const: Any, size: int, inputs: Sequence[str], outputs: Sequence[str]):
        self.fn = fn                      # the ctypes function (argtypes: two pointers, two doubles)
        self.const = const                # a ctypes double array
        self.v = (C.c_double * size)()
        self.inputs = tuple(inputs)       # the model attributes of v[0], v[1]...
        self.outputs = tuple(outputs)     # of the slots after the inputs
        self.addresses = (C.cast(fn, C.c_void_p).value, C.addressof(const), C.addressof(self.v))

    def load(self, model) -> bool | None:
        """The model's state, outputs and inputs (those its last step took) into ``v``; the caller
        then puts the inputs of the coming step into the input slots. False: the state does not fit
        now (the Python step runs)."""
        raise NotImplementedError

    def store(self, model) -> None:
        """``v``'s state and outputs into the model, with the inputs its last step took as the
        model's inputs (the input slots may hold values stored since, which the model has not
        seen: they go to the caller's value table, as before a Python step)."""
        raise NotImplementedError

    def step(self, t: float, h: float) -> bool:
        """The step in C: True taken (``v`` holds the new state and outputs), False not taken
        (``v`` as before but for scratch: run the model's ``do_step`` after :meth:`store`)."""
        return self.fn(self.const, self.v, t, h) == 0


__all__ = ["NativeStep"]
