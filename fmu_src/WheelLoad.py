"""WheelLoad.fmu: half-shaft, wheel and longitudinal tyre of one driven wheel (FMI 2.0 co-simulation).

A thin adapter: the interface and its mapping onto the physics live in
:mod:`spurdiff.wheel_fmu`, the FMI plumbing in :mod:`spurdiff.fmi_adapter`.
Causality: flange angle and speed in, flange torque out (couples to the differential's sun
flange); wheel load and wheel-centre speed in, tyre force out (couples to the vehicle).
"""
from spurdiff import wheel_fmu as interface
from spurdiff.fmi_adapter import ModelFmu


class WheelLoad(ModelFmu):
    """Compliant half-shaft, wheel inertia and transient-slip Magic Formula tyre of one driven wheel."""

    description = ("Wheel load of one driven wheel: compliant half-shaft, wheel inertia and transient-slip "
                   "Magic Formula longitudinal tyre")
    VARIABLES = interface.VARIABLES

    def build_model(self, values):
        return interface.build_model(values)

    def push_inputs(self, model, values):
        interface.push_inputs(model, values)

    def pull_outputs(self, model, values):
        interface.pull_outputs(model, values)
