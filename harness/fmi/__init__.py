"""The harness's side of FMI: one wrapper around fmpy for every FMU instance (:mod:`.instance`;
an FMI 3.0 instance with the same API in :mod:`.instance3`, fmpy's log lines in :mod:`.fmpy_logging`).

May import: :mod:`harness.scene` (its errors and the typing of a value), :mod:`harness.common` and
:mod:`spurdiff`.
"""
from .instance import (REFUSED, STATUS_LABELS, CallFailed, FmuCache, Instance, Port, RealPort, fmu_cache,
                       make_logger, status_label)

__all__ = ["REFUSED", "STATUS_LABELS", "CallFailed", "FmuCache", "Instance", "Port", "RealPort", "fmu_cache", "make_logger",
           "status_label"]
