"""Post-processing of a pythonfmu modelDescription.xml.

pythonfmu 0.7 writes no units, no UnitDefinitions, no InitialUnknowns and no dependencies, so
``fmpy validate`` rejects its FMUs. From the FMU's own :class:`~spurdiff.fmi.variables.Var` list this
module adds: ``unit`` / ``displayUnit`` on every Real, the UnitDefinitions (SI base-unit exponents
and display-unit factors), ``Outputs`` with their direct dependencies and ``InitialUnknowns``
(outputs and calculated parameters, which are computed in initialization). It also states
``needsExecutionTool``: false for an FMU that carries its own Python runtime (the default build),
true for one that runs on pythonfmu's wrapper and the host's Python.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from typing import Iterable, Sequence

from spurdiff.fmi.variables import Var

# unit -> (SI base-unit exponents, {display unit: (factor, offset)}); value_display = factor * value + offset
UNITS: dict[str, tuple[dict[str, int] | None, dict[str, tuple[float, float]]]] = {
    "1": ({}, {"%": (100.0, 0.0)}),
    "s": ({"s": 1}, {"ms": (1e3, 0.0)}),
    "m": ({"m": 1}, {"mm": (1e3, 0.0)}),
    "m/s": ({"m": 1, "s": -1}, {"km/h": (3.6, 0.0)}),
    "m/s2": ({"m": 1, "s": -2}, {"g": (1.0 / 9.80665, 0.0)}),
    "rad": ({"rad": 1}, {"deg": (180.0 / math.pi, 0.0)}),
    "rad/s": ({"rad": 1, "s": -1}, {"rpm": (30.0 / math.pi, 0.0), "deg/s": (180.0 / math.pi, 0.0)}),
    "rad/s2": ({"rad": 1, "s": -2}, {"deg/s2": (180.0 / math.pi, 0.0)}),
    "N": ({"kg": 1, "m": 1, "s": -2}, {"kN": (1e-3, 0.0)}),
    "N.m": ({"kg": 1, "m": 2, "s": -2}, {"N.mm": (1e3, 0.0)}),
    "N.m/rad": ({"kg": 1, "m": 2, "s": -2, "rad": -1}, {"N.m/deg": (math.pi / 180.0, 0.0)}),
    "N.m.s/rad": ({"kg": 1, "m": 2, "s": -1, "rad": -1}, {"N.m.s/deg": (math.pi / 180.0, 0.0)}),
    "N/m": ({"kg": 1, "s": -2}, {"N/mm": (1e-3, 0.0)}),
    "N.s/m": ({"kg": 1, "s": -1}, {"N.s/mm": (1e-3, 0.0)}),
    "W": ({"kg": 1, "m": 2, "s": -3}, {"kW": (1e-3, 0.0)}),
    "J": ({"kg": 1, "m": 2, "s": -2}, {"kJ": (1e-3, 0.0)}),
    "kg": ({"kg": 1}, {"g": (1e3, 0.0)}),
    "kg.m2": ({"kg": 1, "m": 2}, {"kg.mm2": (1e6, 0.0)}),
    "kg/m3": ({"kg": 1, "m": -3}, {"kg/mm3": (1e-9, 0.0)}),
    "m2": ({"m": 2}, {"mm2": (1e6, 0.0)}),
    "N.m.s/m": ({"kg": 1, "m": 1, "s": -1}, {"N.m.s/mm": (1e-3, 0.0)}),
    "N.m/m": ({"kg": 1, "m": 1, "s": -2}, {"N.m/mm": (1e-3, 0.0)}),
    "Pa": ({"kg": 1, "m": -1, "s": -2}, {"MPa": (1e-6, 0.0)}),
    "1/s": ({"s": -1}, {"1/min": (60.0, 0.0)}),
    "N.m/s": ({"kg": 1, "m": 2, "s": -3}, {"kN.m/s": (1e-3, 0.0)}),
    "N/s": ({"kg": 1, "m": 1, "s": -3}, {"kN/s": (1e-3, 0.0)}),
    "1/(kg.m2)": ({"kg": -1, "m": -2}, {"1/(kg.mm2)": (1e-6, 0.0)}),
}


def generation_tool(pythonfmu_tool: str | None) -> str:
    """``spurdiff <version>``, and the pythonfmu whose modules the FMU's Python side runs on (what
    pythonfmu wrote, e.g. "PythonFMU 0.7.0")."""
    from importlib.metadata import PackageNotFoundError, version
    try:
        ours = version("spurdiff")
    except PackageNotFoundError:
        import spurdiff
        ours = spurdiff.__version__
    tool = f"spurdiff {ours}"
    return f"{tool} (with {pythonfmu_tool} modules)" if pythonfmu_tool else tool


def _indent(elem: ET.Element, level: int = 0) -> None:
    ET.indent(elem, space="  ", level=level)


def add_unit_definitions(root: ET.Element, used: Iterable[str]) -> None:
    used = sorted(set(used))
    old = root.find("UnitDefinitions")
    if old is not None:
        root.remove(old)
    ud = ET.Element("UnitDefinitions")
    for name in used:
        if name not in UNITS:
            raise KeyError(f"unit {name!r} has no definition in harness/build/modeldescription.py UNITS")
        base, displays = UNITS[name]
        u = ET.SubElement(ud, "Unit", name=name)
        if base is not None:
            ET.SubElement(u, "BaseUnit", {k: str(v) for k, v in base.items()})
        for dname, (factor, offset) in displays.items():
            attrs = {"name": dname, "factor": repr(factor)}
            if offset:
                attrs["offset"] = repr(offset)
            ET.SubElement(u, "DisplayUnit", attrs)
    # UnitDefinitions comes right after the CoSimulation/ModelExchange elements
    children = list(root)
    pos = 0
    for i, child in enumerate(children):
        if child.tag in ("ModelExchange", "CoSimulation"):
            pos = i + 1
    root.insert(pos, ud)


def postprocess(xml_text: str, variables: Sequence[Var], default_experiment: dict | None = None,
                needs_execution_tool: bool = False) -> str:
    """Return modelDescription.xml text with units, dependencies and InitialUnknowns added, and
    CoSimulation's ``needsExecutionTool`` set (false: the FMU carries its runtime)."""
    root = ET.fromstring(xml_text)
    root.set("generationTool", generation_tool(root.get("generationTool")))
    for cs in root.findall("CoSimulation"):
        cs.set("needsExecutionTool", "true" if needs_execution_tool else "false")
    by_name = {v.name: v for v in variables}
    mv = root.find("ModelVariables")
    index: dict[str, int] = {}
    used_units: set[str] = set()
    for i, sv in enumerate(mv.findall("ScalarVariable"), start=1):
        name = sv.get("name")
        index[name] = i
        v = by_name.get(name)
        if v is None:
            raise KeyError(f"variable {name} is not declared in the FMU's VARIABLES list")
        if v.description:
            sv.set("description", v.description)
        integer = sv.find("Integer")
        if integer is not None:
            if v.min is not None:
                integer.set("min", str(int(v.min)))
            if v.max is not None:
                integer.set("max", str(int(v.max)))
        real = sv.find("Real")
        if real is not None:
            if not v.unit:
                raise ValueError(f"Real variable {name} has no unit")
            real.set("unit", v.unit)
            used_units.add(v.unit)
            if v.min is not None:
                real.set("min", repr(float(v.min)))
            if v.max is not None:
                real.set("max", repr(float(v.max)))
            if v.display_unit:
                if v.display_unit not in UNITS[v.unit][1]:
                    raise ValueError(f"{name}: display unit {v.display_unit} not defined for {v.unit}")
                real.set("displayUnit", v.display_unit)
        if v.causality in ("output", "calculatedParameter"):
            # computed in initialization: no start value
            for child in sv:
                child.attrib.pop("start", None)
            sv.set("initial", "calculated")
    add_unit_definitions(root, used_units)

    if default_experiment:
        old = root.find("DefaultExperiment")
        if old is not None:
            root.remove(old)
        de = ET.Element("DefaultExperiment", {k: repr(float(v)) for k, v in default_experiment.items()})
        root.insert(list(root).index(mv), de)

    ms = root.find("ModelStructure")
    for child in list(ms):
        ms.remove(child)
    outputs = [v for v in variables if v.causality == "output"]
    calculated = [v for v in variables if v.causality == "calculatedParameter"]
    if outputs:
        out_el = ET.SubElement(ms, "Outputs")
        for v in outputs:
            _unknown(out_el, v, index)
    if outputs or calculated:
        init_el = ET.SubElement(ms, "InitialUnknowns")
        for v in sorted(outputs + calculated, key=lambda v: index[v.name]):
            ET.SubElement(init_el, "Unknown", index=str(index[v.name]))
    _indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _unknown(parent: ET.Element, v: Var, index: dict[str, int]) -> None:
    deps = " ".join(str(index[d]) for d in v.depends)
    attrs = {"index": str(index[v.name]), "dependencies": deps}
    if v.depends:
        attrs["dependenciesKind"] = " ".join("dependent" for _ in v.depends)
    ET.SubElement(parent, "Unknown", attrs)
