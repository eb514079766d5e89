"""The harness's side of FMI: one wrapper around fmpy for every FMU instance (:mod:`.instance`)."""
from .instance import (REFUSED, STATUS_LABELS, CallFailed, FmuCache, Instance, Port, RealPort, fmu_cache,
                       make_logger, status_label)

__all__ = ["REFUSED", "STATUS_LABELS", "CallFailed", "FmuCache", "Instance", "Port", "RealPort", "fmu_cache", "make_logger",
           "status_label"]
