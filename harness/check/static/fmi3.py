"""Static rules for FMI 3.0 FMUs (kind ``static3``): the archive and modelDescription.xml, no binary loaded.

One function per ``static3`` rule of :mod:`..rules`, each taking the parsed :class:`~..archive.FmuArchive` and returning
(status, reason). The tables are FMI 3.0's (section 2.4.7.4 Table 18, section 2.4.7.5 Table 22).
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import Callable

from ..archive import FmuArchive
from ..report import FAIL, PASS, SKIP
from .common import check_archive, cut as _cut, start_range

Outcome = tuple[str, str]

FLOATS = ("Float32", "Float64")
INTS = {"Int8": (-2 ** 7, 2 ** 7 - 1), "UInt8": (0, 2 ** 8 - 1), "Int16": (-2 ** 15, 2 ** 15 - 1),
        "UInt16": (0, 2 ** 16 - 1), "Int32": (-2 ** 31, 2 ** 31 - 1), "UInt32": (0, 2 ** 32 - 1),
        "Int64": (-2 ** 63, 2 ** 63 - 1), "UInt64": (0, 2 ** 64 - 1), "Enumeration": (-2 ** 63, 2 ** 63 - 1)}
TYPES = FLOATS + tuple(INTS) + ("Boolean", "String", "Binary", "Clock")

# Table 18 (2.4.7.4): variability -> causalities allowed
ALLOWED = {"constant": {"output", "local"},
           "fixed": {"structuralParameter", "parameter", "calculatedParameter", "local"},
           "tunable": {"structuralParameter", "parameter", "calculatedParameter", "local"},
           "discrete": {"input", "output", "local"},
           "continuous": {"input", "output", "local", "independent"}}
# Table 22 (2.4.7.5): (causality, variability) -> (default initial, allowed initial values)
_PARAMS = {"structuralParameter": ("exact", {"exact"}), "parameter": ("exact", {"exact"}),
           "calculatedParameter": ("calculated", {"calculated", "approx"}), "local": ("calculated", {"calculated", "approx"})}
_SIGNALS = {"input": ("exact", {"exact"}), "output": ("calculated", {"calculated", "exact", "approx"}),
            "local": ("calculated", {"calculated", "exact", "approx"})}
INITIAL = {**{(c, "constant"): ("exact", {"exact"}) for c in ("output", "local")},
           **{(c, v): d for v in ("fixed", "tunable") for c, d in _PARAMS.items()},
           **{(c, v): d for v in ("discrete", "continuous") for c, d in _SIGNALS.items()}}


class Var:
    """One variable element of ModelVariables, with its defaults filled in (FMI 3.0)."""

    def __init__(self, el: ET.Element):
        self.el, self.type = el, el.tag
        self.name = el.get("name", "")
        self.vr = el.get("valueReference")
        self.causality = el.get("causality", "local")
        self.variability = el.get("variability") or ("continuous" if self.type in FLOATS else "discrete")
        self.initial = el.get("initial")
        self.start = el.get("start")
        if self.start is None and el.find("Start") is not None:   # String/Binary arrays: <Start value=.../>
            self.start = " ".join(s.get("value", "") for s in el.findall("Start"))
        self.dimensions = el.findall("Dimension")
        self.clocked = el.get("clocks") is not None

    def initial_or_default(self) -> str | None:
        if self.initial is not None:
            return self.initial
        d = INITIAL.get((self.causality, self.variability))
        return d[0] if d else None


def variables(arc: FmuArchive) -> list[Var]:
    mv = arc.root.find("ModelVariables") if arc.root is not None else None
    return [Var(el) for el in mv] if mv is not None else []


def _by_vr(vs: list[Var]) -> dict[str, Var]:
    return {v.vr: v for v in vs if v.vr is not None}


def _result(problems: list[str], n: int, what: str) -> Outcome:
    if problems:
        return FAIL, f"{len(problems)} problem(s): " + _cut(problems)
    return PASS, f"{what} ({n} checked)"


# --- the rules ---------------------------------------------------------------------------------

def check_fmi3(arc: FmuArchive) -> Outcome:
    if arc.root is None:
        return FAIL, arc.xml_error or "no modelDescription.xml"
    problems = []
    version = arc.root.get("fmiVersion") or ""
    if not version.startswith("3."):
        problems.append(f'fmiVersion is "{version}", not "3.x"')
    if not (arc.root.get("instantiationToken") or "").strip():
        problems.append("no instantiationToken (a mandatory attribute)")
    kinds = [t for t in ("ModelExchange", "CoSimulation", "ScheduledExecution") if arc.root.find(t) is not None]
    if not kinds:
        problems.append("neither a ModelExchange, CoSimulation nor ScheduledExecution element")
    problems += [f"{t} without modelIdentifier" for t in kinds if not arc.root.find(t).get("modelIdentifier")]
    if problems:
        return FAIL, "; ".join(problems)
    return PASS, f"FMI {version}: " + ", ".join(f'{t} ("{arc.root.find(t).get("modelIdentifier")}")' for t in kinds)


def check_schema(arc: FmuArchive) -> Outcome:
    import os

    import fmpy
    from lxml import etree
    xsd = os.path.join(os.path.dirname(fmpy.__file__), "schema", "fmi3", "fmi3ModelDescription.xsd")
    schema = etree.XMLSchema(file=xsd)
    root = etree.fromstring(ET.tostring(arc.root))
    if schema.validate(root):
        return PASS, "valid against fmi3ModelDescription.xsd"
    errors = [f"line {e.line}: {e.message}" for e in schema.error_log]
    return FAIL, f"{len(errors)} schema error(s): " + _cut(errors, 4)


def check_binary3(arc: FmuArchive) -> Outcome:
    from fmpy import platform_tuple, sharedLibraryExtension
    ids = {arc.root.find(t).get("modelIdentifier") for t in ("ModelExchange", "CoSimulation")
           if arc.root.find(t) is not None and arc.root.find(t).get("modelIdentifier")}
    if not ids:
        return SKIP, "no ModelExchange or CoSimulation interface"
    wanted = sorted(f"binaries/{platform_tuple}/{i}{sharedLibraryExtension}" for i in ids)
    missing = [w for w in wanted if w not in arc.members]
    if not missing:
        return PASS, ", ".join(wanted)
    have = sorted({m.split("/")[1] for m in arc.members if m.startswith("binaries/") and m.count("/") >= 2})
    return FAIL, f"no {', '.join(missing)} (binaries for: {', '.join(have) or 'none'}): it cannot run here"


def check_variables(arc: FmuArchive) -> Outcome:
    vs = variables(arc)
    problems, names, vrs = [], {}, {}
    for v in vs:
        for alias in [v.name] + [a.get("name", "") for a in v.el.findall("Alias")]:
            if not alias:
                problems.append(f"a variable ({v.type} vr {v.vr}) has an empty name")
            elif alias in names:
                problems.append(f"name {alias!r} is not unique")
            names[alias] = v
        if v.vr in vrs:
            problems.append(f"valueReference {v.vr} of {v.name} is also {vrs[v.vr].name}'s")
        vrs[v.vr] = v
        if v.type not in TYPES:
            problems.append(f"{v.name}: element <{v.type}> is no variable type")
        if v.variability == "continuous" and v.type not in FLOATS:
            problems.append(f'{v.name}: a {v.type} with variability="continuous" (only Float32/Float64 may be)')
        if v.type == "Clock" and v.variability != "discrete":
            problems.append(f"{v.name}: a Clock with variability={v.variability!r}")
    indep = [v for v in vs if v.causality == "independent"]
    if len(indep) != 1:
        problems.append(f"{len(indep)} independent variables (exactly one must be)")
    problems += [f"{v.name}: the independent variable is a {v.type} (a floating point type is required)"
                 for v in indep if v.type not in FLOATS]
    problems += [f"{v.name}: the independent variable has a start value" for v in indep if v.start is not None]
    return _result(problems, len(vs), "names and value references unique, one independent variable, continuous "
                                      "only on floats")


def check_causality_variability(arc: FmuArchive) -> Outcome:
    vs = variables(arc)
    bad = [f'{v.name}: causality="{v.causality}" with variability="{v.variability}"' for v in vs
           if v.causality not in ALLOWED.get(v.variability, ())]
    return _result(bad, len(vs), "every causality/variability combination is one Table 18 allows")


def check_initial(arc: FmuArchive) -> Outcome:
    vs = variables(arc)
    problems = []
    for v in vs:
        if v.type == "Clock" or v.causality not in ALLOWED.get(v.variability, ()):
            continue   # Clocks have no start; a refused combination is static3.causality-variability's finding
        if v.causality == "independent":
            if v.initial is not None:
                problems.append(f"{v.name}: the independent variable has initial={v.initial!r}")
            continue
        default, allowed = INITIAL[(v.causality, v.variability)]
        if v.initial is not None and v.initial not in allowed:
            problems.append(f'{v.name}: initial="{v.initial}" for causality="{v.causality}", variability='
                            f'"{v.variability}" (Table 22 allows {", ".join(sorted(allowed))})')
            continue
        initial = v.initial or default
        needs = initial in ("exact", "approx") or v.causality in ("parameter", "input") or v.variability == "constant"
        if needs and v.start is None:
            problems.append(f'{v.name}: no start value (initial="{initial}", causality="{v.causality}")')
        if initial == "calculated" and v.start is not None:
            problems.append(f'{v.name}: initial="calculated" but a start value ({v.start})')
    return _result(problems, len(vs), "initial and start as Table 22 and 2.4.7.5 say")


def check_units(arc: FmuArchive) -> Outcome:
    units = {u.get("name"): {d.get("name") for d in u.findall("DisplayUnit")}
             for u in arc.root.findall("UnitDefinitions/Unit")}
    types = {t.get("name"): t for t in (arc.root.find("TypeDefinitions") or [])}
    problems, n = [], 0

    def check(where: str, unit: str | None, display: str | None) -> None:
        if unit is not None and unit not in units:
            problems.append(f"{where}: unit {unit!r} is not defined under UnitDefinitions")
        if display is not None:
            if unit is None:
                problems.append(f"{where}: displayUnit {display!r} without a unit")
            elif unit in units and display not in units[unit]:
                problems.append(f"{where}: displayUnit {display!r} is not a DisplayUnit of {unit!r}")

    for name, t in types.items():
        n += 1
        check(f"type {name}", t.get("unit"), t.get("displayUnit"))
    for v in variables(arc):
        n += 1
        dt = types.get(v.el.get("declaredType") or "")
        unit = v.el.get("unit") or (dt.get("unit") if dt is not None else None)
        check(v.name, v.el.get("unit"), v.el.get("displayUnit"))
        for a in v.el.findall("Alias"):
            if a.get("displayUnit") is not None:
                check(f"{v.name} alias {a.get('name')}", unit, a.get("displayUnit"))
    return _result(problems, n, "every unit and displayUnit is defined")


def check_outputs(arc: FmuArchive) -> Outcome:
    vs = variables(arc)
    by_vr = _by_vr(vs)
    ms = arc.root.find("ModelStructure")
    listed = [o.get("valueReference") for o in (ms.findall("Output") if ms is not None else [])]
    problems = []
    for vr in listed:
        v = by_vr.get(vr)
        if v is None:
            problems.append(f"Output valueReference {vr} names no variable")
        elif v.causality != "output":
            problems.append(f'Output lists {v.name}, which has causality="{v.causality}"')
    problems += [f"Output lists valueReference {vr} {listed.count(vr)} times" for vr in sorted(set(listed))
                 if listed.count(vr) > 1]
    problems += [f"output {v.name} is not listed under ModelStructure/Output" for v in vs
                 if v.causality == "output" and v.vr not in listed]
    for d in (ms.findall("ContinuousStateDerivative") if ms is not None else []):
        v = by_vr.get(d.get("valueReference"))
        if v is None:
            problems.append(f"ContinuousStateDerivative valueReference {d.get('valueReference')} names no variable")
        elif v.el.get("derivative") is None:
            problems.append(f"ContinuousStateDerivative {v.name} has no derivative attribute")
        elif by_vr.get(v.el.get("derivative")) is None or by_vr[v.el.get("derivative")].type not in FLOATS:
            problems.append(f"{v.name}: derivative={v.el.get('derivative')} names no float variable")
    return _result(problems, len(listed), "Output lists every output once; every state derivative names its state")


def check_initial_unknowns(arc: FmuArchive) -> Outcome:
    vs = variables(arc)
    by_vr = _by_vr(vs)
    ms = arc.root.find("ModelStructure")
    if ms is None:
        return FAIL, "no ModelStructure"
    listed = [u.get("valueReference") for u in ms.findall("InitialUnknown")]
    expected: dict[str, str] = {}
    for v in vs:
        init = v.initial_or_default()
        if v.causality == "output" and not v.clocked and init in ("approx", "calculated"):
            expected[v.vr] = f'output, initial="{init}"'
        if v.causality == "calculatedParameter":
            expected[v.vr] = "calculatedParameter"
    for d in ms.findall("ContinuousStateDerivative"):
        der = by_vr.get(d.get("valueReference"))
        state = by_vr.get(der.el.get("derivative")) if der is not None else None
        for w, what in ((der, "state derivative"), (state, "continuous-time state")):
            if w is not None and w.initial_or_default() in ("approx", "calculated"):
                expected[w.vr] = f'{what}, initial="{w.initial_or_default()}"'
    events = {e.get("valueReference") for e in ms.findall("EventIndicator")}
    problems = [f"InitialUnknown lists valueReference {vr} {listed.count(vr)} times" for vr in sorted(set(listed))
                if listed.count(vr) > 1]
    for vr in listed:
        v = by_vr.get(vr)
        if v is None:
            problems.append(f"InitialUnknown valueReference {vr} names no variable")
        elif vr not in expected and not v.clocked:
            why = "an event indicator" if vr in events else f'causality="{v.causality}", initial="{v.initial_or_default()}"'
            problems.append(f"InitialUnknown lists {v.name} ({why})")
    problems += [f"{by_vr[vr].name} ({what}) is not listed as InitialUnknown" for vr, what in expected.items()
                 if vr not in listed]
    return _result(problems, len(expected), "InitialUnknown lists exactly the unknowns of 2.4.8")


def _size(v: Var, by_vr: dict[str, Var]) -> int | None:
    n = 1
    for d in v.dimensions:
        start = d.get("start")
        ref = by_vr.get(d.get("valueReference")) if start is None else None
        text = start if start is not None else (ref.start if ref is not None else None)
        try:
            n *= int(text)
        except (TypeError, ValueError):
            return None
    return n


def check_dimensions(arc: FmuArchive) -> Outcome:
    vs = variables(arc)
    by_vr = _by_vr(vs)
    problems, n = [], 0
    for v in vs:
        if v.causality == "structuralParameter" and v.dimensions:
            problems.append(f"structural parameter {v.name} has a <Dimension>")
        for d in v.dimensions:
            n += 1
            start, ref = d.get("start"), d.get("valueReference")
            if (start is None) == (ref is None):
                problems.append(f"{v.name}: a Dimension with {'both' if start else 'neither'} start and valueReference")
                continue
            if ref is not None:
                r = by_vr.get(ref)
                if r is None:
                    problems.append(f"{v.name}: Dimension valueReference {ref} names no variable")
                    continue
                if r.type != "UInt64" or not (r.variability == "constant" or r.causality == "structuralParameter"):
                    problems.append(f"{v.name}: Dimension valueReference {ref} is {r.name}, a {r.type} "
                                    f'(causality="{r.causality}", variability="{r.variability}"), not a UInt64 '
                                    f"constant or structural parameter")
                    continue
                start = r.start
            try:
                if int(start) <= 0:
                    problems.append(f"{v.name}: initial dimension size {start} (must be positive)")
            except (TypeError, ValueError):
                problems.append(f"{v.name}: initial dimension size {start!r} is no integer")
    if not n and not problems:
        return SKIP, "no array variables"
    return _result(problems, n, "every Dimension is one size or one UInt64 structural parameter, positive")


def _numbers(text: str | None, typ: str) -> list[float]:
    if text is None:
        return []
    out = []
    for w in text.split():
        if typ in FLOATS:
            out.append(float(w))
        else:
            out.append(float(int(w)))
    return out


def check_start_range3(arc: FmuArchive) -> Outcome:
    types = {t.get("name"): t for t in (arc.root.find("TypeDefinitions") or [])}

    def items():
        for v in variables(arc):
            if (v.type not in FLOATS and v.type not in INTS) or v.start is None:
                continue
            dt = types.get(v.el.get("declaredType") or "")
            lo = v.el.get("min") if v.el.get("min") is not None else (dt.get("min") if dt is not None else None)
            hi = v.el.get("max") if v.el.get("max") is not None else (dt.get("max") if dt is not None else None)
            yield v.name, v.start, lambda text, t=v.type: _numbers(text, t), lo, hi
    return start_range(items(), _cut)


CHECKS3: dict[str, Callable[[FmuArchive], Outcome]] = {
    "static3.archive": check_archive,
    "static3.fmi3": check_fmi3,
    "static3.schema": check_schema,
    "static3.binary": check_binary3,
    "static3.variables": check_variables,
    "static3.causality-variability": check_causality_variability,
    "static3.initial": check_initial,
    "static3.units": check_units,
    "static3.outputs": check_outputs,
    "static3.initial-unknowns": check_initial_unknowns,
    "static3.dimensions": check_dimensions,
    "static3.start-range": check_start_range3,
}
GATES3 = ("static3.archive", "static3.fmi3")   # when one fails, the others are SKIPped
