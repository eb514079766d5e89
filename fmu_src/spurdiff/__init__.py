"""spurdiff: physics of a spur-gear planetary inter-wheel differential, and its FMUs.

Plain Python on floats and lists, the standard library only (the solvers and the small linear algebra are
our own, :mod:`spurdiff.numerics`; the hot loops are compiled, ``fmu_src/native``); no FMI needed below
:mod:`spurdiff.fmi`. The packages, each importing only those below it (docs/architecture.md):

* :mod:`spurdiff.fmi`: the FMI layer (variables, bindings, the three FMU declarations, the adapter);
* :mod:`spurdiff.differential` and :mod:`spurdiff.vehicle`: the models;
* :mod:`spurdiff.gears`: the gear set (geometry, checks, pin layout, phasing);
* the core at the top: :mod:`.errors`, :mod:`.datafile` (with ``data/``), :mod:`.numerics`,
  :mod:`.native_library`, :mod:`.native_step`; this module imports nothing.
"""
__version__ = "0.1.0"
