"""The compiled kernel of the rigid level (``fmu_src/native/kernels/rigid_kernel.c``) through ctypes.

The rigid level's hot path is the Newton solve of the planets' moment balances while the
differential slips with the pin-load locking law (:meth:`spurdiff.differential.rigid.RigidDifferential._slip_exact`,
one per inner step of a differential owning its half-shafts): ``rk_slip`` does that solve, and
``rk_step_slip`` the whole usual step of a carrier torque-driven model slipping throughout
(:meth:`spurdiff.differential.rigid.RigidDifferential._step_compiled`). Both transcribe the Python code (same
operations, same order, no fused multiply-adds), so the two agree bit for bit
(tests/physics/test_rigid_kernel.py); the Python code stays the reference and the fallback.

The library is found as the mesh kernel's (:mod:`spurdiff.differential.mesh.kernel`): beside this module
(``librigid_kernel.so``, as ``harness/build/fmu.py`` ships it inside each SpurDifferential FMU), else in
the folders of :data:`SEARCH_PATH`, ``$SPURDIFF_KERNEL_DIR``, ``$SPURDIFF_FMU_DIR`` and a checkout's
``build/fmus`` as ``rigid_kernel-<digest>.so``, the digest of the C source beside it (a stale
library is not used). Selected by the same switch, ``solver.kernel`` (auto | compiled | python).
"""
from __future__ import annotations

import ctypes as C
from pathlib import Path

from spurdiff import native_library
from spurdiff.native_library import KERNELS  # noqa: F401 (re-exported)

ABI = 5
NCONST = 94
NIO = 12
NIO_STEP = 24
LIB_NAME = "librigid_kernel.so"   # not rigid_kernel.so: Python would import that for this module
SEARCH_PATH: list[Path] = []

_REPORTED: set[str] = set()    # the reasons logged (once each)
_LIB: tuple | None = None      # the cached search: (library, path) or (None, why)

_BINDING = native_library.Binding(__name__, "rigid_kernel", "rigid", "spurdiff.rigid", [
    native_library.Check(("rk_abi", "rk_nconst", "rk_nio", "rk_nio_step"), (ABI, NCONST, NIO, NIO_STEP),
                         "ABI {got[0]} with {got[1]} constants, {got[2]} values (this module needs ABI "
                         "{want[0]}, {want[1]}, {want[2]})")],
    ("rk_slip", "rk_step_slip"),      # (const, io), (const, sio): the Kernel's arrays
    fallback="the rigid level runs the Python reference of the pin-load solve (slower, same results)")
MISSING, log, source_digest, _check, _candidates, load, reset = _BINDING.exports()


def choose(model) -> tuple["Kernel | None", str]:
    """The kernel for an initialized rigid model with the pin-load law (``model.kernel``: auto or
    compiled) or None (python, or auto without a loadable library: logged once per reason), and a
    note saying which implementation runs; ParameterError for an unknown value or for
    ``compiled`` without a library."""
    lib, note = _BINDING.library(model.kernel)
    return (Kernel(lib, model) if lib is not None else None), note


class Kernel:
    """The compiled solve bound to one initialized :class:`spurdiff.differential.rigid.RigidDifferential`:
    its constants, set once, and the array of the inputs and results of one call."""

    def __init__(self, lib: C.CDLL, m):
        pf = m.pf
        _, rb1, _, rb2 = pf.rb
        M01, M02 = pf.M0
        const = (rb1, rb2, m._nrbA, m._nrbB, pf.c, M01, M02, m.J_A, m.J_B, m.lam, m.J_1, m.J_2, m.rho1, m.rho2,
                 m.Mcd, m.Mcc, pf.n) + (tuple(m._pin1) + tuple(m._pin2) + tuple(m._g) + (m.c_slide,) + tuple(m._gt)
                 + tuple(m._pin1L) + tuple(m._pin2L) + tuple(m._wpin))
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
