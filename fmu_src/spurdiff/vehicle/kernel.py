"""The compiled steps of the car and the wheel (``fmu_src/native/kernels/vehicle_kernel.c``) through ctypes.

``vk_car_step`` is :meth:`spurdiff.vehicle.car.Vehicle.do_step`'s Runge-Kutta loop with the rate
function of :mod:`spurdiff.vehicle.car_rates` and the outputs; ``vk_wheel_step`` is
:meth:`spurdiff.vehicle.wheel.WheelLoad._substeps` with ``_update_outputs`` and
``_update_surrogate``. Both transcribe the Python code (same operations, same order, the same libm
functions, no fused multiply-adds), so the two agree bit for bit (tests/physics/test_vehicle_kernel.py);
the Python code stays the reference and the fallback. The input checks, the input caches and
everything done once per run stay in Python.

The library is found as the differential's kernels are (:mod:`spurdiff.native_library`): beside
this module (``libvehicle_kernel.so``, as ``harness/build.py`` ships it inside each Vehicle and
WheelLoad FMU), else in the folders of :data:`SEARCH_PATH`, ``$SPURDIFF_KERNEL_DIR``,
``$SPURDIFF_FMU_DIR`` and a checkout's ``build/fmus`` as ``vehicle_kernel-<digest>.so``, the digest
of the C source (a stale library is not used). Selected by the models' ``kernel`` attribute, the
FMUs' parameter ``solver.kernel``: auto (the compiled kernel when it loads, else the Python
reference, the reason logged once) | compiled (refuse without it) | python.
"""
from __future__ import annotations

import ctypes as C
import sys
from pathlib import Path

from spurdiff import native_library
from spurdiff.native_library import KERNELS  # noqa: F401 (re-exported)
from spurdiff.native_step import NativeStep

ABI = 2
CAR_NCONST, CAR_NIO, CAR_NV = 29, 60, 119
WHEEL_NCONST, WHEEL_NIO, WHEEL_NV = 12, 48, 103
LIB_NAME = "libvehicle_kernel.so"
SEARCH_PATH: list[Path] = []

_REPORTED: set[str] = set()    # the reasons logged (once each)
_LIB: tuple | None = None      # the cached search: (library, path) or (None, why)

_BINDING = native_library.Binding(__name__, "vehicle_kernel", "vehicle", "spurdiff.vehicle", [
    native_library.Check(("vk_abi", "vk_car_nconst", "vk_car_nio", "vk_car_nv", "vk_wheel_nconst", "vk_wheel_nio",
                          "vk_wheel_nv"), (ABI, CAR_NCONST, CAR_NIO, CAR_NV, WHEEL_NCONST, WHEEL_NIO, WHEEL_NV))],
    {"vk_car_step": (None, C.c_int64), "vk_wheel_step": (None, C.c_int64),  # (const, io): the kernels' arrays
     # the native steps (spurdiff.native_step): (const, v, t, h)
     "vk_car_native": ([C.POINTER(C.c_double), C.POINTER(C.c_double), C.c_double, C.c_double], C.c_int64),
     "vk_wheel_native": ([C.POINTER(C.c_double), C.POINTER(C.c_double), C.c_double, C.c_double], C.c_int64)},
    fallback="the vehicle (and wheel) model runs its Python reference (slower, same results)")
MISSING, log, source_digest, _check, _candidates, load, reset = _BINDING.exports()


def choose_car(model) -> tuple["CarKernel | None", str]:
    """The compiled step for an initialized :class:`spurdiff.vehicle.car.Vehicle` (``model.kernel``)
    or None (python, or auto without a loadable library: logged once per reason), and a note saying
    which implementation runs."""
    lib, note = _BINDING.library(model.kernel)
    return (CarKernel(lib, model) if lib is not None else None), note


def choose_wheel(model) -> tuple["WheelKernel | None", str]:
    """As :func:`choose_car` for an initialized :class:`spurdiff.vehicle.wheel.WheelLoad`."""
    lib, note = _BINDING.library(model.kernel)
    return (WheelKernel(lib, model) if lib is not None else None), note


class CarKernel:
    """The compiled car step bound to one initialized Vehicle: its constants and the io array."""

    def __init__(self, lib: C.CDLL, m):
        from spurdiff.vehicle.car_params import G, STEER_ANGLE

        p = m.params
        b, lt, st, sc = p.vehicle, p.lateralTyre, p.steering, p.speedControl
        const = (b.m, b.L, b.l_f, b.L - b.l_f, b.h_cg, lt.B, lt.C, lt.E, -b.f_rr, b.v_rr,
                 -0.5 * b.rho_air * b.CdA, b.trackRear, b.Iz, sc.Kp, sc.Ki, sc.driveTorqueMax,
                 sc.driveTorqueMin, 1.0 / lt.sigma, 1.0 / b.tau_load, st.delta_max,
                 1.0 if st.mode == STEER_ANGLE else 0.0, st.K_r, st.K_ri, b.h_max, lt.sigma,
                 lt.alpha_max, b.rollStiffnessShareRear, G, 2.0)
        assert len(const) == CAR_NCONST
        self.const = (C.c_double * CAR_NCONST)(*(float(v) for v in const))
        self.io = (C.c_double * CAR_NIO)()
        self.fn = lib.vk_car_step
        self.native_fn = lib.vk_car_native


# the car's native step (vehicle_kernel.c, vk_car_native): the slots of its array
CAR_INPUTS = ("rearLeft_Fx", "rearRight_Fx", "speedTarget", "pathRadius", "speedTargetRate", "pathRadiusRate",
              "steering_angle_cmd", "grade", "mu")
_CAR_STATE, _CAR_RANGE, _CAR_TOOK = 33, 108, 110   # the state s (12), t, n_steps, n_substeps; the grade's
# range; the inputs the last step took


class CarNative(NativeStep):
    """The car's whole step in C (``vk_car_native``: :meth:`spurdiff.vehicle.car.Vehicle.do_step` with
    its compiled step, the input checks and the outputs the FMU reads)."""

    integers = {"n_substeps": _CAR_STATE + 14}

    def __init__(self, vk: CarKernel, grade_range: tuple[float, float], output_keys: tuple[str, ...]):
        # output_keys: car._OUTPUT_KEYS, the order of vk_car_step's outputs
        super().__init__(vk.native_fn, vk.const, CAR_NV, CAR_INPUTS,
                         output_keys + ("vx", "vy", "x", "y", "psi", "kinetic_energy"))
        assert len(self.inputs) + len(self.outputs) == _CAR_STATE
        self.v[_CAR_RANGE:_CAR_RANGE + 2] = grade_range

    def layout(self) -> tuple:
        """For the native start (:mod:`spurdiff.fmi.native_start`): the step function, and its constants
        as the context itself (not a structure of pointers)."""
        return (sys.modules[__name__], "vk_car_native"), [(1, self.const)], True

    def load(self, m) -> None:
        v = self.v
        v[0:_CAR_STATE] = [getattr(m, k) for k in self.inputs + self.outputs]
        v[_CAR_STATE:_CAR_STATE + 15] = (*m.s, m.t, m.n_steps, m.n_substeps)
        v[_CAR_TOOK:_CAR_TOOK + 9] = v[0:9]

    def store(self, m) -> None:
        v = self.v
        for k, x in zip(CAR_INPUTS, v[_CAR_TOOK:_CAR_TOOK + 9]):
            setattr(m, k, x)
        m._set_outputs(tuple(v[9:27]))
        s = v[_CAR_STATE:_CAR_STATE + 15]
        m.s = s[:12]
        m.t, m.n_steps, m.n_substeps = s[12], int(s[13]), int(s[14])


class WheelKernel:
    """The compiled wheel sub-steps and outputs bound to one initialized WheelLoad."""

    def __init__(self, lib: C.CDLL, m):
        p = m.params
        ty = p.tyre
        const = (p.wheel.J, p.wheel.R, ty.B, ty.C, ty.E, ty.k_max, ty.f_rr, 1.0 / ty.w_eps, ty.sigma,
                 ty.w_eps, p.halfShaft.c, p.halfShaft.d)
        assert len(const) == WHEEL_NCONST
        self.const = (C.c_double * WHEEL_NCONST)(*(float(v) for v in const))
        self.io = (C.c_double * WHEEL_NIO)()
        self.fn = lib.vk_wheel_step
        self.native_fn = lib.vk_wheel_native


# the wheel's native step (vehicle_kernel.c, vk_wheel_native): the slots of its array
WHEEL_INPUTS = ("flange_phi", "flange_w", "Fz", "mu", "tau_in", "dw_in", "vx", "dFz", "dvx")
WHEEL_OUTPUTS = ("flange_tau", "Fx", "wheel_w", "phi", "sur_a", "sur_invJ", "sur_dadw", "sur_qrate", "sur_ct",
                 "sur_rt", "slip", "shaft_tau", "shaft_power", "theta", "work_flange", "work_road", "loss_damping",
                 "loss_slip", "loss_rolling", "energy_dissipated", "kinetic_energy", "potential_energy",
                 "energy_residual")
_WHEEL_PLAIN = 19                    # the outputs that are attributes (the rest are properties)
_WHEEL_STATE = ("w", "k", "phi_ref", "w_anchor", "t", "n_steps", "n_substeps", "KE0", "PE0")


class WheelNative(NativeStep):
    """The wheel's whole step in C (``vk_wheel_native``: :meth:`spurdiff.vehicle.wheel.WheelLoad.do_step`
    with its compiled sub-steps, either coupling, the input checks and the outputs the FMU reads)."""

    integers = {"n_substeps": 38}

    def __init__(self, vk: WheelKernel, m):
        super().__init__(vk.native_fn, vk.const, WHEEL_NV, WHEEL_INPUTS, WHEEL_OUTPUTS)
        p = m.params
        self.v[41:46] = (1.0 if m.wheel_mode else 0.0, 1.0 if p.interfaceStiffness else 0.0,
                         1.0 if p.rampAnchor == "end" else 0.0, 1.0 if p.followFlangeAngle else 0.0, p.h_max)

    def layout(self) -> tuple:
        """As :meth:`CarNative.layout`."""
        return (sys.modules[__name__], "vk_wheel_native"), [(1, self.const)], True

    def load(self, m) -> None:
        v = self.v
        v[0:41] = [getattr(m, k) for k in WHEEL_INPUTS + WHEEL_OUTPUTS + _WHEEL_STATE]
        v[94:103] = v[0:9]

    def store(self, m) -> None:
        v = self.v[0:103]
        d = m.__dict__
        d.update(zip(WHEEL_INPUTS, v[94:103]))
        d.update(zip(WHEEL_OUTPUTS[:_WHEEL_PLAIN], v[9:9 + _WHEEL_PLAIN]))
        d.update(zip(_WHEEL_STATE, v[32:41]))
        m.n_steps, m.n_substeps = int(v[37]), int(v[38])
