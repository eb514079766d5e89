"""Static checks of an FMI 2.0 co-simulation FMU: the archive and its modelDescription.xml.

Nothing here loads the FMU's binary, so these checks run in the checker's own process.

Checks (ids and rules; see docs/compliance.md):

``static.fmi2-cosimulation``
    The archive is a zip with a ``modelDescription.xml`` whose root has ``fmiVersion="2.0"``
    and a ``CoSimulation`` element with a ``modelIdentifier`` (FMI 2.0 spec, 2.2 and 4.3.1).
``static.fmpy-validate``
    :func:`fmpy.validation.validate_fmu`: XML schema, unique and legal names, ModelStructure
    (Outputs, InitialUnknowns), required start values, causality/variability/initial
    combinations, units against UnitDefinitions.
``static.binary``
    ``binaries/<platform>/<modelIdentifier><ext>`` exists for the platform the checker runs on
    (FMI 2.0 spec, 2.3), e.g. ``binaries/linux64/Model.so``: the lifecycle checks need it.
``static.units``
    Every Real variable has a non-empty ``unit``, or a ``declaredType`` whose SimpleType has a
    non-empty ``unit``. Dimensionless quantities must say so with ``unit="1"``.
``static.output-dependencies``
    Every ``ModelStructure/Outputs/Unknown`` has a ``dependencies`` attribute (an empty one is
    an explicit "depends on no input"). Without it an importer must assume direct feedthrough
    from every input (FMI 2.0 spec, 2.2.8), which creates spurious algebraic loops.
``static.descriptions``
    Every ScalarVariable has a non-blank ``description``.
``static.names``
    Names are unique and legal for the declared ``variableNamingConvention``: for "structured"
    the grammar of FMI 2.0 spec 2.2.9 (``a.b[1,2]``, ``'quoted name'``, ``der(x)``,
    ``der(x,2)``); for "flat" no carriage return, line feed or tab.
"""
from __future__ import annotations

import re
import time
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from .report import FAIL, PASS, SKIP, CheckResult

STATIC_CHECKS: tuple[str, ...] = (
    "static.fmi2-cosimulation",
    "static.fmpy-validate",
    "static.binary",
    "static.units",
    "static.output-dependencies",
    "static.descriptions",
    "static.names",
)

# --- FMI 2.0 structured names (spec 2.2.9) ----------------------------------------------------
_B_NAME = r"(?:[A-Za-z_][A-Za-z0-9_]*|'(?:[A-Za-z0-9_!#$%&()*+,\-./:;<=>?@\[\]^{}|~ ]|\\['\"?\\abfnrtv])+')"
_INDICES = r"(?:\[[0-9]+(?:,[0-9]+)*\])"
_IDENTIFIER = rf"{_B_NAME}{_INDICES}?(?:\.{_B_NAME}{_INDICES}?)*"
_STRUCTURED = re.compile(rf"(?:{_IDENTIFIER}|der\({_IDENTIFIER}(?:,[0-9]+)?\))")


def is_structured_name(name: str) -> bool:
    """True when ``name`` follows the FMI 2.0 "structured" naming grammar (spec 2.2.9)."""
    return _STRUCTURED.fullmatch(name) is not None


def host_platform() -> tuple[str, str]:
    """(FMI platform folder, shared-library extension) of this machine, e.g. ("linux64", ".so")."""
    import fmpy
    return fmpy.platform, fmpy.sharedLibraryExtension


@dataclass
class FmuArchive:
    """What the static checks need from an FMU file: its member names and parsed XML."""

    path: Path
    members: list[str] = field(default_factory=list)
    root: ET.Element | None = None
    error: str = ""  # why the archive or its modelDescription.xml could not be read

    @property
    def model_identifier(self) -> str | None:
        if self.root is None:
            return None
        cs = self.root.find("CoSimulation")
        return cs.get("modelIdentifier") if cs is not None else None

    @property
    def model_name(self) -> str | None:
        return None if self.root is None else self.root.get("modelName")

    def variables(self) -> list[ET.Element]:
        if self.root is None:
            return []
        return self.root.findall("ModelVariables/ScalarVariable")


def read_archive(path: str | Path) -> FmuArchive:
    """Open the FMU zip and parse ``modelDescription.xml`` (no validation, no binary loading)."""
    arc = FmuArchive(Path(path))
    try:
        with zipfile.ZipFile(arc.path) as zf:
            arc.members = zf.namelist()
            if "modelDescription.xml" not in arc.members:
                arc.error = "the archive has no modelDescription.xml at its root"
                return arc
            data = zf.read("modelDescription.xml")
    except (zipfile.BadZipFile, OSError) as e:
        arc.error = f"not a readable zip archive: {e}"
        return arc
    try:
        arc.root = ET.fromstring(data)
    except ET.ParseError as e:
        arc.error = f"modelDescription.xml is not well-formed XML: {e}"
    return arc


def _names_list(names: list[str], limit: int = 8) -> str:
    shown = ", ".join(names[:limit])
    return shown + (f", ... ({len(names) - limit} more)" if len(names) > limit else "")


# --- the checks: each takes the archive and returns (status, reason) ---------------------------

def check_fmi2_cosimulation(arc: FmuArchive) -> tuple[str, str]:
    if arc.root is None:
        return FAIL, arc.error
    version = arc.root.get("fmiVersion")
    if version != "2.0":
        return FAIL, f'fmiVersion is "{version}", this checker handles FMI 2.0 only'
    if arc.root.find("CoSimulation") is None:
        return FAIL, "no CoSimulation element: not a co-simulation FMU (model exchange is not checked)"
    if not arc.model_identifier:
        return FAIL, "CoSimulation has no modelIdentifier"
    return PASS, f'FMI 2.0 co-simulation, modelIdentifier "{arc.model_identifier}"'


def check_fmpy_validate(arc: FmuArchive) -> tuple[str, str]:
    from fmpy.validation import validate_fmu
    try:
        problems = validate_fmu(str(arc.path))
    except Exception as e:  # fmpy raises on unreadable archives
        problems = [f"{type(e).__name__}: {e}"]
    if problems:
        return FAIL, f"{len(problems)} problem(s): " + " | ".join(problems[:5]) + (" | ..." if len(problems) > 5 else "")
    return PASS, "fmpy.validation.validate_fmu found no problems"


def check_binary(arc: FmuArchive) -> tuple[str, str]:
    plat, ext = host_platform()
    wanted = f"binaries/{plat}/{arc.model_identifier}{ext}"
    if wanted in arc.members:
        return PASS, wanted
    have = sorted({m.split("/")[1] for m in arc.members if m.startswith("binaries/") and m.count("/") >= 2 and m.split("/")[1]})
    sources = any(m.startswith("sources/") for m in arc.members)
    found = f"binaries for: {', '.join(have)}" if have else "no binaries"
    return FAIL, f"no {wanted} ({found}{'; has sources/ (compile them first)' if sources else ''}): it cannot run here"


def _type_units(root: ET.Element) -> dict[str, str | None]:
    """SimpleType name -> unit of its Real element (None if it has none or is not Real)."""
    units: dict[str, str | None] = {}
    for st in root.findall("TypeDefinitions/SimpleType"):
        real = st.find("Real")
        units[st.get("name", "")] = (real.get("unit") or None) if real is not None else None
    return units


def check_units(arc: FmuArchive) -> tuple[str, str]:
    type_units = _type_units(arc.root)
    missing: list[str] = []
    n_real = 0
    for sv in arc.variables():
        real = sv.find("Real")
        if real is None:
            continue
        n_real += 1
        unit = (real.get("unit") or "").strip()
        if unit:
            continue
        declared = real.get("declaredType")
        if declared and (type_units.get(declared) or "").strip():
            continue
        missing.append(sv.get("name", "?") + (f" (declaredType {declared} has no unit)" if declared else ""))
    if n_real == 0:
        return SKIP, "no Real variables"
    if missing:
        return FAIL, (f"{len(missing)} of {n_real} Real variables have no unit: {_names_list(missing)} "
                      '(give each a unit, or a declaredType with a unit; unit="1" for dimensionless)')
    return PASS, f"all {n_real} Real variables have a unit"


def check_output_dependencies(arc: FmuArchive) -> tuple[str, str]:
    variables = arc.variables()
    outputs = arc.root.findall("ModelStructure/Outputs/Unknown")
    if not outputs:
        return SKIP, "no outputs declared in ModelStructure/Outputs"
    missing: list[str] = []
    for u in outputs:
        if u.get("dependencies") is None:
            try:
                missing.append(variables[int(u.get("index", "0")) - 1].get("name", "?"))
            except (ValueError, IndexError):
                missing.append(f"index {u.get('index')}")
    if missing:
        return FAIL, (f"{len(missing)} of {len(outputs)} outputs declare no dependencies (an importer must then "
                      f"assume direct feedthrough from every input): {_names_list(missing)}")
    return PASS, f"all {len(outputs)} outputs declare their dependencies"


def check_descriptions(arc: FmuArchive) -> tuple[str, str]:
    variables = arc.variables()
    if not variables:
        return SKIP, "no variables"
    missing = [sv.get("name", "?") for sv in variables if not (sv.get("description") or "").strip()]
    if missing:
        return FAIL, f"{len(missing)} of {len(variables)} variables have no description: {_names_list(missing)}"
    return PASS, f"all {len(variables)} variables have a description"


def check_names(arc: FmuArchive) -> tuple[str, str]:
    variables = arc.variables()
    if not variables:
        return SKIP, "no variables"
    convention = arc.root.get("variableNamingConvention", "flat")
    names = [sv.get("name") or "" for sv in variables]
    problems: list[str] = []
    seen: set[str] = set()
    for name in names:
        if name in seen:
            problems.append(f"{name!r} is not unique")
        seen.add(name)
        if not name:
            problems.append("a variable has an empty name")
        elif convention == "structured":
            if not is_structured_name(name):
                problems.append(f"{name!r} is not a legal structured name")
        elif any(c in name for c in "\r\n\t"):
            problems.append(f"{name!r} contains a carriage return, line feed or tab")
    if problems:
        return FAIL, f'naming convention "{convention}": ' + "; ".join(problems[:8]) + ("; ..." if len(problems) > 8 else "")
    return PASS, f'all {len(names)} names are unique and legal for naming convention "{convention}"'


_CHECKS: dict[str, Callable[[FmuArchive], tuple[str, str]]] = {
    "static.fmi2-cosimulation": check_fmi2_cosimulation,
    "static.fmpy-validate": check_fmpy_validate,
    "static.binary": check_binary,
    "static.units": check_units,
    "static.output-dependencies": check_output_dependencies,
    "static.descriptions": check_descriptions,
    "static.names": check_names,
}


def run_static_checks(fmu_path: str | Path, subject: str | None = None) -> list[CheckResult]:
    """Run every static check on one FMU file; ``subject`` names it in the report (default: the path).

    When the archive is not an FMI 2.0 co-simulation FMU, the other checks are SKIPped (they
    would only repeat the same failure).
    """
    subject = subject if subject is not None else str(fmu_path)
    arc = read_archive(fmu_path)
    results: list[CheckResult] = []
    for check_id in STATIC_CHECKS:
        t0 = time.perf_counter()
        if check_id != "static.fmi2-cosimulation" and results and results[0].failed:
            status, reason = SKIP, "not an FMI 2.0 co-simulation FMU (see static.fmi2-cosimulation)"
        else:
            try:
                status, reason = _CHECKS[check_id](arc)
            except Exception as e:  # a malformed description must not stop the other checks
                status, reason = FAIL, f"could not evaluate: {type(e).__name__}: {e}"
        results.append(CheckResult(subject, check_id, status, reason, time.perf_counter() - t0))
    return results
