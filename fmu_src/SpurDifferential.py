"""SpurDifferential.fmu: the spur-gear planetary differential as an FMI 2.0 co-simulation FMU.

A thin adapter: the interface and its mapping onto the physics live in
:mod:`spurdiff.differential_fmu`, the FMI plumbing in :mod:`spurdiff.fmi_adapter`.
Causality: torques in, speeds and angles out (couple it to compliant half-shafts).
"""
from spurdiff import differential_fmu as interface
from spurdiff.fmi_adapter import ModelFmu


class SpurDifferential(ModelFmu):
    """Spur-gear planetary inter-wheel differential."""

    description = ("Spur-gear planetary inter-wheel differential: two suns on the half-shafts, pairs of "
                   "meshing planets on a driven carrier, pin-bushing friction locking")
    VARIABLES = interface.VARIABLES

    def build_model(self, values):
        model = interface.build_model(values)
        if values["solver.kernelInUse"] != "none":      # which implementation runs the mesh level, and why
            self.log(f"meshModel = {values['meshModel']}: {values['solver.kernelInUse']} implementation")
        return model

    def push_inputs(self, model, values):
        interface.push_inputs(model, values)

    def pull_outputs(self, model, values):
        interface.pull_outputs(model, values)
