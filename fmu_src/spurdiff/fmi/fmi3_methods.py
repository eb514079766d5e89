"""What only the FMI 3.0 binary asks of an FMU instance (``fmu_src/native/fmi/fmi3_loader.c`` maps
each FMI 3.0 call onto the bridge's FMI 2.0 one, and these two onto calls of their own): the output
derivatives (fmi3GetOutputDerivatives, from the interface's ``output_rates``) and the step that
returns early at a stick/slip switch (fmi3DoStep with earlyReturnAllowed,
:mod:`spurdiff.differential.transitions`). A mixin of :class:`spurdiff.fmi.adapter.ModelFmu`: it
uses the adapter's state machine (``phase``, ``time``, ``_refuse``, ``fmi2_do_step``, the value
table and the step's bindings)."""
from __future__ import annotations

import math

from pythonfmu.enums import Fmi2Status

from spurdiff.fmi.state import ERROR, OK, WARNING


class Fmi3Methods:
    """The FMI 3.0 calls of :class:`spurdiff.fmi.adapter.ModelFmu`."""

    # ------------------------------------------------------------------ output derivatives (FMI 3.0)
    max_output_derivative_order = 0   # the interface's MAX_OUTPUT_DERIVATIVE_ORDER (fmu_class)
    output_rates = None               # the interface's output_rates(model) -> {attribute: derivative}
    # the time of a state set by fmi2SetFMUstate: the end-of-step rates are not part of an FMU state
    # (the wheel sides' deviations at the step's end are not), so there are none until a step
    _rates_unknown_at = math.nan

    def fmi2_set_state(self, state) -> int:
        status = super().fmi2_set_state(state)
        if status in (None, OK, WARNING):
            self._rates_unknown_at = self.time
        return status

    def fmi2_get_real_output_derivatives(self, vrs, orders) -> tuple[int, list[float]]:
        """(status, values): the ``orders``-th time derivatives of the Real outputs at ``vrs`` at the
        FMU's time (FMI 3.0 fmi3GetOutputDerivatives; only the FMI 3.0 binary passes the call on)."""
        fn = "fmi3GetOutputDerivatives"
        if self.phase != "stepping":
            return self._refuse(ERROR, f"{fn} refused in state '{self.phase}' (only after "
                                       "fmi3ExitInitializationMode)"), []
        top = self.max_output_derivative_order
        names = self._get["Real"]
        for vr, k in zip(vrs, orders):
            name = names.get(vr)
            if name is None or name not in self._output_set:
                what = f"variable {name}" if name else "no Real variable"
                return self._refuse(ERROR, f"{fn}: value reference {vr} is {what}, not a Float64 output"), []
            if not 1 <= k <= top:
                return self._refuse(ERROR, f"{fn}: order {k} for {name} is outside 1..{top} "
                                           f"(maxOutputDerivativeOrder = {top})"), []
        if self.time == self._rates_unknown_at:
            return self._refuse(ERROR, f"{fn}: the derivatives at t = {self.time:g} s are not in the FMU state "
                                       "that was set; they are given again after the next fmi3DoStep"), []
        try:
            rates = self.output_rates(self.model)
        except Exception as e:
            return self._refuse(ERROR, f"{fn} failed: {type(e).__name__}: {e}"), []
        out = []
        for vr in vrs:
            name = names[vr]
            x = rates.get(self._bind_of[name])
            if x is None:
                return self._refuse(ERROR, f"{fn}: output {name} has no derivative (offered: "
                                           f"{', '.join(self._rate_outputs(rates))})"), []
            out.append(float(x))
        return OK, out

    # ------------------------------------------------------------------ early return (FMI 3.0)
    might_return_early = False        # the interface's MIGHT_RETURN_EARLY (fmu_class)

    def fmi2_do_step_early(self, t: float, h: float, no_set_prior: bool = False) -> tuple[int, float]:
        """(status, time reached): fmi2DoStep that ends just past the first stick/slip switch
        inside the step (spurdiff.differential.transitions), for the FMI 3.0 binary's fmi3DoStep
        with earlyReturnAllowed. Without a switch it is fmi2DoStep, the same call."""
        model = self.model
        if not self.might_return_early or self.phase != "stepping" or model is None:
            return self.fmi2_do_step(t, h, no_set_prior), self.time
        saved, n0 = model.get_state(), model.n_mode_switches
        status = self.fmi2_do_step(t, h, no_set_prior)
        if status != OK or model.n_mode_switches == n0:
            return status, self.time
        from spurdiff.differential.transitions import transition_step

        push, pull, pull_total, _ = self._step_io
        values = self.values

        def step(hh: float) -> int:
            model.set_state(saved)
            push(model, values)
            model.do_step(t, hh)
            return model.n_mode_switches

        try:
            hx = transition_step(step, h, n0)
        except Exception as e:   # a shorter step the model refuses: the whole step stands
            self._log(f"fmi3DoStep at t = {t:g} s: no early return ({type(e).__name__}: {e})", Fmi2Status.warning)
            step(h)
            hx = None
        pull_total(model, values)
        if hx is not None:
            self.time = t + hx
        return OK, self.time

    def _rate_outputs(self, rates: dict) -> list[str]:
        return [n for n in self._outputs if self._bind_of[n] in rates]
