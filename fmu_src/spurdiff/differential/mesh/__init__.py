"""The compliant and contact levels of the differential: gear-mesh dynamics with switchable
effects (backlash, stiffness wave, pin and flank friction).

Modules: :mod:`.params` (parameters and their limits), :mod:`.layout` (state vector, mesh
geometry), :mod:`.laws` (force and friction laws), :mod:`.forces` (the effects and the
right-hand side), :mod:`.events`, :mod:`.stickslip` (friction modes), :mod:`.integrator`
(ROS34PW2, RODAS5P), :mod:`.stepper` (the driver over a communication step), :mod:`.kernel` (the same
communication step compiled, fmu_src/native/kernels/mesh_kernel.c, through ctypes), :mod:`.model`
(:class:`MeshDifferential`). Documentation: docs/mesh-dynamics.md.

May import: the rest of :mod:`spurdiff.differential` (parameters, statics, the locking law, the rigid
level for the stick-slip start), :mod:`spurdiff.gears` and the core.
"""
from spurdiff.errors import StepError
from spurdiff.differential.mesh.params import LEVELS, N_PER_MM15, MeshParams


def __getattr__(name: str):
    """:class:`MeshDifferential` imported when first asked for: a rigid run never loads the mesh levels'
    modules (a quicker FMU start), only their parameters."""
    if name == "MeshDifferential":
        from spurdiff.differential.mesh.model import MeshDifferential
        return MeshDifferential
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

__all__ = ["MeshDifferential", "MeshParams", "LEVELS", "N_PER_MM15", "StepError"]
