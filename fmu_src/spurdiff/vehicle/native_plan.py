"""The native step of a model whose step has a compiled kernel (the car, the wheel): the plan a
host that steps without Python runs (:mod:`spurdiff.native_step`), made once per kernel."""
from __future__ import annotations


class NativeStepMixin:
    """``native_step`` for a model with ``_vk`` (its compiled kernel in use, or None), ``_ready``,
    ``params.nativeStep`` and ``_native_plan(vk)`` (its plan on that kernel)."""

    def native_step(self):
        """The whole step in C for a host that steps without Python (:mod:`spurdiff.native_step`), or
        None (no compiled kernel in use, ``params.nativeStep`` false, or not initialized); the same plan
        while the kernel is the same."""
        vk = self._vk if self._ready and self.params.nativeStep else None
        if vk is None:
            return None
        plan = self.__dict__.get("_native")
        if plan is None or plan.const is not vk.const:
            plan = self._native = self._native_plan(vk)
        return plan
