"""The compiled communication step of the differential owning its half-shafts (``fmu_src/native/kernels/shaft_kernel.c``) through ctypes.

``sk_step`` is :meth:`spurdiff.differential.shafts.ShaftedDifferential._do_step` with the sub-step
solve of :mod:`spurdiff.differential.shaft_solver` (the Newton/Broyden iteration, its
finite-difference Jacobian and cache per mode, the halving) and the rigid inner model's step
(:meth:`spurdiff.differential.rigid.RigidDifferential.do_step`: the stuck path transcribed, the slip
path calling the rigid kernel's ``rk_slip`` / ``rk_step_slip``, passed as function pointers of the
library :mod:`spurdiff.differential.rigid_kernel` loaded). It transcribes the Python code (same
operations, same order, no fused multiply-adds), so the two agree bit for bit
(tests/physics/test_shaft_kernel.py); the Python code stays the reference and the fallback: a step
the kernel does not take (an error the Python code raises and names, a state it has no room for)
leaves the state as it was and the Python code runs it. The compliant and contact inner levels stay
in Python (their own kernels do their internal steps).

Used when the inner model is the rigid one with the pin-load law and its compiled solve (the rigid
model's ``kernel``, the FMU's ``solver.kernel``: auto | compiled | python, decides for both). The
library is found as the other kernels are (:mod:`spurdiff.native_library`): beside this module
(``libshaft_kernel.so``, as ``harness/build/fmu.py`` ships it in the SpurDifferential FMU), else as
``shaft_kernel-<digest>.so`` in the folders of :data:`SEARCH_PATH`, ``$SPURDIFF_KERNEL_DIR``,
``$SPURDIFF_FMU_DIR`` and a checkout's ``build/fmus``.
"""
from __future__ import annotations

import ctypes as C
import operator
import struct
import sys
from pathlib import Path

from spurdiff import native_library
from spurdiff.attrpath import assign, resolve
from spurdiff.differential import rigid_kernel
from spurdiff.native_library import KERNELS  # noqa: F401 (re-exported)
from spurdiff.native_step import NativeStep

ABI = 4
NRS, NSS, NSC, NIN = 48, 64, 15, 18
NOC, NV = 21, 81                # the native step's output constants and value array (sk_native)
# the rigid kernel this one calls: the ABI and layouts shaft_kernel.c was transcribed for (its
# RK_NCONST and io arrays). Another runs the Python reference (the transcription is to be checked
# against it first: tests/physics/test_shaft_kernel.py)
RIGID_ABI = 5
RIGID_LAYOUT = (94, 12, 24)     # rk_nconst, rk_nio, rk_nio_step
LIB_NAME = "libshaft_kernel.so"
SEARCH_PATH: list[Path] = []

_REPORTED: set[str] = set()    # the reasons logged (once each)
_LIB: tuple | None = None      # the cached search: (library, path) or (None, why)

# the rigid model's state as the kernel holds it (shaft_kernel.c's R_* layout): plain numbers first
_R_HEAD = ("t", "wc", "wd", "phic", "phid", "ac", "ad", "Qf", "slip_dir", "F12", "cap")     # 0..10
# 11, 12 _ad_guess (flag, value); 13..21 _slip_key (flag, s, flag and ac_given, tau_c, tau_L, tau_R,
# _g_wc, _g_ac); 22..27 _slip_val
_R_MID = ("work_in", "energy_loss", "loss_last_step")                                       # 28..30
# 31, 32 n_mode_switches, n_steps; 33..36 _g, 37 _g_wc, 38..41 _gt, 42 _g_ac
_R_TAIL = ("w_ref", "tau_c", "tau_L", "tau_R", "_last_h")                                   # 43..47
# the shafts' state (S_* layout): ShaftedDifferential's _STATE_KEYS without jac, then q_end_L/R,
# then the Jacobian cache
_S_KEYS = ("t", "off_L", "off_R", "theta_L", "theta_R", "T_L", "T_R", "tau_mean_L", "tau_mean_R", "tau_end_L",
           "tau_end_R", "work_wheels", "work_suns", "shaft_loss", "PE0_shaft")               # 0..14
_S_COUNTS = ("n_steps", "n_substeps", "n_evals", "n_jacobians", "n_halvings")               # 15..19
# 20, 21 dw_pred_L/R; 22, 23 q_end_L/R (the kernel writes them, never reads them)
_JAC_KEYS = ("+1", "-1", "+0", "-0", "+1x", "-1x", "+0x", "-0x")                            # slots of 24..63
_JAC_SLOT = {k: i for i, k in enumerate(_JAC_KEYS)}


class SkNative(C.Structure):
    """sk_native's context: the Kernel's arrays and the native step's output constants."""
    _fields_ = [("sc", C.POINTER(C.c_double)), ("k", C.POINTER(C.c_double)), ("rs", C.POINTER(C.c_double)),
                ("ss", C.POINTER(C.c_double)), ("fp", C.c_void_p * 2), ("oc", C.POINTER(C.c_double))]


_BINDING = native_library.Binding(__name__, "shaft_kernel", "half-shaft", "spurdiff.shafts", [
    native_library.Check(("sk_abi", "sk_nrs", "sk_nss", "sk_nsc", "sk_nin", "sk_noc", "sk_nv"),
                         (ABI, NRS, NSS, NSC, NIN, NOC, NV))],
    {"sk_step": (None, C.c_int64),         # (sc, k, rs, ss, inp, fp): the Kernel's arrays
     "sk_native": ([C.POINTER(SkNative), C.POINTER(C.c_double), C.c_double, C.c_double], C.c_int64)},
    fallback="the half-shaft step runs its Python reference (slower, same results)")
MISSING, log, source_digest, _check, _candidates, load, reset = _BINDING.exports()


def choose(model) -> tuple["Kernel | None", str]:
    """The compiled step for an initialized :class:`spurdiff.differential.shafts.ShaftedDifferential`
    or None, and a note saying which implementation runs the half-shaft step. The switch is the
    inner model's ``kernel`` (auto | compiled | python); the kernel needs the rigid inner model with
    its compiled pin-load solve. ParameterError for ``compiled`` without the library."""
    inner = model.inner
    if getattr(inner, "mesh_model", None) != "rigid":
        return None, "python (the compliant and contact levels' half-shaft step is not compiled)"
    want = inner.kernel
    note = _BINDING.switch(want)
    if note is not None:
        return None, note
    if inner._rk is None:
        return None, f"python (the rigid level has no compiled pin-load solve: {inner.kernel_note})"
    if (rigid_kernel.ABI, (rigid_kernel.NCONST, rigid_kernel.NIO, rigid_kernel.NIO_STEP)) != (RIGID_ABI, RIGID_LAYOUT):
        return _BINDING.refuse(want, f"the half-shaft kernel is written for the rigid kernel's ABI {RIGID_ABI}, "
                                     f"this one has ABI {rigid_kernel.ABI}")
    lib, note = _BINDING.compiled(want)
    if lib is None:
        return None, note
    rlib, _ = rigid_kernel.load()
    return Kernel(lib, rlib, model), "compiled"


class Kernel:
    """The compiled step bound to one initialized ShaftedDifferential with a rigid inner model: the
    constants, the state arrays and :meth:`step`."""

    def __init__(self, lib: C.CDLL, rlib: C.CDLL, m):
        inner = m.inner
        sp = m.shafts
        (c1x, c1y), (c2x, c2y) = inner._cf
        (t1x, t1y), (t2x, t2y) = inner._ct
        const = (sp.left.c, sp.left.d, sp.right.c, sp.right.d, sp.h_max, m._accept,
                 1.0 if inner.speed_drive else 0.0, c1x, c1y, c2x, c2y, t1x, t1y, t2x, t2y)
        assert len(const) == NSC
        self.sc = (C.c_double * NSC)(*(float(v) for v in const))
        self.rs = (C.c_double * NRS)()
        self.ss = (C.c_double * NSS)()
        self.inp = (C.c_double * NIN)()
        self.fp = (C.c_void_p * 2)(C.cast(rlib.rk_slip, C.c_void_p).value, C.cast(rlib.rk_step_slip, C.c_void_p).value)
        self.fn = lib.sk_step
        self.native_fn = lib.sk_native
        self.k = inner._rk.const
        # what the last compiled step wrote: the two models' time values and the Jacobian cache
        self._rt = self._st = self._jac = None

    def step(self, m, t: float, h: float, pL: float, wL: float, pR: float, wR: float) -> bool:
        """The step of ``m`` (inputs checked by the caller): True when done (the state of ``m`` and
        of its inner model updated), False when the kernel did not take it (nothing changed).

        The arrays keep the state the last compiled step left: they are packed from the models only
        when the state is not that one any more (the time values are not the objects that step
        wrote, or the Jacobian cache is another dict: a set_state, an initialize, a step the Python
        code ran); else only the carrier inputs go in. States go in and out with struct."""
        d = m.inner.__dict__
        md = m.__dict__
        j = md["_jac"]
        if d["t"] is self._rt and md["t"] is self._st and (j is None or j is self._jac):
            rs = self.rs
            rs[43] = d["w_ref"]
            rs[44] = d["tau_c"]
        elif not self._pack(d, md):
            return False
        mL, mR = m.wheelL_model, m.wheelR_model
        _IN.pack_into(self.inp, 0, t, h, pL, wL, pR, wR, mL.a_free, mL.inv_J, mL.dadw, mL.q_rate, mL.c_t, mL.r_t,
                      mR.a_free, mR.inv_J, mR.dadw, mR.q_rate, mR.c_t, mR.r_t)
        if self.fn(self.sc, self.k, self.rs, self.ss, self.inp, self.fp):
            return False
        self.unpack(d, md)
        return True

    def unpack(self, d: dict, md: dict) -> None:
        """The state the last compiled step left in the arrays into the models' dictionaries (``d``
        the inner model's, ``md`` the shafted one's); the arrays then hold their present state."""
        r = unpack_rigid(self.rs, d)
        s = _SS.unpack_from(self.ss)
        md.update(zip(_S_PLAIN, _pick_s(s)))
        md["n_steps"], md["n_substeps"], md["n_evals"], md["n_jacobians"], md["n_halvings"] = map(int, s[15:20])
        md["_jac"] = None          # the arrays hold the Jacobian cache (ShaftedDifferential.jac reads it)
        self._rt, self._st = r[0], s[0]

    def current(self, d: dict, md: dict) -> bool:
        """The arrays hold the models' present state (see :meth:`step`), else pack it (False: it does
        not fit, the Python code keeps it)."""
        j = md["_jac"]
        if d["t"] is self._rt and md["t"] is self._st and (j is None or j is self._jac):
            return True
        return self._pack(d, md)

    def jac_dict(self) -> dict:
        """The Jacobian cache as the last compiled step left it (mode key -> S_n), as a dict."""
        s = self.ss[24:]
        self._jac = j = {_JAC_KEYS[i]: s[5 * i + 1:5 * i + 5] for i in _SLOTS if s[5 * i]}
        return j

    def _pack(self, d: dict, md: dict) -> bool:
        """The models' state into the arrays; False when it does not fit (the Python code runs)."""
        slots = [0.0] * 40
        jac = md["_jac"]
        for k, v in (jac if jac is not None else self.jac_dict()).items():
            i = _JAC_SLOT.get(k)
            if i is None or len(v) != 4:
                return False    # not a rigid model's key: the Python code keeps it
            slots[5 * i:5 * i + 5] = (1.0, *v)
        if not pack_rigid(self.rs, d):
            return False
        try:
            _SS.pack_into(self.ss, 0, *_get_s(md), 0.0, 0.0, *slots)
        except (struct.error, TypeError):   # a value that is not a number (a state from elsewhere)
            return False
        return True

    def forget(self) -> None:
        """The Python code runs a step (it updates the Jacobian cache in place): pack anew next time."""
        self._rt = self._st = self._jac = None


def pack_rigid(rs, d: dict) -> bool:
    """The rigid model's state (its dictionary ``d``) into ``rs`` (shaft_kernel.c's R_* layout); False
    when it does not fit (a value that is not a number: a state from elsewhere)."""
    adg, key, val = d["_ad_guess"], d["_slip_key"], d["_slip_val"]
    if key is None:
        key9 = _NO_KEY
    else:
        acg = key[1]
        key9 = ((1.0, key[0], 0.0, 0.0) if acg is None else (1.0, key[0], 1.0, acg)) + tuple(key[2:7])
    try:
        _RS.pack_into(rs, 0, *_get_head(d), *((0.0, 0.0) if adg is None else (1.0, adg)), *key9,
                      *(_NO_VAL if val is None else val), *_get_mid(d), *d["_g"], d["_g_wc"], *d["_gt"],
                      *_get_tail(d), d.get("_last_h", 0.0))
    except (struct.error, TypeError, ValueError):
        return False
    return True


def unpack_rigid(rs, d: dict) -> tuple:
    """``rs`` into the rigid model's dictionary ``d`` (the inverse of :func:`pack_rigid`); the values."""
    r = _RS.unpack_from(rs)
    d.update(zip(_R_PLAIN, _pick_plain(r)))
    d["_ad_guess"] = r[12] if r[11] else None
    if r[13]:
        d["_slip_key"] = (r[14], r[16] if r[15] else None, r[17], r[18], r[19], r[20], r[21])
        d["_slip_val"] = r[22:28]
    d["n_mode_switches"] = int(r[31])
    d["n_steps"] = int(r[32])
    d["_g"] = r[33:37]
    d["_gt"] = r[38:42]
    return r


_RS, _SS, _IN = struct.Struct(f"{NRS}d"), struct.Struct(f"{NSS}d"), struct.Struct(f"{NIN}d")
_NO_KEY, _NO_VAL = (0.0,) * 9, (0.0,) * 6
_SLOTS = range(8)
_get_head = operator.itemgetter(*_R_HEAD)
_get_mid = operator.itemgetter(*_R_MID, "n_mode_switches", "n_steps")
_get_tail = operator.itemgetter("_g_ac", *_R_TAIL[:-1])
_get_s = operator.itemgetter(*_S_KEYS, *_S_COUNTS, "dw_pred_L", "dw_pred_R")
# the plain numbers of the rigid state the kernel changes (not the carrier inputs w_ref, tau_c) and their keys
_R_PLAIN = _R_HEAD + _R_MID + ("_g_wc", "_g_ac") + _R_TAIL[2:]
_pick_plain = operator.itemgetter(*range(0, 11), 28, 29, 30, 37, 42, 45, 46, 47)
# the shafts' plain numbers the kernel changes, with the end-of-step tyre-torque deviations (outputs
# derivatives.py reads; not part of the state)
_S_PLAIN = _S_KEYS + ("dw_pred_L", "dw_pred_R", "q_end_L", "q_end_R")
_pick_s = operator.itemgetter(*range(0, 15), 20, 21, 22, 23)


# the differential's native step (sk_native: WatchedShaftedDifferential.do_step with this kernel's step,
# the watches, the outputs): the slots of its array
_SURROGATE = ("a_free", "inv_J", "dadw", "q_rate", "c_t", "r_t")
DIFF_INPUTS = ("w_ref", "tau_c", "tau_L", "tau_R", "wheelL_phi", "wheelL_w", "wheelR_phi", "wheelR_w",
               *(f"wheelL_model.{f}" for f in _SURROGATE), *(f"wheelR_model.{f}" for f in _SURROGATE))
DIFF_OUTPUTS = ("tau_mean_L", "tau_mean_R", "dw_pred_L", "dw_pred_R", "tau_end_L", "tau_end_R", "theta_L", "theta_R",
                "wc", "phic", "w_L", "phi_L", "w_R", "phi_R", "tau_drive", "tau_mesh_L", "tau_mesh_R",
                "mesh_forces.F_A1", "mesh_forces.F_B2", "mesh_forces.F_12", "locking_torque", "locking_capacity",
                "power_loss", "energy_loss", "work_in", "kinetic_energy", "stuck_indicator", "potential_energy",
                "parametric_work", "overspeed_watch.indicator", "capacity_watch.sigma_H_max",
                "capacity_watch.sigma_F_max", "capacity_watch.exceeded_indicator")
_UNUSED = ("tau_L", "tau_R")      # the inner model's, set by the shafts: not the model's inputs here
WATCHES = ("capacity_watch", "overspeed_watch")


class DiffNative(NativeStep):
    """The differential's whole step in C (``sk_native``): the shafted model with the rigid inner model
    and its two watches (:class:`spurdiff.differential.watches.CapacityWatch`, ``OverspeedWatch``),
    as the FMU builds it with ``shaftCoupling = wheel`` at rigid."""

    integers = {"loaded_flanks": 53, "n_mode_switches": 54, "n_internal_steps": 55, "n_contact_transitions": 56}

    def __init__(self, kernel: Kernel, m):
        inner, cw, ow = m.inner, m.capacity_watch, m.overspeed_watch
        rb = inner.pf.rb
        oc = (inner.J_A, inner.J_B, inner.lam, inner.Mcc, inner.Mcd, inner.Mdd, inner.pf.n * rb[0], inner.pf.n * rb[2],
              1.0 if inner.speed_drive else 0.0, m.shafts.left.c, m.shafts.right.c, ow.limit, *cw._aH, *cw._aF,
              cw.sigma_HG_static, cw.sigma_FG_static, 2.0)
        assert len(oc) == NOC
        self.oc = (C.c_double * NOC)(*(float(x) for x in oc))
        P = C.POINTER(C.c_double)
        self.ctx = SkNative(C.cast(kernel.sc, P), C.cast(kernel.k, P), C.cast(kernel.rs, P), C.cast(kernel.ss, P),
                            (C.c_void_p * 2)(*kernel.fp), C.cast(self.oc, P))
        super().__init__(kernel.native_fn, self.ctx, NV, DIFF_INPUTS, DIFF_OUTPUTS)
        self.kernel = kernel

    def layout(self) -> tuple:
        """For the native start and the hand-over (:mod:`spurdiff.fmi.native_start`), as
        :meth:`spurdiff.differential.rigid_native.RigidNative.layout`: sk_native and its context's fields,
        the Kernel's arrays themselves (the state rs and ss come back with v), the rigid kernel's solves."""
        k = self.kernel
        return ((sys.modules[__name__], "sk_native"),
                [(1, k.sc), (1, k.k), (1, k.rs), (1, k.ss), (2, rigid_kernel, "rk_slip"),
                 (2, rigid_kernel, "rk_step_slip"), (1, self.oc)], False)

    def load(self, m) -> bool:
        if not self.kernel.current(m.inner.__dict__, m.__dict__):
            return False
        v = self.v
        v[0:53] = [float(resolve(m, k)) for k in DIFF_INPUTS + DIFF_OUTPUTS]
        v[53:57] = (m.loaded_flanks, m.n_mode_switches, m.n_internal_steps, m.n_contact_transitions)
        v[57:61] = (*m.capacity_watch._F_max, 1.0 if m.overspeed_watch.warned else 0.0)
        v[61:81] = v[0:20]
        return True

    def store(self, m) -> None:
        md = m.__dict__
        self.kernel.unpack(m.inner.__dict__, md)
        md["_mf"] = None            # the mesh forces of the new state (computed when asked for)
        v = self.v[0:81]
        for k, x in zip(DIFF_INPUTS, v[61:81]):
            if k not in _UNUSED:
                assign(m, k, x)
        cw = m.capacity_watch
        cw.sigma_H_max, cw.sigma_F_max, cw._F_max = v[50], v[51], (v[57], v[58], v[59])
        m.overspeed_watch.indicator = v[49]


def native(m) -> "DiffNative | None":
    """The native step of an initialized shafted model whose step is compiled here and whose watches
    are the FMU's two, or None."""
    sk = m.__dict__.get("_sk")
    if sk is None or tuple(w.name for w in getattr(m, "watches", ())) != WATCHES:
        return None
    return DiffNative(sk, m)
