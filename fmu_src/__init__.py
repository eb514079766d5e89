"""The FMU sources as package data (``spurdiff_fmus``): ``native/``, the C sources of the FMUs'
binaries: ``native/fmi/`` the loader, bridge and server (the FMI side), ``native/kernels/`` the
compiled steps of the models. The FMUs themselves are declared in the ``spurdiff`` physics package
(``spurdiff.fmi.differential_fmu``, ``wheel_fmu``, ``vehicle_fmu``), from which the build
(:mod:`harness.build`) generates each FMU's pythonfmu script; it reads the C sources from here, in
a checkout and in an installed wheel."""
