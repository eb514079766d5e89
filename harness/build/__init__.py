"""Building the FMUs: :mod:`.fmu` builds the FMI 2.0 FMUs into ``build/fmus/`` (pythonfmu, the C
loader and kernels; :data:`~harness.build.fmu.FMUS` names them), :mod:`.fmu3` the FMI 3.0 ones from
them; :mod:`.modeldescription` and :mod:`.modeldescription3` write their modelDescription.xml,
:mod:`.fmu_package` the FMU's copy of ``spurdiff``, :mod:`.runtime_bundle` the Python runtime each
FMU carries (probed with the standalone script :mod:`.runtime_probe`, needs read by :mod:`.elf`),
:mod:`.runtime_win64` the win64 binaries and runtime.

May import: :mod:`harness.common` and :mod:`spurdiff`. Nothing here runs a scene.
"""
