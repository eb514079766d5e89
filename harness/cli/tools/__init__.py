"""The developers' ``python -m`` entries beside the ``spurdiff`` commands: kernel and coupling
benches (``python -m harness.cli.tools.mesh_bench``, ``rigid_kernel_bench``, ``vehicle_kernel_bench``,
``coupling_bench``), measurements (``pin_tangential``, ``fmi3_features``, ``fmi_versions``), the
libcosim runner (``libcosim_run``) and the import-graph check (``import_graph``). Each parses its
own arguments and prints; none is a ``spurdiff`` command.

May import: every harness package, :mod:`harness.cli` (its ``fail``) and :mod:`spurdiff`; nothing
imports it.
"""
