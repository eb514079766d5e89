"""spurdiff: physics of a spur-gear planetary inter-wheel differential.

Plain Python (numpy, scipy); no FMI needed. The FMU adapters in ``fmu_src/*.py`` and the
harness build on these modules.
"""
__version__ = "0.1.0"
