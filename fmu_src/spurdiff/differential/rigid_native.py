"""The rigid differential's native step without half-shafts (``shaftCoupling = torque``, the FMU's
default interface): ``sk_rigid_native`` of ``fmu_src/native/kernels/shaft_kernel.c`` through ctypes.

The whole communication step of :class:`spurdiff.differential.rigid.RigidDifferential` with the FMU's
two watches (``WatchedRigidDifferential.do_step``) in C over one array (:mod:`spurdiff.native_step`):
the input checks, the rigid step (the C transcription the half-shaft step uses for its inner model,
calling the rigid kernel's pin-load solves), the load-capacity and overspeed watches and every output
the FMU reads, the same operations as the Python code, so bit for bit its results
(tests/physics/test_rigid_native.py). The Python code stays the reference and the fallback: a step
the C code does not take (a refused input, a watch that would log, a non-finite output) changes
nothing and the model's ``do_step`` runs it.

Every locking law of the rigid level: the pin-load law with its compiled solve (the rigid kernel in use:
``solver.kernel`` auto or compiled), and the linear capacity ``K |T_0| + T_pre`` (``lockingLaw = paper``,
or the pin-load law without pin friction: ``mesh.pinFriction = false``, ``mu_pin = 0``), either carrier
drive; with ``solver.nativeStep`` true. The library is the half-shaft kernel's
(:mod:`spurdiff.differential.shaft_kernel`).
"""
from __future__ import annotations

import ctypes as C
import math

from spurdiff.attrpath import assign, resolve
from spurdiff.differential import rigid_kernel, shaft_kernel as sk
from spurdiff.differential.statics import pin_friction_share
from spurdiff.native_step import NativeStep

# the array: sk_native's layout (shaft_kernel.c), so that a host sets the same inputs with either coupling
NV = sk.NV
INPUTS = sk.DIFF_INPUTS            # the model's four, then the wheel-side inputs (carried, not used here)
USED = ("w_ref", "tau_c", "tau_L", "tau_R")
OUTPUTS = sk.DIFF_OUTPUTS
WATCHES = sk.WATCHES


class SkRigidNative(C.Structure):
    """sk_rigid_native's context."""
    _fields_ = [("sc", C.POINTER(C.c_double)), ("k", C.POINTER(C.c_double)), ("rs", C.POINTER(C.c_double)),
                ("fp", C.c_void_p * 2), ("oc", C.POINTER(C.c_double)), ("pp", C.POINTER(C.c_double))]


def _linear_constants(m) -> tuple:
    """shaft_kernel.c's PP_* constants of the linear capacity (the model without a pin-load solve):
    the coefficients and the mesh-force divisors, computed as rigid.py and statics.mesh_forces_for do."""
    geo = m.geometry
    n = geo.table.nPairs
    cA = math.cos(geo.meshA1.alpha_w)
    return (m.K, m.K_slide, m.K_break, m.preload, m.Mdd, n * geo.r_a * cA, n * geo.r_b * math.cos(geo.meshB2.alpha_w),
            geo.r_1, cA, geo.mesh12.rw1 * math.cos(geo.mesh12.alpha_w), pin_friction_share(geo))


class RigidNative(NativeStep):
    """The plain rigid model's whole step in C with its two watches."""

    integers = sk.DiffNative.integers

    def __init__(self, lib: C.CDLL, rlib: C.CDLL | None, m):
        cw, ow = m.capacity_watch, m.overspeed_watch
        (c1x, c1y), (c2x, c2y) = m._cf
        (t1x, t1y), (t2x, t2y) = m._ct
        speed = 1.0 if m.speed_drive else 0.0
        sc = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, speed, c1x, c1y, c2x, c2y, t1x, t1y, t2x, t2y)
        assert len(sc) == sk.NSC
        rb = m.pf.rb
        oc = (m.J_A, m.J_B, m.lam, m.Mcc, m.Mcd, m.Mdd, m.pf.n * rb[0], m.pf.n * rb[2], speed, 0.0, 0.0, ow.limit,
              *cw._aH, *cw._aF, cw.sigma_HG_static, cw.sigma_FG_static, 2.0)
        assert len(oc) == sk.NOC
        self.sc = (C.c_double * sk.NSC)(*(float(x) for x in sc))
        self.oc = (C.c_double * sk.NOC)(*(float(x) for x in oc))
        self.rs = (C.c_double * sk.NRS)()
        self.rk = rk = m._rk
        P = C.POINTER(C.c_double)
        if rk is not None:      # the pin-load law: the rigid kernel's constants and solves
            k, pp = rk.const, None
            fp = (C.c_void_p * 2)(C.cast(rlib.rk_slip, C.c_void_p).value, C.cast(rlib.rk_step_slip, C.c_void_p).value)
        else:                   # the linear capacity: the constants the step reads (shaft_kernel.c's k[7..15])
            k = self.k = (C.c_double * rigid_kernel.NCONST)()
            k[7], k[8], k[9], k[14], k[15] = m.J_A, m.J_B, m.lam, m.Mcd, m.Mcc
            pp = self.pp = (C.c_double * 11)(*(float(x) for x in _linear_constants(m)))
            fp = (C.c_void_p * 2)()
        self.ctx = SkRigidNative(C.cast(self.sc, P), C.cast(k, P), C.cast(self.rs, P), fp, C.cast(self.oc, P),
                                 C.cast(pp, P) if pp is not None else None)
        fn = lib.sk_rigid_native
        fn.argtypes = [C.POINTER(SkRigidNative), C.POINTER(C.c_double), C.c_double, C.c_double]
        fn.restype = C.c_int64
        super().__init__(fn, self.ctx, NV, INPUTS, OUTPUTS)

    def load(self, m) -> bool:
        if m._rk is not self.rk or not sk.pack_rigid(self.rs, m.__dict__):
            return False
        v = self.v
        v[0:4] = [float(getattr(m, k)) for k in USED]
        v[4:20] = [0.0] * 16             # the wheel-side inputs: the caller's value table has them
        v[20:53] = [float(resolve(m, k)) for k in OUTPUTS]
        v[53:57] = (m.loaded_flanks, m.n_mode_switches, m.n_internal_steps, m.n_contact_transitions)
        v[57:61] = (*m.capacity_watch._F_max, 1.0 if m.overspeed_watch.warned else 0.0)
        v[61:81] = v[0:20]
        return True

    def layout(self) -> tuple:
        """For the native start (:mod:`spurdiff.fmi.native_start`): the step function as (binding module,
        name), the context's fields in order, each (1, array) an array of doubles (the ctypes array the step
        uses, not a copy: the hand-over to the host writes it back), (2, binding module, name) a function
        of a kernel, (0,) NULL, and False: the context is a structure of their pointers."""
        if self.rk is not None:
            fp = ((2, rigid_kernel, "rk_slip"), (2, rigid_kernel, "rk_step_slip"))
            k, pp = self.rk.const, (0,)
        else:
            fp, k, pp = ((0,), (0,)), self.k, (1, self.pp)
        return ((sk, "sk_rigid_native"), [(1, self.sc), (1, k), (1, self.rs), *fp, (1, self.oc), pp], False)

    def store(self, m) -> None:
        sk.unpack_rigid(self.rs, m.__dict__)
        v = self.v[0:81]
        for k, x in zip(USED, v[61:65]):
            assign(m, k, x)
        cw = m.capacity_watch
        cw.sigma_H_max, cw.sigma_F_max, cw._F_max = v[50], v[51], (v[57], v[58], v[59])
        m.overspeed_watch.indicator = v[49]


def native(m) -> "RigidNative | None":
    """The native step of an initialized watched rigid model, or None: with the pin-load law it needs
    the compiled solve (``solver.kernel`` auto or compiled with the rigid kernel loaded), with the linear
    capacity (``lockingLaw = paper``, or no pin friction) ``solver.kernel`` other than python; and the
    FMU's watches and the library with the step."""
    if tuple(w.name for w in getattr(m, "watches", ())) != WATCHES:
        return None
    if m._exact and m._rk is None or not m._exact and m.kernel == "python":
        return None
    if (rigid_kernel.ABI, (rigid_kernel.NCONST, rigid_kernel.NIO, rigid_kernel.NIO_STEP)) != (sk.RIGID_ABI,
                                                                                            sk.RIGID_LAYOUT):
        return None
    lib, _ = sk.load()
    rlib = rigid_kernel.load()[0] if m._exact else None
    if lib is None or m._exact and rlib is None or not hasattr(lib, "sk_rigid_native") or lib.sk_rigid_nv() != NV:
        return None
    return RigidNative(lib, rlib, m)


__all__ = ["RigidNative", "native", "INPUTS", "USED", "OUTPUTS"]
