"""The mesh levels' parameters: which effects act (structural switches) and their data, SI units,
validated from one table of limits.

Defaults and their sources: docs/mesh-dynamics.md.
"""
from __future__ import annotations


from spurdiff.datafile import differential_default as _d
from spurdiff.errors import Bound
from spurdiff.errors import ParameterError, require_range
from spurdiff.attrpath import record

LEVELS = ("compliant", "contact")
KERNELS = ("auto", "compiled", "python")
METHODS = ("ros34pw2", "rodas5p")      # the integrator's tableaux by name (integrator.METHODS' keys: a test
                                      # checks; not imported here, so a rigid run loads no mesh-level module)
METHOD_CHOICES = ("auto",) + METHODS  # solver.method (auto: by the level, MeshParams.method_in_use)
AUTO_METHOD = {"contact": "rodas5p", "compliant": "ros34pw2"}   # what auto selects per level
N_PER_MM15 = 1e3 ** 1.5  # 1 N/mm^1.5 in N/m^1.5
SWITCHES = ("backlash", "meshStiffnessVariation", "pinFriction", "flankFriction", "preload")


@record
class MeshParams:
    """Selects the mesh effects and their data (SI units)."""

    level: str = "compliant"              # "compliant" | "contact"
    backlash: bool = False
    meshStiffnessVariation: bool = False
    pinFriction: bool = True
    flankFriction: bool = False
    tolerance: float = _d("solver.tolerance")   # relative accuracy of the internal integrator
    # data: spurdiff/data/differential.toml (with their sources)
    # circumferential backlash at the operating pitch circle (m); ISO/TR 10064-2 minimum for
    # this gear set: j_bn = 2/3 (0.06 + 0.0005 a + 0.03 m) mm, j_t = j_bn / cos(alpha_w)
    backlashA1: float = _d("meshA1.backlash")
    backlashB2: float = _d("meshB2.backlash")
    backlash12: float = _d("mesh12.backlash")
    # compliant law: mesh stiffness per pair (N/m), 0 = ISO 6336-1 c_gamma_alpha * b
    stiffnessA1: float = _d("meshA1.c")
    stiffnessB2: float = _d("meshB2.c")
    stiffness12: float = _d("mesh12.c")
    dampingRatio: float = _d("mesh.dampingRatio")
    youngsModulus: float = _d("mesh.E")   # Pa, the paper's 40CrNi2Mo (used for the ISO stiffness)
    # contact law (ADAMS IMPACT), the paper's values
    contactStiffnessA1: float = _d("meshA1.contactStiffness")   # N/m^1.5
    contactStiffnessB2: float = _d("meshB2.contactStiffness")
    contactStiffness12: float = _d("mesh12.contactStiffness")
    contactExponent: float = _d("mesh.contactExponent")
    contactDamping: float = _d("mesh.contactDamping")   # N s/m (50 N s/mm)
    contactDepth: float = _d("mesh.contactDepth")       # m, penetration of full damping (0.1 mm)
    # flank friction (paper: static 0.05, dynamic 0.03)
    muStatic: float = _d("flank.muStatic")
    muDynamic: float = _d("flank.muDynamic")
    vStiction: float = _d("flank.vStiction")            # m/s
    vTransition: float = _d("flank.vTransition")        # m/s
    # numerics / start
    preload: bool = _d("mesh.preload")                  # start with the meshes statically loaded
    maxInternalSteps: int = _d("solver.maxInternalSteps")   # per communication step, else StepError
    # implementation: auto (the compiled kernel if it loads, else Python) | compiled | python
    kernel: str = _d("solver.kernel")
    # integration method: ros34pw2 (order 3, a W-method: Jacobian reused) | rodas5p (order 5,
    # a Jacobian every step; fewer steps from tolerance 1e-4 down, docs/accuracy.md) | auto
    # (default: rodas5p at the contact level, ros34pw2 at the compliant level)
    method: str = _d("solver.method")
    # the whole step in C without Python where the FMU has it (solver.nativeStep; spurdiff.native_step:
    # the rigid level with shaftCoupling = wheel and its compiled step)
    nativeStep: bool = True

    def method_in_use(self) -> str:
        """The integration method that runs: ``method``, or with ``auto`` the level's (AUTO_METHOD)."""
        return AUTO_METHOD.get(self.level, "ros34pw2") if self.method == "auto" else self.method

    def validate(self) -> None:
        """Raise ParameterError naming the first invalid field (checked in the order of LIMITS)."""
        if self.level not in LEVELS:
            raise ParameterError("level", self.level, " | ".join(LEVELS))
        if self.kernel not in KERNELS:
            raise ParameterError("kernel", self.kernel, " | ".join(KERNELS))
        if self.method not in METHOD_CHOICES:
            raise ParameterError("method", self.method, " | ".join(METHOD_CHOICES))
        if self.nativeStep not in (0, 1):
            raise ParameterError("nativeStep", self.nativeStep, "0 or 1 (false or true)")
        for name in SWITCHES:
            v = getattr(self, name)
            if not isinstance(v, bool) and type(v).__name__ != "bool_" and v not in (0, 1):   # numpy's bool_ too
                raise ParameterError(name, v, "a boolean")
        for name, lo, hi, allowed, lo_open in LIMITS:
            lo_v = getattr(self, lo) if isinstance(lo, str) else lo
            hi_v = getattr(self, hi) if isinstance(hi, str) else hi
            require_range(name, getattr(self, name), lo_v, hi_v, allowed.format(lo=lo_v, hi=hi_v), lo_open)
        self.BOUNDS["maxInternalSteps"].check("maxInternalSteps", self.maxInternalSteps)


def _per_mesh(stem: str, lo, hi, allowed: str, lo_open: bool = False) -> list[tuple]:
    return [(stem + m, lo, hi, allowed, lo_open) for m in ("A1", "B2", "12")]


# (field, lower, upper, allowed range as the error states it, lower bound exclusive);
# a bound given as a string is the value of that field
LIMITS: tuple[tuple, ...] = (
    ("tolerance", 1e-12, 1e-1, "between 1e-12 and 0.1", False),
    *_per_mesh("backlash", 0.0, 2e-3, "between 0 and 2e-3 m"),
    *_per_mesh("stiffness", 0.0, 1e12, "between 0 (ISO 6336-1) and 1e12 N/m"),
    ("dampingRatio", 0.0, 10.0, "between 0 and 10", False),
    ("youngsModulus", 1e9, 1e12, "between 1e9 and 1e12 Pa", False),
    *_per_mesh("contactStiffness", 0.0, 1e15, "> 0 and <= 1e15 N/m^e", True),
    ("contactExponent", 1.0, 3.0, "between 1 and 3", False),
    ("contactDamping", 0.0, 1e8, "between 0 and 1e8 N s/m", False),
    ("contactDepth", 0.0, 1e-2, "> 0 and <= 0.01 m", True),
    ("muStatic", 0.0, 1.0, "between 0 and 1", False),
    ("muDynamic", 0.0, "muStatic", "between 0 and muStatic = {hi:g}", False),
    ("vStiction", 0.0, 1.0, "> 0 and <= 1 m/s", True),
    ("vTransition", "vStiction", 10.0, "> vStiction = {lo:g} and <= 10 m/s", True),
)

# the fields' fixed ranges as spurdiff.errors declares them (the FMU's min/max), from the same LIMITS
# validate checks: a bound given by another field (muDynamic <= muStatic) is left open here
MeshParams.BOUNDS = {
    name: Bound(lo if not isinstance(lo, str) else None, hi if not isinstance(hi, str) else None,
                lo_open=lo_open and not isinstance(lo, str), allowed=allowed if "{" not in allowed else None)
    for name, lo, hi, allowed, lo_open in LIMITS}
MeshParams.BOUNDS["maxInternalSteps"] = Bound(10, 10 ** 8, integer=True, allowed="an integer from 10 to 1e8")
