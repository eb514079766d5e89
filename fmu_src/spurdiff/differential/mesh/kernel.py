"""The compiled kernel of the mesh levels (``fmu_src/native/kernels/mesh_kernel*.c``) through ctypes.

The kernel does a whole communication step (the internal ROS34PW2 or RODAS5P steps, the tableau
as data, with their error control, events, loss quadrature, stick-slip and work accounting) in C,
so Python is entered once per communication step. It transcribes the pure-Python reference (:mod:`spurdiff.differential.mesh.stepper` and
what it calls), which stays the specification and the fallback; the two agree to rounding
(tests/physics/mesh/test_mesh_kernel.py).

Where the library is found (first hit): beside this module (``mesh_kernel.so``, as
``harness/build/fmu.py`` ships it inside each SpurDifferential FMU), in the folders of
:data:`SEARCH_PATH` (``harness.build.fmu.kernel_library`` adds the FMU folder, where it compiles
``mesh_kernel-<digest>.so`` for the direct runs and the tests), ``$SPURDIFF_KERNEL_DIR``,
``$SPURDIFF_FMU_DIR`` and a checkout's ``build/fmus``.
A library in a checkout's folders must carry the digest of the C source beside it; one whose
structure sizes or ABI version do not match is refused. :func:`load` says why a kernel is not
available; the model then runs the Python reference.
"""
from __future__ import annotations

import ctypes as C
from pathlib import Path

from spurdiff import native_library
from spurdiff.errors import StepError
from spurdiff.differential.mesh.integrator import SMAX      # mesh_kernel.h SMAX: the most stages of a tableau

ABI = 9
LIB_NAME = "mesh_kernel.so"
SEARCH_PATH: list[Path] = []
_d, _i = C.c_double, C.c_int64


class MkMesh(C.Structure):
    _fields_ = [(n, _d) for n in ("sigma", "rb1", "rb2", "k", "c", "K", "jn", "eps", "pb", "l1min", "galpha", "L",
                                  "xi0", "xi0c", "xip", "a1", "a2")] + [(n, _i) for n in ("d", "g1", "g2")]


class MkParams(C.Structure):
    _fields_ = ([(n, _i) for n in ("N", "speed_drive", "law", "wave", "tracked", "flank", "pin", "bl", "contact",
                                   "dissipative", "var", "max_steps", "n", "stages", "w_method", "loss5")]
                + [(n, _d) for n in ("rbA", "rb1", "rbB", "rb2", "JA", "JB", "J1", "J2", "Jc", "Jtot", "lam", "e", "C",
                                     "dmax", "mu_s", "mu_d", "v_s", "v_d", "c_pin", "M01", "M02")]
                + [("pin_flat", _d * 8 * 2), ("Minv", _d * 5 * 5), ("atol", _d * 10), ("rtol", _d), ("w_stick", _d),
                   ("gamma", _d), ("err_exp", _d), ("a", _d * SMAX * SMAX), ("cc", _d * SMAX * SMAX), ("m", _d * SMAX),
                   ("ew", _d * SMAX), ("dmid", _d * SMAX), ("dq", _d * SMAX * 2),
                   ("md", MkMesh * 3), ("dpoly", _d * SMAX * 4), ("c_pind", _d),
                   ("pin_ends", _d * 18 * 2), ("pin3d", _i * 2)])


class MkState(C.Structure):
    _fields_ = ([("y", _d * 10)]
                + [(n, _d) for n in ("w_ref", "tau_c", "tau_L", "tau_R", "ac", "wc", "phic", "t", "h_next", "work_in",
                                     "energy_loss", "parametric_work", "loss_last_step", "last_h", "dA0", "dB0",
                                     "d120")]
                + [("sv", _d * 13), ("s", _i * 2), ("flags", _i * 6), ("n_flags", _i)]
                + [(n, _i) for n in ("n_internal_steps", "n_rejected_steps", "n_mode_switches",
                                     "n_contact_transitions", "n_steps")]
                + [("fail_t", _d), ("fail_h", _d)]
                # the integrator's memory between communication steps (the Jacobian in use, its
                # factored W, the cached f and side values at y with their inputs, the Jacobian's age)
                + [("Jf", _d * 100), ("LU", _d * 100), ("f0c", _d * 10), ("sv0c", _d * 13), ("key", _d * 4),
                   ("lu_h", _d), ("piv", C.c_int32 * 10), ("key_s", _i * 2), ("cache_ok", _i), ("jac_age", _i),
                   ("n_jac", _i), ("n_lu", _i), ("gpin", _d * 4)]
                # the phase modes held over an internal step (the model's _mode), phold = 0: none
                + [("pk", _d * 6), ("pnc", _i * 6), ("phold", _i), ("n_psw", _i)])


_REPORTED: set[str] = set()    # the reasons logged (once each)
_LIB: tuple | None = None      # the cached search: (library, path) or (None, why)

_BINDING = native_library.Binding(__name__, "mesh_kernel", "mesh", "spurdiff.mesh", [
    native_library.Check(("mk_abi",), (ABI,), "ABI {got[0]} (this module needs {want[0]})", C.c_int),
    native_library.Check(("mk_sizeof_params", "mk_sizeof_state"), (C.sizeof(MkParams), C.sizeof(MkState)),
                         "structure sizes differ from this module's")],
    {"mk_advance": ([C.POINTER(MkParams), C.POINTER(MkState), _d, _d], C.c_int),
     "mk_evaluate": ([C.POINTER(MkParams), C.POINTER(MkState), C.c_void_p, C.c_void_p, C.c_void_p, C.c_void_p], None),
     "mk_advance_dense": ([C.POINTER(MkParams), C.POINTER(MkState), _d, _d, C.c_int64, C.c_void_p, C.c_void_p],
                          C.c_int),
     "mk_run": ([C.POINTER(MkParams), C.POINTER(MkState), _d, _d, C.c_int64, C.c_void_p], C.c_int64)},
    fallback="the mesh levels run the Python reference (slower, same results)", sources="mesh_kernel*.c",
    param="kernel", values=None)        # MeshParams checks the value
MISSING, log, source_digest, _check, _candidates, load, reset = _BINDING.exports()


def choose(model) -> tuple["Kernel | None", str]:
    """The kernel for an initialized model (``MeshParams.kernel``: auto or compiled) or None
    (python, or auto without a loadable library: logged once per reason), and a note saying which
    implementation runs; ParameterError for ``compiled`` without a library."""
    lib, note = _BINDING.library(model.mesh.kernel)
    return (Kernel(lib, model) if lib is not None else None), note


class Kernel:
    """The compiled kernel bound to one initialized :class:`spurdiff.differential.mesh.MeshDifferential`."""

    def __init__(self, lib: C.CDLL, model):
        self.lib = lib
        c = model
        P = self.params = MkParams()
        P.N, P.speed_drive, P.n = c._N, int(c.speed_drive), int(c.n)
        P.law = 2 if c._contact else (1 if c._bl else 0)
        P.wave, P.tracked, P.flank, P.pin = int(c._var), int(c._need_phase), int(c._flank), int(c._pin)
        P.bl, P.contact, P.dissipative, P.var = int(c._bl), int(c._contact), int(c._dissipative), int(c._var)
        P.max_steps = int(c.mesh.maxInternalSteps)
        for k in ("rbA", "rb1", "rbB", "rb2", "JA", "JB", "J1", "J2", "Jc", "Jtot", "lam", "c_pin"):
            setattr(P, k, float(getattr(c, k)))
        P.M01, P.M02 = float(c._M01), float(c._M02)
        P.c_pind = float(c.c_pin_slide)
        law, fl = c.law_obj, c.flank_obj
        if c._contact:
            P.e, P.C, P.dmax = law.e, law.C, law.dmax
        m = c.mesh
        P.mu_s, P.mu_d, P.v_s, P.v_d = ((fl.mu_s, fl.mu_d, fl.v_s, fl.v_d) if fl is not None else
                                        (m.muStatic, m.muDynamic, m.vStiction, m.vTransition))
        flat = c._pf.layout._flat
        for i in (0, 1):
            for j in range(8):
                P.pin_flat[i][j] = flat[i][j]
        for i, (c0, w0, cL, wL) in enumerate(c._pf.layout.ends):   # the journal's ends (issue 41)
            P.pin_ends[i][:] = tuple(c0) + (w0,) + tuple(cL) + (wL,)
            P.pin3d[i] = c._pin3d[i]
        if not c.speed_drive:
            for i in range(5):
                for j in range(5):
                    P.Minv[i][j] = float(c._Minv[i][j])
        for i in range(c._N):
            P.atol[i] = float(c._atol[i])
        P.rtol, P.w_stick = c._rtol, c._w_stick
        tr = c._integ.method
        P.stages, P.w_method, P.loss5 = tr.stages, int(tr.w_method), int(tr.dquarter is not None)
        P.gamma, P.err_exp = tr.gamma, tr.err_exp
        for i in range(tr.stages):
            for k, v in enumerate(tr.a_rows[i]):
                P.a[i][k] = float(v)
            for k, v in enumerate(tr.c_rows[i]):
                P.cc[i][k] = float(v)
            P.m[i], P.ew[i], P.dmid[i] = float(tr.m[i]), float(tr.e[i]), float(tr.dmid[i])
            for p in range(4):
                P.dpoly[p][i] = tr.dpoly[p][i]
            if tr.dquarter is not None:
                P.dq[0][i], P.dq[1][i] = tr.dquarter[0][i], tr.dquarter[1][i]
        for i, md in enumerate(c.md):
            dst = P.md[i]
            for f in ("sigma", "rb1", "rb2", "k", "c", "K", "jn", "eps", "pb", "l1min", "galpha", "L", "xi0", "xi0c",
                      "xip", "a1", "a2"):
                setattr(dst, f, float(getattr(md, f)))
            dst.d, dst.g1, dst.g2 = md.d, md.g1, md.g2
        self.state = MkState()
        self._pP, self._pS = C.byref(self.params), C.byref(self.state)
        # the state's doubles (y, w_ref ... d120, sv) and integers (s, flags, n_flags, counters) as
        # arrays over the structure's memory
        self._D = (_d * 40).from_buffer(self.state)
        self._I = (_i * 14).from_buffer(self.state, MkState.s.offset)
        assert MkState.y.offset == 0 and MkState.sv.offset == 27 * 8 and MkState.n_steps.offset == 53 * 8
        # the model's continuous state lives here (the model's y is this array): never copied
        N = model._N
        self.y = (_d * N).from_buffer(self.state)
        self.J = (_d * N * N).from_buffer(self.state, MkState.Jf.offset)      # rows of N

    def _pack(self, c) -> MkState:
        """The model's state into the structure: all of it after the model's state was set from
        outside (``c._kernel_dirty``: initialize, set_state, load_state_vector), else only the
        inputs (the rest is what the last step left)."""
        D, I = self._D, self._I
        if not c._kernel_dirty:
            D[10:14] = (c.w_ref, c.tau_c, c.tau_L, c.tau_R)
            return self.state
        c._kernel_dirty = False
        S = self.state
        S.cache_ok = 0
        if c._jac_dirty:               # the Jacobian in use set in Python (initialize, set_state)
            c._jac_dirty = False
            for row, src in zip(self.J, c._integ.J):
                row[:] = src
            S.jac_age, S.lu_h = c._jac_age, 0.0
            S.n_jac, S.n_lu = c.n_jacobians, c._integ.n_factorizations
            S.n_psw = c.n_phase_switches
        if c.y is not self.y:
            D[:c._N] = list(c.y)
        D[10:27] = (c.w_ref, c.tau_c, c.tau_L, c.tau_R, c._ac, c.wc, c.phic, c.t, c.h_next, c.work_in, c.energy_loss,
                    c.parametric_work, c.loss_last_step, c._last_h, c._dA0, c._dB0, c._d120)
        fl = c._contact_flags
        nf = len(fl)
        I[0], I[1] = c.s
        if nf:
            I[2:2 + nf] = fl
        I[8] = nf
        I[9:14] = (c.n_internal_steps, c.n_rejected_steps, c.n_mode_switches, c.n_contact_transitions, c.n_steps)
        S.gpin[:] = c._g
        mode = c._mode
        S.phold = int(mode is not None)
        if mode is not None:
            for i, (kp, np_, kn, nn) in enumerate(mode):
                S.pk[2 * i], S.pnc[2 * i], S.pk[2 * i + 1], S.pnc[2 * i + 1] = kp, np_, kn, nn
        return S

    def set_speed_loads(self, g) -> None:
        """The planets' inertial forces for the next steps; the cached f at y no longer holds."""
        S = self.state
        S.gpin[:] = g
        S.cache_ok = 0

    def advance(self, c, t: float, h: float) -> list:
        """One communication step of model ``c`` in C; updates the model's state and returns the
        side values of the outputs (spurdiff.differential.mesh.forces.SideValues fields). Raises StepError
        with the model unchanged."""
        S = self._pack(c)
        rc = self.lib.mk_advance(self._pP, self._pS, t, h)
        if rc != 0:
            if rc == 1:
                raise StepError(f"more than {int(c.mesh.maxInternalSteps)} internal steps in the step at "
                                f"t = {t:.9g} s (maxInternalSteps)")
            raise StepError(f"internal step size {S.fail_h:.3g} s below 1e-13 s at t = {S.fail_t:.9g} s")
        v = self._D[14:40]
        (c._ac, c.wc, c.phic, c.t, c.h_next, c.work_in, c.energy_loss, c.parametric_work, c.loss_last_step,
         c._last_h) = v[:10]
        i = self._I[:]
        c.s = i[:2]
        c._contact_flags = i[2:2 + i[8]]
        c.n_internal_steps, c.n_rejected_steps, c.n_mode_switches, c.n_contact_transitions, c.n_steps = i[9:14]
        c._f0_key = None
        return v[13:26]

    def advance_dense(self, c, t: float, h: float, times: list) -> tuple[list, list]:
        """One step t -> t + h in C with the states at ``times`` (into the step, floats) by the dense
        output (:meth:`spurdiff.differential.mesh.MeshDifferential.run_dense`); the model ends at t + h.
        Returns the states (a list of rows) and the side values of the outputs at the end, as :meth:`advance`."""
        n, N = len(times), c._N
        tq = (_d * n)(*times)
        ys = (_d * (n * N))()
        S = self._pack(c)
        rc = self.lib.mk_advance_dense(self._pP, self._pS, t, h, n, tq, ys)
        if rc != 0:
            raise StepError(f"the run from t = {t:.9g} s failed at t = {S.fail_t:.9g} s (code {rc})")
        self._unpack(c)
        return _rows(ys, N), self._D[27:40]

    def _unpack(self, c) -> None:
        v = self._D[14:24]
        (c._ac, c.wc, c.phic, c.t, c.h_next, c.work_in, c.energy_loss, c.parametric_work, c.loss_last_step,
         c._last_h) = v
        i = self._I[:]
        c.s, c._contact_flags = i[:2], i[2:2 + i[8]]
        c.n_internal_steps, c.n_rejected_steps, c.n_mode_switches, c.n_contact_transitions, c.n_steps = i[9:14]
        c._f0_key = None

    def run(self, c, t0: float, h: float, n: int) -> list:
        """n communication steps with the inputs held, in one call (the states after each, a list of rows);
        the same steps as n calls of :meth:`advance`. The model ends at the last state (its
        outputs are not refreshed); StepError if a step fails (the model then stays as it was)."""
        N = c._N
        ys = (_d * (n * N))()
        self._pack(c)
        done = self.lib.mk_run(self._pP, self._pS, t0, h, n, ys)
        if done != n:
            raise StepError(f"step {done + 1} of {n} at t = {t0 + done * h:.9g} s failed")
        self._unpack(c)
        return _rows(ys, N)

    def evaluate(self, c, y, f: list, J: list | None) -> tuple:
        """The model evaluation in C at y (inputs, carrier acceleration and modes of ``c``) into the
        list ``f`` and, if given, the rows of ``J`` (as the Python reference: the rows that depend on y; the
        others, the constant kinematic ones, keep what ``J`` held)."""
        c._kernel_dirty = True           # a full pack: the caller may have changed anything
        self._pack(c)
        N = c._N
        ya = (_d * N)(*y)
        fa = (_d * N)(*f)
        Ja = None if J is None else (_d * (N * N))(*(v for row in J for v in row))
        sv = (_d * 13)()
        self.lib.mk_evaluate(self._pP, self._pS, ya, fa, Ja, sv)
        f[:] = fa[:]
        if J is not None:
            for k, row in enumerate(J):
                row[:] = Ja[k * N:(k + 1) * N]
        return tuple(sv)


def _rows(flat, N: int) -> list:
    """A flat C array of rows of N doubles as a list of lists."""
    v = flat[:]
    return [v[k:k + N] for k in range(0, len(v), N)]
