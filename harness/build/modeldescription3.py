"""The FMI 3.0 modelDescription.xml of an FMU, from the same declaration as its FMI 2.0 one.

The FMI 2.0 file (pythonfmu's, post-processed by :mod:`harness.build.modeldescription`) gives the
model's attributes, the GUID (FMI 3.0's ``instantiationToken``), the value references pythonfmu
assigned and the start values the class reports; the FMU's :class:`~spurdiff.fmi.variables.Var`
list gives everything else, as it does for FMI 2.0: causality, variability, unit, display unit,
range, description, the outputs' dependencies. The unit definitions are the same
(:data:`harness.build.modeldescription.UNITS`). FMI 3.0 adds:

* the independent variable ``time`` (exactly one is required), value reference :data:`TIME_VR`,
  answered by the FMI 3.0 binary itself (``fmu_src/native/fmi/fmi3_loader.c``);
* types by size: Real -> ``Float64``, Integer -> ``Int32``; a String's start is a ``Start`` element;
* ``ModelStructure`` by value reference: ``Output``, ``InitialUnknown``;
* the Co-Simulation capabilities of the FMI 3.0 binary: no Event Mode, no intermediate update;
  ``maxOutputDerivativeOrder`` and ``mightReturnEarlyFromDoStep`` as the interface module declares
  them (``MAX_OUTPUT_DERIVATIVE_ORDER``, ``MIGHT_RETURN_EARLY``; SpurDifferential: 1 and true, the
  others 0 and false).
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import Sequence

from harness.build.modeldescription import add_unit_definitions
from spurdiff.fmi.variables import Var

FMI3_VERSION = "3.0"
TIME_VR = 2147483647          # fmi3_loader.c: TIME_VR
PLATFORM = "x86_64-linux"     # the FMI 3.0 platform tuple of binaries/<platform>/
TYPE3 = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}
CATEGORIES = (("logStatusWarning", "Log messages with fmi3Warning status."),
              ("logStatusDiscard", "Log messages with fmi3Discard status."),
              ("logStatusError", "Log messages with fmi3Error status."),
              ("logStatusFatal", "Log messages with fmi3Fatal status."),
              ("logAll", "Log all messages."))


def fmi3_description(fmi2_xml: str, variables: Sequence[Var], default_experiment: dict | None = None,
                     max_output_derivative_order: int = 0, might_return_early: bool = False) -> str:
    """The FMI 3.0 modelDescription.xml text of the FMU whose FMI 2.0 one is ``fmi2_xml``."""
    md2 = ET.fromstring(fmi2_xml)
    cs2 = md2.find("CoSimulation")
    if cs2 is None:
        raise ValueError("the FMI 2.0 modelDescription.xml has no CoSimulation element")
    sv2 = {sv.get("name"): sv for sv in md2.find("ModelVariables").findall("ScalarVariable")}
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": FMI3_VERSION, "modelName": md2.get("modelName"),
        "instantiationToken": md2.get("guid"),
        **{k: md2.get(k) for k in ("description", "author", "license", "generationTool",
                                   "generationDateAndTime") if md2.get(k)},
        "variableNamingConvention": "structured"})
    ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": cs2.get("modelIdentifier"),
        "needsExecutionTool": cs2.get("needsExecutionTool", "false"),
        "canBeInstantiatedOnlyOncePerProcess": "false",
        "canGetAndSetFMUState": "true", "canSerializeFMUState": "true",
        "canHandleVariableCommunicationStepSize": "true",
        "maxOutputDerivativeOrder": str(int(max_output_derivative_order)),
        "providesIntermediateUpdate": "false",
        "mightReturnEarlyFromDoStep": "true" if might_return_early else "false",
        "canReturnEarlyAfterIntermediateUpdate": "false", "hasEventMode": "false"})
    used_units = {"s"} | {v.unit for v in variables if v.kind == "Real" and v.unit}
    add_unit_definitions(root, used_units)
    cats = ET.SubElement(root, "LogCategories")
    for name, text in CATEGORIES:
        ET.SubElement(cats, "Category", name=name, description=text)
    if default_experiment:
        ET.SubElement(root, "DefaultExperiment", {k: repr(float(v)) for k, v in default_experiment.items()})
    mv = ET.SubElement(root, "ModelVariables")
    ET.SubElement(mv, "Float64", {"name": "time", "valueReference": str(TIME_VR), "causality": "independent",
                                  "variability": "continuous", "description": "Simulation time", "unit": "s"})
    vr: dict[str, str] = {}
    for v in variables:
        sv = sv2.get(v.name)
        if sv is None:
            raise KeyError(f"variable {v.name} is declared but not in the FMI 2.0 modelDescription.xml")
        vr[v.name] = sv.get("valueReference")
        typed2 = sv.find(v.kind)
        if typed2 is None:
            raise ValueError(f"variable {v.name} is {v.kind} in the declaration but not in modelDescription.xml")
        attrs = {"name": v.name, "valueReference": vr[v.name], "causality": v.causality,
                 "variability": v.fmi_variability}
        if v.description:
            attrs["description"] = v.description
        if sv.get("initial"):
            attrs["initial"] = sv.get("initial")
        start = typed2.get("start")
        for key in ("unit", "displayUnit", "min", "max") if v.kind == "Real" else ("min", "max"):
            if typed2.get(key) is not None:
                attrs[key] = typed2.get(key)
        if start is not None and v.kind != "String":
            attrs["start"] = start
        el = ET.SubElement(mv, TYPE3[v.kind], attrs)
        if start is not None and v.kind == "String":
            ET.SubElement(el, "Start", value=start)
    ms = ET.SubElement(root, "ModelStructure")
    outputs = [v for v in variables if v.causality == "output"]
    for v in outputs:
        deps = " ".join(vr[d] for d in v.depends)
        attrs = {"valueReference": vr[v.name], "dependencies": deps}
        if v.depends:
            attrs["dependenciesKind"] = " ".join("dependent" for _ in v.depends)
        ET.SubElement(ms, "Output", attrs)
    # the initial unknowns: outputs and calculated parameters (computed in initialization)
    for v in sorted((v for v in variables if v.causality in ("output", "calculatedParameter")),
                    key=lambda v: int(vr[v.name])):
        ET.SubElement(ms, "InitialUnknown", valueReference=vr[v.name])
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"
