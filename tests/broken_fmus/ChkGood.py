"""ChkGood: a small, well-behaved FMI 2.0 co-simulation FMU for the compliance-checker tests, and the
base of the broken variants (each ``ChkX.py`` subclasses it and breaks one thing; chk_build.py packs
this file beside each).

Model: x' = k u (explicit Euler over each communication step), y = k u (direct feedthrough).
It tracks the FMI state machine and refuses what FMI 2.0 forbids, the way a pythonfmu FMU can:
``do_step`` returns False (fmi2Discard) before initialization, for a step size <= 0 and for
non-finite inputs (outputs then show NaN); setting the fixed parameter ``k`` after
initialization raises, which pythonfmu turns into fmi2Fatal (an error status).
A step past a stop time given to fmi2SetupExperiment is refused (fmi2Discard: the only refusal a
pythonfmu ``do_step`` can give; FMI 2.0 section 2.1.6 asks for fmi2Error, so cs.stop-time warns).
The state lives in registered variables only, so pythonfmu's saved state is complete; it is
restored by assigning the attributes directly (the default restore calls the setters, and k's
setter refuses after initialization). Built with --handle-state --serialize-state.

Hooks for the variants: :meth:`init_state` (the integrator state at construction, which
pythonfmu's fmi2Reset runs again), :meth:`past_stop` (the stop-time refusal), ``_set_fmu_state``
and ``do_step``. A variant must define at least one method of its own: pythonfmu 0.7 instantiates
a class without one once, then fails the next fmi2Instantiate of the process ("module has no
attribute").
"""

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.default_experiment import DefaultExperiment


class ChkGood(Fmi2Slave):
    description = "Integrator x' = k u with feedthrough y = k u (compliance-checker test FMU)"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=0.1, step_size=0.01)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.u = 1.0
        self.k = 2.0
        self.init_state()
        self.y = 2.0
        self.phase = 0.0  # 0 instantiated, 1 initializing, 2 stepping (a Real so state save keeps it)
        self.stop_time = None
        self.register_variable(Real("u", causality=Fmi2Causality.input,
                                    variability=Fmi2Variability.continuous, description="input signal"))
        self.register_variable(Real("k", causality=Fmi2Causality.parameter,
                                    variability=Fmi2Variability.fixed, description="gain",
                                    setter=self._set_k))
        self.register_variable(Real("x", causality=Fmi2Causality.output,
                                    variability=Fmi2Variability.continuous, description="integral of k u"))
        self.register_variable(Real("y", causality=Fmi2Causality.output,
                                    variability=Fmi2Variability.continuous, description="k u"))
        self.register_variable(Real("phase", causality=Fmi2Causality.local,
                                    variability=Fmi2Variability.discrete,
                                    description="FMI state: 0 instantiated, 1 initializing, 2 stepping"))

    def init_state(self):
        self.x = 0.0

    def _set_k(self, value):
        if self.phase >= 2:
            raise RuntimeError("k is a fixed parameter: it cannot be set after initialization")
        self.k = value

    def _set_fmu_state(self, state):
        # pythonfmu's default restore goes through the setters, and k's setter refuses after
        # initialization: restore the attributes directly.
        for name, value in state.items():
            setattr(self, name, value)

    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self.stop_time = stop_time

    def enter_initialization_mode(self):
        self.phase = 1.0

    def exit_initialization_mode(self):
        self.y = self.k * self.u
        self.phase = 2.0

    def past_stop(self, current_time, step_size) -> bool:
        return self.stop_time is not None and current_time + step_size > self.stop_time * (1 + 1e-12) + 1e-12

    def do_step(self, current_time, step_size):
        if self.phase < 2 or not step_size > 0:
            return False
        if self.past_stop(current_time, step_size):
            return False
        self.y = self.k * self.u
        self.x += self.y * step_size
        return True
