"""The FMU sources as package data (``spurdiff_fmus``): one script per FMU (a thin pythonfmu class
over the ``spurdiff`` physics package) and ``native/``, the C sources of the FMUs' binary. The
build (:mod:`harness.build`) reads them from here, in a checkout and in an installed wheel."""
