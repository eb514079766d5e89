"""Other engines and your own tool: :mod:`.ssp` exports a scene as an SSP archive, :mod:`.libcosim_run`
runs one with DNV's libcosim, :mod:`.starter` writes a ready-to-run starter (``spurdiff starter``)
from the standalone :mod:`.recipes` (scripts and a C host that import nothing of the harness).

May import: :mod:`harness.measure`, :mod:`harness.run`, :mod:`harness.build`, :mod:`harness.fmi`,
:mod:`harness.scene`, :mod:`harness.common` and :mod:`spurdiff`.
"""
