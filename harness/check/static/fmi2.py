"""Static rules for FMI 2.0 FMUs (kind ``static``): the archive and its modelDescription.xml (no binary loaded).

Each ``static`` rule of :mod:`..rules` has one function here taking the parsed :class:`~..archive.FmuArchive`
and returning (status, reason). See docs/compliance.md for the table.
"""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from typing import Callable

from ..archive import FmuArchive
from ..report import FAIL, PASS, SKIP
from .common import check_archive, start_range

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


def _names_list(names: list[str], limit: int = 8) -> str:
    shown = ", ".join(names[:limit])
    return shown + (f", ... ({len(names) - limit} more)" if len(names) > limit else "")


Outcome = tuple[str, str]


# --- the rules ---------------------------------------------------------------------------------

def check_fmi2(arc: FmuArchive) -> Outcome:
    if arc.root is None:
        return FAIL, arc.xml_error
    version = arc.root.get("fmiVersion")
    if version != "2.0":
        return FAIL, f'fmiVersion is "{version}", this kit checks FMI 2.0 only'
    kinds = [k for k in ("cs", "me") if arc.interface(k) is not None]
    if not kinds:
        return FAIL, "neither a CoSimulation nor a ModelExchange element"
    missing = [k for k in kinds if not arc.model_identifier(k)]
    if missing:
        return FAIL, " and ".join({"cs": "CoSimulation", "me": "ModelExchange"}[k] for k in missing) + " without modelIdentifier"
    names = {"cs": "co-simulation", "me": "model exchange"}
    return PASS, "FMI 2.0 " + " and ".join(f'{names[k]} ("{arc.model_identifier(k)}")' for k in kinds)


def check_fmpy_validate(arc: FmuArchive) -> Outcome:
    from fmpy.validation import validate_fmu
    try:
        problems = validate_fmu(str(arc.path))
    except Exception as e:  # fmpy raises on unreadable archives
        problems = [f"{type(e).__name__}: {e}"]
    if problems:
        return FAIL, f"{len(problems)} problem(s): " + " | ".join(problems[:5]) + (" | ..." if len(problems) > 5 else "")
    return PASS, "fmpy.validation.validate_fmu found no problems"


def check_binary(arc: FmuArchive) -> Outcome:
    plat, ext = host_platform()
    have_ids = [(k, arc.model_identifier(k)) for k in ("cs", "me") if arc.model_identifier(k)]
    found = [f"binaries/{plat}/{mid}{ext}" for _, mid in have_ids if f"binaries/{plat}/{mid}{ext}" in arc.members]
    wanted = [f"binaries/{plat}/{mid}{ext}" for _, mid in have_ids]
    if found and set(found) == set(wanted):
        return PASS, ", ".join(sorted(set(found)))
    have = sorted({m.split("/")[1] for m in arc.members if m.startswith("binaries/") and m.count("/") >= 2 and m.split("/")[1]})
    sources = any(m.startswith("sources/") for m in arc.members)
    where = f"binaries for: {', '.join(have)}" if have else "no binaries"
    missing = sorted(set(wanted) - set(found))
    return FAIL, (f"no {', '.join(missing)} ({where}{'; has sources/ (compile them first)' if sources else ''}): "
                  f"it cannot run here")


def _type_units(root: ET.Element) -> dict[str, str | None]:
    units: dict[str, str | None] = {}
    for st in root.findall("TypeDefinitions/SimpleType"):
        real = st.find("Real")
        units[st.get("name", "")] = (real.get("unit") or None) if real is not None else None
    return units


def check_units(arc: FmuArchive) -> Outcome:
    type_units = _type_units(arc.root)
    missing: list[str] = []
    n_real = 0
    for sv in arc.variables():
        real = sv.find("Real")
        if real is None or sv.get("causality") == "independent":
            continue
        n_real += 1
        if (real.get("unit") or "").strip():
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


def _outputs_without_dependencies(arc: FmuArchive) -> tuple[list[str], int]:
    variables = arc.variables()
    outputs = arc.root.findall("ModelStructure/Outputs/Unknown")
    missing: list[str] = []
    for u in outputs:
        if u.get("dependencies") is None:
            try:
                missing.append(variables[int(u.get("index", "0")) - 1].get("name", "?"))
            except (ValueError, IndexError):
                missing.append(f"index {u.get('index')}")
    return missing, len(outputs)


def _every(missing: list[str], n: int, none: str, lacking: str, having: str, note: str = "") -> Outcome:
    """SKIP (``none``) when there are no items, FAIL naming the ``missing`` of ``n``, else PASS."""
    if not n:
        return SKIP, none
    if missing:
        return FAIL, f"{len(missing)} of {n} {lacking}{note}: {_names_list(missing)}"
    return PASS, f"all {n} {having}"


def check_output_dependencies(arc: FmuArchive) -> Outcome:
    if not any(sv.get("causality") == "input" for sv in arc.variables()):
        return SKIP, "no inputs: an output can depend on nothing but time and states"
    missing, n = _outputs_without_dependencies(arc)
    return _every(missing, n, "no outputs declared in ModelStructure/Outputs", "outputs declare no dependencies",
                  "outputs declare their dependencies",
                  " (an importer must then assume direct feedthrough from every input)")


def check_all_output_dependencies(arc: FmuArchive) -> Outcome:
    missing, n = _outputs_without_dependencies(arc)
    return _every(missing, n, "no outputs declared in ModelStructure/Outputs", "outputs declare no dependencies",
                  "outputs declare their dependencies")


def check_descriptions(arc: FmuArchive) -> Outcome:
    variables = arc.variables()
    missing = [sv.get("name", "?") for sv in variables if not (sv.get("description") or "").strip()]
    return _every(missing, len(variables), "no variables", "variables have no description", "variables have a description")


def check_names(arc: FmuArchive) -> Outcome:
    variables = arc.variables()
    if not variables:
        return SKIP, "no variables"
    convention = arc.root.get("variableNamingConvention", "flat")
    problems: list[str] = []
    seen: set[str] = set()
    for sv in variables:
        name = sv.get("name") or ""
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
    return PASS, f'all {len(variables)} names are unique and legal for naming convention "{convention}"'


def check_model_exchange(arc: FmuArchive) -> Outcome:
    if arc.interface("me") is None:
        return SKIP, "no ModelExchange element"
    problems: list[str] = []
    nei = arc.root.get("numberOfEventIndicators", "0")
    try:
        if int(nei) < 0:
            raise ValueError
    except ValueError:
        problems.append(f"numberOfEventIndicators={nei!r} is not a non-negative integer")
    variables = arc.variables()

    def real_of(i: int) -> ET.Element | None:
        return variables[i - 1].find("Real") if 1 <= i <= len(variables) else None

    derivative_of: dict[int, int] = {}
    for i, sv in enumerate(variables, 1):
        real = sv.find("Real")
        if real is not None and real.get("derivative"):
            try:
                derivative_of[i] = int(real.get("derivative"))
            except ValueError:
                problems.append(f"{sv.get('name')}: derivative={real.get('derivative')!r} is not an index")
    listed: list[int] = []
    for u in arc.root.findall("ModelStructure/Derivatives/Unknown"):
        try:
            listed.append(int(u.get("index", "")))
        except ValueError:
            problems.append(f"Derivatives/Unknown index={u.get('index')!r} is not an index")
    for i in listed:
        if i not in derivative_of:
            name = variables[i - 1].get("name") if 1 <= i <= len(variables) else f"index {i}"
            problems.append(f"Derivatives lists {name}, which has no derivative attribute")
            continue
        j = derivative_of[i]
        state = real_of(j)
        if state is None:
            problems.append(f"{variables[i - 1].get('name')}: derivative={j} points to no Real variable")
        elif variables[j - 1].get("variability", "continuous") != "continuous":
            problems.append(f"state {variables[j - 1].get('name')} is not continuous")
    if problems:
        return FAIL, "; ".join(problems[:6]) + ("; ..." if len(problems) > 6 else "")
    return PASS, (f"{len(listed)} continuous states, each listed derivative names a continuous Real state; "
                  f"{nei} event indicators")


def check_start_range(arc: FmuArchive) -> Outcome:
    types: dict[str, ET.Element] = {}
    for st in arc.root.findall("TypeDefinitions/SimpleType"):
        for el in st:
            types[st.get("name", "")] = el

    def items():
        for sv in arc.variables():
            el = next((c for c in sv if c.tag in ("Real", "Integer", "Enumeration")), None)
            if el is None or el.get("start") is None:
                continue
            base = types.get(el.get("declaredType") or "")
            lo = el.get("min") if el.get("min") is not None else (base.get("min") if base is not None else None)
            hi = el.get("max") if el.get("max") is not None else (base.get("max") if base is not None else None)
            yield sv.get("name"), el.get("start"), lambda text: [float(text)], lo, hi
    return start_range(items(), lambda problems: "; ".join(problems[:6]))


CHECKS: dict[str, Callable[[FmuArchive], Outcome]] = {
    "static.archive": check_archive,
    "static.fmi2": check_fmi2,
    "static.fmpy-validate": check_fmpy_validate,
    "static.binary": check_binary,
    "static.names": check_names,
    "static.model-exchange": check_model_exchange,
    "static.start-range": check_start_range,
    "static.output-dependencies": check_output_dependencies,
    "static.units": check_units,
    "static.descriptions": check_descriptions,
    "static.all-output-dependencies": check_all_output_dependencies,
}
