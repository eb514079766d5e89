"""harness: runs the FMUs of ``spurdiff`` through FMI (fmpy), and builds, checks and measures them.

One package per concept, each importing only the packages above it in this list (siblings on one
line never import each other; ``tests/test_imports.py`` checks it, docs/architecture.md draws it):

* :mod:`harness.cli`: the command line (``spurdiff COMMAND``), the only place with argparse;
* :mod:`harness.interop`: other engines: SSP export, libcosim, starters for your own tool, recipes;
* :mod:`harness.measure` (bench, accuracy, the FMI 3.0 features, FMI 2.0 against 3.0, ``info``),
  :mod:`harness.sweep` (design sweeps on Dask), :mod:`harness.check` (the compliance kit);
* :mod:`harness.run`: running a scene: the masters, the direct runs, results, report, plots;
* :mod:`harness.fmi` (the one FMU wrapper over fmpy), :mod:`harness.build` (building the FMUs);
* :mod:`harness.scene`: what a scene file says (schema, expressions, input profiles, limits);
* :mod:`harness.common`: shared pieces: paths, safe output files, messages, Ctrl-C, the import graph.

Data: the scene files in ``harness/scenes/``, the sweep files in ``harness/sweeps/``. Any harness
package may import :mod:`spurdiff`; :mod:`spurdiff` never imports the harness. This module imports
nothing.
"""
