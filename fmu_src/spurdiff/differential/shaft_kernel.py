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
(``libshaft_kernel.so``, as ``harness/build.py`` ships it in the SpurDifferential FMU), else as
``shaft_kernel-<digest>.so`` in the folders of :data:`SEARCH_PATH`, ``$SPURDIFF_KERNEL_DIR``,
``$SPURDIFF_FMU_DIR`` and a checkout's ``build/fmus``.
"""
from __future__ import annotations

import ctypes as C
import logging
import sys
from pathlib import Path

from spurdiff import native_library
from spurdiff.differential import rigid_kernel
from spurdiff.errors import ParameterError

ABI = 1
NRS, NSS, NSC, NIN = 42, 62, 11, 18
LIB_NAME = "libshaft_kernel.so"
KERNELS = ("auto", "compiled", "python")
SEARCH_PATH: list[Path] = []
_HERE = Path(__file__).resolve().parent

log = logging.getLogger("spurdiff.shafts")
_REPORTED: set[str] = set()
_LIB: tuple | None = None

# the rigid model's state as the kernel holds it (shaft_kernel.c's R_* layout): plain numbers first
_R_HEAD = ("t", "wc", "wd", "phic", "phid", "ac", "ad", "Qf", "slip_dir", "F12", "cap")     # 0..10
_R_MID = ("work_in", "energy_loss", "loss_last_step")                                       # 27..29
_R_TAIL = ("w_ref", "tau_c", "tau_L", "tau_R", "_last_h")                                   # 37..41
# the shafts' state (S_* layout): ShaftedDifferential's _STATE_KEYS without jac, which follows
_S_KEYS = ("t", "off_L", "off_R", "theta_L", "theta_R", "T_L", "T_R", "tau_mean_L", "tau_mean_R", "tau_end_L",
           "tau_end_R", "work_wheels", "work_suns", "shaft_loss", "PE0_shaft")               # 0..14
_S_COUNTS = ("n_steps", "n_substeps", "n_evals", "n_jacobians", "n_halvings")               # 15..19
_JAC_KEYS = ("+1", "-1", "+0", "-0", "+1x", "-1x", "+0x", "-0x")                            # slots of 22..61
_JAC_SLOT = {k: i for i, k in enumerate(_JAC_KEYS)}


def source_digest(native: Path) -> str:
    """Digest of the kernel's sources (``shaft_kernel*.c`` in the folder ``native``)."""
    return native_library.source_digest(native, "shaft_kernel")


def _check(lib: C.CDLL) -> str | None:
    """None if ``lib`` is the kernel this module speaks to (its function types then declared), else why not."""
    for f in (lib.sk_abi, lib.sk_nrs, lib.sk_nss, lib.sk_nsc, lib.sk_nin):
        f.restype = C.c_int64
    got = (lib.sk_abi(), lib.sk_nrs(), lib.sk_nss(), lib.sk_nsc(), lib.sk_nin())
    want = (ABI, NRS, NSS, NSC, NIN)
    if got != want:
        return f"ABI and sizes {got} (this module needs {want})"
    lib.sk_step.argtypes = None    # the Kernel's arrays, passed as pointers as they are
    lib.sk_step.restype = C.c_int64
    return None


def _candidates() -> list[Path]:
    return native_library.candidates("shaft_kernel", _HERE / LIB_NAME, SEARCH_PATH)


MISSING = ("no compiled half-shaft kernel found (build it with `spurdiff build`, which compiles "
           "fmu_src/native/kernels/shaft_kernel.c)")


def load() -> tuple[C.CDLL | None, str]:
    """(library, where it came from) or (None, why not). Cached per process."""
    return native_library.load_cached(sys.modules[__name__])


def reset() -> None:
    """Forget the cached search result (after the search path changed)."""
    global _LIB
    _LIB = None


def choose(model) -> tuple["Kernel | None", str]:
    """The compiled step for an initialized :class:`spurdiff.differential.shafts.ShaftedDifferential`
    or None, and a note saying which implementation runs the half-shaft step. The switch is the
    inner model's ``kernel`` (auto | compiled | python); the kernel needs the rigid inner model with
    its compiled pin-load solve. ParameterError for ``compiled`` without the library."""
    inner = model.inner
    if getattr(inner, "mesh_model", None) != "rigid":
        return None, "python (the compliant and contact levels' half-shaft step is not compiled)"
    want = inner.kernel
    if want not in KERNELS:
        raise ParameterError("solver.kernel", want, " | ".join(KERNELS))
    if want == "python":
        return None, "python (kernel = python)"
    if inner._rk is None:
        return None, f"python (the rigid level has no compiled pin-load solve: {inner.kernel_note})"
    lib, where = load()
    if lib is None:
        if want == "compiled":
            raise ParameterError("solver.kernel", want, f"auto | python here: {where}")
        if where not in _REPORTED:
            _REPORTED.add(where)
            log.warning("the half-shaft step runs its Python reference (slower, same results): %s", where)
        return None, f"python ({where})"
    rlib, _ = rigid_kernel.load()
    return Kernel(lib, rlib, model), "compiled"


class Kernel:
    """The compiled step bound to one initialized ShaftedDifferential with a rigid inner model: the
    constants, the state arrays and :meth:`step`."""

    def __init__(self, lib: C.CDLL, rlib: C.CDLL, m):
        inner = m.inner
        sp = m.shafts
        (c1x, c1y), (c2x, c2y) = inner._cf
        const = (sp.left.c, sp.left.d, sp.right.c, sp.right.d, sp.h_max, m._accept,
                 1.0 if inner.speed_drive else 0.0, c1x, c1y, c2x, c2y)
        assert len(const) == NSC
        self.sc = (C.c_double * NSC)(*(float(v) for v in const))
        self.rs = (C.c_double * NRS)()
        self.ss = (C.c_double * NSS)()
        self.inp = (C.c_double * NIN)()
        self.fp = (C.c_void_p * 2)(C.cast(rlib.rk_slip, C.c_void_p).value, C.cast(rlib.rk_step_slip, C.c_void_p).value)
        self.fn = lib.sk_step
        self.k = inner._rk.const

    def step(self, m, t: float, h: float, pL: float, wL: float, pR: float, wR: float) -> bool:
        """The step of ``m`` (inputs checked by the caller): True when done (the state of ``m`` and
        of its inner model updated), False when the kernel did not take it (nothing changed)."""
        inner = m.inner
        d = inner.__dict__
        adg, key, val, g = d["_ad_guess"], d["_slip_key"], d["_slip_val"], d["_g"]
        rs = [d["t"], d["wc"], d["wd"], d["phic"], d["phid"], d["ac"], d["ad"], d["Qf"], d["slip_dir"], d["F12"],
              d["cap"], 0.0 if adg is None else 1.0, 0.0 if adg is None else adg]
        if key is None:
            rs += (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        else:
            acg = key[1]
            rs += (1.0, key[0], 0.0 if acg is None else 1.0, 0.0 if acg is None else acg, key[2], key[3], key[4],
                   key[5])
        rs += (0.0, 0.0, 0.0, 0.0, 0.0, 0.0) if val is None else val
        rs += (d["work_in"], d["energy_loss"], d["loss_last_step"], d["n_mode_switches"], d["n_steps"])
        rs += g
        rs += (d["_g_wc"], d["w_ref"], d["tau_c"], d["tau_L"], d["tau_R"], d.get("_last_h", 0.0))
        md = m.__dict__
        jac = md["jac"]
        ss = [md[k] for k in _S_KEYS] + [md[k] for k in _S_COUNTS] + [md["dw_pred_L"], md["dw_pred_R"]]
        slots = [0.0] * 40
        for k, v in jac.items():
            i = _JAC_SLOT.get(k)
            if i is None or len(v) != 4:
                return False       # not a rigid model's key: the Python code keeps it
            slots[5 * i:5 * i + 5] = (1.0, *v)
        try:
            self.rs[:] = rs
            self.ss[:] = ss + slots
        except TypeError:          # a value that is not a number (a state from elsewhere): Python
            return False
        mL, mR = m.wheelL_model, m.wheelR_model
        self.inp[:] = (t, h, pL, wL, pR, wR, mL.a_free, mL.inv_J, mL.dadw, mL.q_rate, mL.c_t, mL.r_t,
                       mR.a_free, mR.inv_J, mR.dadw, mR.q_rate, mR.c_t, mR.r_t)
        if self.fn(self.sc, self.k, self.rs, self.ss, self.inp, self.fp):
            return False
        r = self.rs[:]
        d.update(zip(_R_HEAD, r[0:11]))
        d["_ad_guess"] = r[12] if r[11] else None
        d["_slip_key"] = ((r[14], r[16] if r[15] else None, r[17], r[18], r[19], r[20]) if r[13] else None)
        d["_slip_val"] = tuple(r[21:27]) if r[13] else val
        d.update(zip(_R_MID, r[27:30]))
        d["n_mode_switches"] = int(r[30])
        d["n_steps"] = int(r[31])
        d["_g"] = tuple(r[32:36])
        d["_g_wc"] = r[36]
        d.update(zip(_R_TAIL, r[37:42]))
        s = self.ss[:]
        md.update(zip(_S_KEYS, s[0:15]))
        md["n_steps"], md["n_substeps"], md["n_evals"], md["n_jacobians"], md["n_halvings"] = map(int, s[15:20])
        md["dw_pred_L"], md["dw_pred_R"] = s[20], s[21]
        md["jac"] = {_JAC_KEYS[i]: s[23 + 5 * i:27 + 5 * i] for i in range(8) if s[22 + 5 * i]}
        return True
