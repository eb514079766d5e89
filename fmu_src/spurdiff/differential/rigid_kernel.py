"""The compiled kernel of the rigid level (``fmu_src/native/kernels/rigid_kernel.c``) through ctypes.

The rigid level's hot path is the Newton solve of the planets' moment balances while the
differential slips with the pin-load locking law (:meth:`spurdiff.differential.rigid.RigidDifferential._slip_exact`,
one per inner step of a differential owning its half-shafts): ``rk_slip`` does that solve, and
``rk_step_slip`` the whole usual step of a carrier torque-driven model slipping throughout
(:meth:`spurdiff.differential.rigid.RigidDifferential._step_compiled`). Both transcribe the Python code (same
operations, same order, no fused multiply-adds), so the two agree bit for bit
(tests/physics/test_rigid_kernel.py); the Python code stays the reference and the fallback.

The library is found as the mesh kernel's (:mod:`spurdiff.differential.mesh.kernel`): beside this module
(``librigid_kernel.so``, as ``harness/build.py`` ships it inside each SpurDifferential FMU), else in
the folders of :data:`SEARCH_PATH`, ``$SPURDIFF_KERNEL_DIR``, ``$SPURDIFF_FMU_DIR`` and a checkout's
``build/fmus`` as ``rigid_kernel-<digest>.so``, the digest of the C source beside it (a stale
library is not used). Selected by the same switch, ``solver.kernel`` (auto | compiled | python).
"""
from __future__ import annotations

import ctypes as C
import sys
import logging
from pathlib import Path

from spurdiff import native_library
from spurdiff.errors import ParameterError

ABI = 4
NCONST = 58
NIO = 12
NIO_STEP = 24
LIB_NAME = "librigid_kernel.so"   # not rigid_kernel.so: Python would import that for this module
KERNELS = ("auto", "compiled", "python")
SEARCH_PATH: list[Path] = []
_HERE = Path(__file__).resolve().parent

log = logging.getLogger("spurdiff.rigid")
_REPORTED: set[str] = set()
_LIB: tuple | None = None


def source_digest(native: Path) -> str:
    """Digest of the kernel's sources (``rigid_kernel*.c`` in the folder ``native``)."""
    return native_library.source_digest(native, "rigid_kernel")


def _check(lib: C.CDLL) -> str | None:
    """None if ``lib`` is the kernel this module speaks to (its function types then declared), else why not."""
    lib.rk_abi.restype = lib.rk_nconst.restype = lib.rk_nio.restype = C.c_int64
    lib.rk_nio_step.restype = C.c_int64
    if lib.rk_abi() != ABI or lib.rk_nconst() != NCONST or lib.rk_nio() != NIO or lib.rk_nio_step() != NIO_STEP:
        return (f"ABI {lib.rk_abi()} with {lib.rk_nconst()} constants, {lib.rk_nio()} values (this module "
                f"needs ABI {ABI}, {NCONST}, {NIO})")
    # no argtypes: the two arguments are always the Kernel's c_double arrays, which ctypes passes
    # as pointers as they are (declared argtypes would convert them at each call: 0.6 us more)
    lib.rk_slip.argtypes = lib.rk_step_slip.argtypes = None
    lib.rk_slip.restype = lib.rk_step_slip.restype = C.c_int64
    return None


def _candidates() -> list[Path]:
    return native_library.candidates("rigid_kernel", _HERE / LIB_NAME, SEARCH_PATH)


MISSING = ("no compiled rigid kernel found (build it with `spurdiff build`, which compiles "
           "fmu_src/native/kernels/rigid_kernel.c)")


def load() -> tuple[C.CDLL | None, str]:
    """(library, where it came from) or (None, why not). Cached per process."""
    return native_library.load_cached(sys.modules[__name__])


def reset() -> None:
    """Forget the cached search result (after the search path changed)."""
    global _LIB
    _LIB = None


def choose(model) -> tuple["Kernel | None", str]:
    """The kernel for an initialized rigid model with the pin-load law (``model.kernel``: auto or
    compiled) or None (python, or auto without a loadable library: logged once per reason), and a
    note saying which implementation runs; ParameterError for an unknown value or for
    ``compiled`` without a library."""
    want = model.kernel
    if want not in KERNELS:
        raise ParameterError("solver.kernel", want, " | ".join(KERNELS))
    if want == "python":
        return None, "python (kernel = python)"
    lib, where = load()
    if lib is None:
        if want == "compiled":
            raise ParameterError("solver.kernel", want, f"auto | python here: {where}")
        if where not in _REPORTED:
            _REPORTED.add(where)
            log.warning("the rigid level runs the Python reference of the pin-load solve (slower, same "
                        "results): %s", where)
        return None, f"python ({where})"
    return Kernel(lib, model), "compiled"


class Kernel:
    """The compiled solve bound to one initialized :class:`spurdiff.differential.rigid.RigidDifferential`:
    its constants, set once, and the array of the inputs and results of one call."""

    def __init__(self, lib: C.CDLL, m):
        pf = m.pf
        _, rb1, _, rb2 = pf.rb
        M01, M02 = pf.M0
        const = (rb1, rb2, m._nrbA, m._nrbB, pf.c, M01, M02, m.J_A, m.J_B, m.lam, m.J_1, m.J_2, m.rho1, m.rho2,
                 m.Mcd, m.Mcc, pf.n) + tuple(m._pin1) + tuple(m._pin2) + tuple(m._g) + (m.c_slide,) + tuple(m._gt)
        assert len(const) == NCONST
        self.const = (C.c_double * NCONST)(*(float(v) for v in const))
        self.io = (C.c_double * NIO)()
        self.fn = lib.rk_slip          # fn(const, io): the arrays above only
        # a whole step of a carrier torque-driven model that slips throughout (rigid.py's do_step)
        self.sio = (C.c_double * NIO_STEP)()
        self.step = lib.rk_step_slip   # step(const, sio): 0 done, 1 not that kind of step

    def set_speed_loads(self, g, gt) -> None:
        """The planets' centrifugal (constants 49..52) and tangential (54..57) force vectors for the
        next solves."""
        k = self.const
        k[49], k[50], k[51], k[52] = g
        k[54], k[55], k[56], k[57] = gt
