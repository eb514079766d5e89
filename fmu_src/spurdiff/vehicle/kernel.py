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
from pathlib import Path

from spurdiff import native_library
from spurdiff.native_library import KERNELS  # noqa: F401 (re-exported)

ABI = 1
CAR_NCONST, CAR_NIO = 29, 60
WHEEL_NCONST, WHEEL_NIO = 12, 48
LIB_NAME = "libvehicle_kernel.so"
SEARCH_PATH: list[Path] = []

_REPORTED: set[str] = set()    # the reasons logged (once each)
_LIB: tuple | None = None      # the cached search: (library, path) or (None, why)

_BINDING = native_library.Binding(__name__, "vehicle_kernel", "vehicle", "spurdiff.vehicle", [
    native_library.Check(("vk_abi", "vk_car_nconst", "vk_car_nio", "vk_wheel_nconst", "vk_wheel_nio"),
                         (ABI, CAR_NCONST, CAR_NIO, WHEEL_NCONST, WHEEL_NIO))],
    ("vk_car_step", "vk_wheel_step"),      # (const, io): the CarKernel's or WheelKernel's arrays
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
