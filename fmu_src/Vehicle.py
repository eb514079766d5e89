"""Vehicle.fmu: planar rear-wheel-drive car with speed and path control (FMI 2.0 co-simulation).

A thin adapter: the interface and its mapping onto the physics live in
:mod:`spurdiff.vehicle_fmu`, the FMI plumbing in :mod:`spurdiff.fmi_adapter`.
Causality: rear tyre forces in; wheel-centre speeds, wheel loads and the axle drive torque out.
"""
from spurdiff import vehicle_fmu as interface
from spurdiff.fmi_adapter import ModelFmu


class Vehicle(ModelFmu):
    """Planar vehicle body with axle-level lateral tyres, load transfer, speed and steering control."""

    description = ("Planar rear-wheel-drive vehicle: body, axle lateral tyres, load transfer, "
                   "speed and path-following steering control")
    VARIABLES = interface.VARIABLES

    def build_model(self, values):
        return interface.build_model(values)

    def push_inputs(self, model, values):
        interface.push_inputs(model, values)

    def pull_outputs(self, model, values):
        interface.pull_outputs(model, values)
