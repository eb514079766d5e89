"""Export a scene as an SSP 1.0 archive that other co-simulation masters run.

``export_ssp(scene, fmu_files, path)`` writes ``path`` (a zip) holding::

    SystemStructure.ssd      the coupled system, written and schema-checked with pyssp-standard
    resources/<FMU>.fmu      each FMU the scene uses, once (instances share the file)

What the SSD carries (see docs/interoperability.md for what it cannot):

* one ``ssd:Component`` per FMU instance (``application/x-fmu-sharedlibrary``), with a connector
  for every input, output, parameter and calculated parameter of the FMU;
* one inline ``ssd:ParameterBinding`` per instance: the scene's parameters (for a
  SpurDifferential instance also the scene's ``effects``, overridden by its own parameters, as
  our master does) and the scene's input profiles as start values on the inputs (a table input
  gets its value at t = 0);
* one ``ssd:Connection`` per scene connection (output -> input);
* ``ssd:DefaultExperiment`` from 0 to the scene's duration, with the communication step as the
  Open Simulation Platform annotation ``osp:FixedStepAlgorithm baseStepSize`` (libcosim reads it);
* a ``org.spurdiff.scene`` annotation on the system: step, algorithm, output interval, the
  recorded variables and the input tables, which only :mod:`harness.interop.libcosim_run` reads.

``spurdiff export-ssp SCENE [-o FILE] [--step H] [--mesh M] [--set inst.param=value]`` is
:func:`main`.
"""
from __future__ import annotations

import contextlib
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

from harness.common.paths import results_dir

from harness.scene.spec import Scene, SceneError, parameter_value, safe_name

SSD_FILE = "SystemStructure.ssd"
FMU_TYPE = "application/x-fmu-sharedlibrary"
OSP_ANNOTATION = "com.opensimulationplatform"
OSP_NS = "http://opensimulationplatform.com/SSP/OSPAnnotations"
SCENE_ANNOTATION = "org.spurdiff.scene"
SCENE_NS = "urn:spurdiff:ssp-scene:1"
CONNECTOR_KINDS = ("input", "output", "parameter", "calculatedParameter")


class SspError(RuntimeError):
    """The SSP file could not be written or does not pass the SSP schema / connection checks."""


@dataclass
class ExportSummary:
    """What went into an SSP file (for the command line and the docs)."""

    path: Path
    components: int
    connections: int
    values: int              # parameter and input start values bound
    tables: list[str]        # table inputs carried only as their t = 0 value (+ scene annotation)


def _model_descriptions(scene: Scene, fmu_files: dict[str, Path]):
    from fmpy import read_model_description

    from harness.fmi.instance import fmi2_type_names

    mds = {}
    for inst in scene.instances:
        if inst.fmu not in fmu_files:
            raise SceneError(f"{inst.name}: no FMU file for {inst.fmu!r}; have: {', '.join(sorted(fmu_files))}")
        if inst.fmu not in mds:   # an FMI 3.0 FMU's Float64/Int32 are SSP 1.0's Real/Integer
            mds[inst.fmu] = fmi2_type_names(read_model_description(str(fmu_files[inst.fmu])))
    return mds


def instance_values(scene: Scene) -> dict[str, dict[str, object]]:
    """Start values per instance, as our master applies them: parameters (:meth:`Scene.parameters_of`:
    the differential's effects under its own parameters), then each input profile's value at t = 0.
    The scene is checked against the FMUs first (:meth:`Scene.check_wiring`)."""
    out = {spec.name: dict(scene.parameters_of(spec.name)) for spec in scene.instances}
    for ref, prof in scene.inputs.items():
        inst, name = ref.split(".", 1)
        out[inst][name] = prof(0.0)
    return out


def _typed(where: str, var, value) -> tuple[str, str]:
    """(ssv type, value text) for a start value of an FMU variable, converted by the variable's
    type as every other command converts it (:func:`harness.scene.spec.parameter_value`: 'off' is
    false, a whole float is an integer...)."""
    if var.type not in ("Real", "Integer", "Enumeration", "Boolean", "String"):
        raise SceneError(f"{where}: variable type {var.type} cannot be bound in SSP")
    v = parameter_value(where, var.type, value)
    if var.type == "Real":
        return "Real", repr(v)
    if var.type in ("Integer", "Enumeration"):  # libcosim cannot read ssv:Enumeration; an enumeration is its integer
        return "Integer", str(v)
    if var.type == "Boolean":
        return "Boolean", "true" if v else "false"
    return "String", v


def _parameter_type(ptype: str, text: str):
    """An ssv value element; values are in the FMU's own units, so no unit attribute is written."""
    from pyssp_standard.parameter_types import ParameterType

    pt = ParameterType(ptype, {"value": text})
    pt.parameter = {k: v for k, v in pt.parameter.items() if v is not None}  # pyssp writes unit=None otherwise
    return pt


def _connector(var):
    from pyssp_standard.common_content_ssc import TypeBoolean, TypeInteger, TypeReal, TypeString
    from pyssp_standard.ssd import Connector

    type_ = {"Real": lambda: TypeReal(None), "Integer": TypeInteger, "Enumeration": TypeInteger,
             "Boolean": TypeBoolean, "String": TypeString}[var.type]()
    return Connector(name=var.name, kind=var.causality, type_=type_)


def _scene_annotation(scene: Scene, tables: dict):
    """The harness facts no SSP element holds: step, algorithm, recording and input tables."""
    from lxml import etree as ET
    from pyssp_standard import Annotation

    q = lambda tag: f"{{{SCENE_NS}}}{tag}"  # noqa: E731
    root = ET.Element(q("Scene"), nsmap={"sd": SCENE_NS},
                      attrib={"name": scene.name, "step": repr(scene.step), "algorithm": scene.algorithm,
                              "outputInterval": repr(scene.output_interval), "duration": repr(scene.duration)})
    for ref in scene.record:
        ET.SubElement(root, q("Record"), variable=ref)
    for ref, prof in tables.items():
        inst, var = ref.split(".", 1)
        tab = ET.SubElement(root, q("InputTable"), element=inst, connector=var)
        for t, v in zip(prof.times, prof.values):
            ET.SubElement(tab, q("Point"), time=repr(t), value=repr(v))
    ann = Annotation(SCENE_ANNOTATION)
    ann.add_element(root)
    return ann


def _osp_annotation(step: float):
    from lxml import etree as ET
    from pyssp_standard import Annotation

    # libcosim walks the children of osp:Algorithm and takes an attribute (such as an xmlns
    # declaration) for an algorithm, so the osp prefix is declared on the ssc:Annotation.
    root = ET.Element(f"{{{Annotation.namespaces['ssc']}}}Annotation", nsmap={"osp": OSP_NS},
                      attrib={"type": OSP_ANNOTATION})
    alg = ET.SubElement(root, f"{{{OSP_NS}}}Algorithm")
    ET.SubElement(alg, f"{{{OSP_NS}}}FixedStepAlgorithm", baseStepSize=repr(step))
    return Annotation(root)


def _check(ssd) -> None:
    """Schema (SSP 1.0, XSD 1.1) and connection semantics; one-line SspError on failure."""
    import xmlschema

    try:
        ssd.__check_compliance__()
    except xmlschema.XMLSchemaValidationError as e:
        raise SspError(f"{SSD_FILE} fails the SSP 1.0 schema at {e.path}: {e.reason}") from None
    problems = ssd.check_connections(unallowed_connections=True, ambiguous_data_flow=True)
    if problems:
        raise SspError(f"{SSD_FILE}: {problems[0]}" + (f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""))


def export_ssp(scene: Scene, fmu_files: dict[str, Path], path: Path | str) -> Path:
    """Write ``scene`` with ``fmu_files`` (FMU name -> .fmu) as an SSP archive at ``path``."""
    return export_ssp_summary(scene, fmu_files, path).path


def export_ssp_summary(scene: Scene, fmu_files: dict[str, Path], path: Path | str) -> ExportSummary:
    """:func:`export_ssp`, also returning what was written."""
    path = Path(path)
    if path.suffix != ".ssp":
        raise SspError(f"{path}: an SSP file name must end in .ssp")
    mds = _model_descriptions(scene, fmu_files)
    variables = {i.name: {v.name: v for v in mds[i.fmu].modelVariables} for i in scene.instances}
    scene.check_wiring(variables)
    values = instance_values(scene)
    tables = {ref: p for ref, p in scene.inputs.items() if p.kind != "constant"}

    from harness.common.outputs import private_path

    with private_path(path) as partial:   # pyssp writes the archive even on error: removed then
        n_values = _write(scene, fmu_files, mds, variables, values, partial)
    return ExportSummary(path, len(scene.instances), len(scene.connections), n_values, sorted(tables))


@contextlib.contextmanager
def _pyssp_archive(path: Path):
    """pyssp-standard's SSP writing ``path``, its temporary folder (``pyssp_*``, where it unpacks the
    archive) removed after, also when writing the archive fails: pyssp writes it in its exit and
    removes the folder only after that (a full disk left 53 MB behind per failed export)."""
    from pyssp_standard import SSP

    folder = None
    try:
        with SSP(path, mode="w") as ssp:
            folder = Path(ssp.unpacked_path).parent
            yield ssp
    finally:
        if folder is not None and folder.name.startswith("pyssp_"):
            shutil.rmtree(folder, ignore_errors=True)


def _write(scene: Scene, fmu_files: dict[str, Path], mds: dict, variables: dict, values: dict, path: Path) -> int:
    """Write the archive with pyssp-standard; returns the number of start values bound."""
    from pyssp_standard import Connection
    from pyssp_standard.ssd import Component, DefaultExperiment, ParameterBinding, System
    from pyssp_standard.ssv import SSVElem

    tables = {ref: p for ref, p in scene.inputs.items() if p.kind != "constant"}
    n_values = 0
    with _pyssp_archive(path) as ssp:
        for fmu in sorted({i.fmu for i in scene.instances}):
            ssp.add_resource(Path(fmu_files[fmu]))
        with ssp.system_structure as ssd:
            ssd.name, ssd.version = scene.name, "1.0"
            ssd.top_level_metadata.generationTool = "spurdiff export-ssp (pyssp_standard)"
            system = System(name=scene.name)
            for spec in scene.instances:
                comp = Component()
                comp.name, comp.component_type = spec.name, FMU_TYPE
                comp.source = f"resources/{Path(fmu_files[spec.fmu]).name}"
                comp.connectors = [_connector(v) for v in mds[spec.fmu].modelVariables if v.causality in CONNECTOR_KINDS]
                params = []
                for name, value in values[spec.name].items():
                    ptype, text = _typed(f"{spec.name}.{name}", variables[spec.name][name], value)
                    params.append({"name": name, "type_name": ptype, "type_value": _parameter_type(ptype, text)})
                if params:
                    comp.parameter_bindings = [ParameterBinding(ssv=SSVElem(name=f"{spec.name}.start", parameters=params))]
                    n_values += len(params)
                system.elements.append(comp)
            for to, frm in scene.connections.items():
                (ti, tv), (fi, fv) = to.split(".", 1), frm.split(".", 1)
                system.connections.append(Connection(start_element=fi, start_connector=fv,
                                                     end_element=ti, end_connector=tv))
            system.annotations.add_annotation(_scene_annotation(scene, tables))
            ssd.system = system
            exp = DefaultExperiment()
            exp.start_time, exp.stop_time = 0.0, scene.duration
            exp.annotations.add_annotation(_osp_annotation(scene.step))
            ssd.default_experiment = exp
            _check(ssd)
    return n_values


def default_output(scene: Scene) -> Path:
    name = safe_name("scene name", scene.name)   # a name becomes a path only after validation
    return results_dir(name) / f"{name}.ssp"
