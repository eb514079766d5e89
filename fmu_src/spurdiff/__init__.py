"""spurdiff: physics of a spur-gear planetary inter-wheel differential.

Plain Python (numpy only: the solvers are our own, :mod:`spurdiff.numerics`); no FMI needed. The
FMUs are declared in ``differential_fmu``, ``wheel_fmu`` and ``vehicle_fmu`` (variables bound to
the models, :mod:`spurdiff.binding`), made into FMU classes by :func:`spurdiff.fmi_adapter.fmu_class`;
the harness builds on these modules.
"""
__version__ = "0.1.0"
