"""SpurDifferential.fmu: the spur-gear planetary differential as an FMI 2.0 co-simulation FMU.

A thin adapter over :mod:`spurdiff` (physics) and :mod:`spurdiff.fmi_adapter` (FMI plumbing).
Causality: torques in, speeds and angles out (couple it to compliant half-shafts).
"""

from spurdiff.differential_fmu import DIFFERENTIAL_VARIABLES, build_differential, pull_differential, push_differential
from spurdiff.fmi_adapter import ModelFmu

class SpurDifferential(ModelFmu):
    """Spur-gear planetary inter-wheel differential (Lin/ADAMS-style paper model)."""

    description = ("Spur-gear planetary inter-wheel differential: two suns on the half-shafts, pairs of "
                   "meshing planets on a driven carrier, pin-bushing friction locking")
    VARIABLES = DIFFERENTIAL_VARIABLES

    def build_model(self, values):
        return build_differential(values)

    def push_inputs(self, model, values):
        push_differential(model, values)

    def pull_outputs(self, model, values):
        pull_differential(model, values)
