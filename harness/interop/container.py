"""Export a scene as one FMU: an FMU container of fmu-manipulation-toolbox (``pip install
fmu-manipulation-toolbox``), whose own C runtime (``container.so`` / ``container.dll``) steps the
scene's FMUs inside it.

``export_container(scene, fmu_files, path)`` writes ``path`` (``<scene>.fmu``). What goes in:

* each instance of the scene as an embedded FMU of its own (``<instance>_<FMU>.fmu``: the container
  names its embedded FMUs by file, so two wheels on one WheelLoad.fmu are two copies of it);
* the scene's connections as the container's links, the scene's parameters and its inputs' values
  at t = 0 as start values of the embedded FMUs (what :func:`harness.interop.ssp.instance_values` gives
  every exporter: for a SpurDifferential instance the scene's effects under its own parameters);
* the scene's recorded quantities as the container's outputs, named ``<instance>.<variable>``; every
  other output of an embedded FMU that no link reads is dropped (the toolbox's ``drop``: declared
  unused, instead of one "Output ... is not connected" warning each);
* the scene's communication step as the container's internal step, its duration as the default
  experiment's stop time (the toolbox takes the first FMU's; the written modelDescription is set to
  the scene's), and its coupling: ``gauss-seidel`` in the scene's order is the container's
  sequential mode (each FMU steps after the ones before it in the list, with their new outputs),
  ``jacobi`` its default parallel mode;
* ``fmi_version``: 2 puts the FMI 2.0 FMUs in an FMI 2.0 container, 3 the FMI 3.0 ones
  (``NAME-fmi3.fmu``) in an FMI 3.0 container (``fmucontainer -fmi 3``).

What the toolbox says while it builds (it exits 0 after ERROR lines too): its WARNING lines and
its "Input '...' is not connected" ERROR lines for inputs the scene does not connect (they keep their
start value, the scene's or the FMU's, as in our master) are carried as one-line warnings
(``ContainerSummary.warnings``, printed by the command); any other ERROR or CRITICAL line, or that line
for an input a link of ours feeds, says a part of the container was not made and fails the export
(``ContainerError`` naming the line; no file is written).

What the container cannot carry: an input that is a time table (only its value at t = 0; such a
scene is refused unless ``tables_at_start``) and our master's per-step extras (input ramps between
communication points are FMU inputs like any other and are connected, so they go in).
"""
from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from harness.common.paths import results_dir
from harness.scene.spec import Scene, SceneError, safe_name
from harness.interop.ssp import instance_values

TOOL = "fmu-manipulation-toolbox"


class ContainerError(RuntimeError):
    """The container could not be made (the toolbox missing or failing, a scene it cannot carry)."""


@dataclass
class ContainerSummary:
    path: Path
    fmus: int
    links: int
    starts: int
    outputs: int
    sequential: bool
    step: float
    tool: str
    fmi_version: int = 2
    warnings: tuple[str, ...] = ()      # the toolbox's WARNING / benign ERROR lines, one line each


def description(scene: Scene, tables_at_start: bool = False, causality: dict[str, str] | None = None) -> dict:
    """The toolbox's JSON description of the container for ``scene`` (see the module docstring);
    ``causality``: ``instance.variable`` -> causality, to keep only outputs among the recorded and to
    drop the outputs nothing reads."""
    tables = sorted(ref for ref, p in scene.inputs.items() if p.kind != "constant")
    if tables and not tables_at_start:
        raise ContainerError(f"scene {scene.name}: input(s) {', '.join(tables)} are time tables; a container holds "
                             "only start values (tables_at_start: their value at t = 0)")
    values = instance_values(scene)
    fmu = embedded_names(scene)
    links = []
    for to, frm in scene.connections.items():
        (ti, tv), (fi, fv) = to.split(".", 1), frm.split(".", 1)
        links.append([fmu[fi], fv, fmu[ti], tv])
    starts = [[fmu[inst], name, _json_value(v)] for inst, vals in values.items() for name, v in vals.items()]
    outputs = [[fmu[inst], var, ref] for ref in scene.record for inst, var in [ref.split(".", 1)]
               if causality is None or causality.get(ref) == "output"]
    used = set(scene.connections.values()) | {o[2] for o in outputs}
    drops = [[fmu[inst], var] for ref, c in (causality or {}).items() if c == "output" and ref not in used
             for inst, var in [ref.split(".", 1)]]
    return {"name": f"{safe_name('scene name', scene.name)}.fmu", "step_size": scene.step,
            "sequential": scene.algorithm != "jacobi", "mt": False,
            "auto_link": False, "auto_input": False, "auto_output": False, "auto_parameter": False,
            "auto_local": False,
            "fmu": [fmu[i.name] for i in scene.instances], "link": links, "start": starts, "output": outputs,
            "drop": drops}


def embedded_names(scene: Scene) -> dict[str, str]:
    """The file of each instance inside the container, ``<instance>_<FMU>.fmu`` (the toolbox names
    the links' variables after the file; ``<instance>.<variable>`` is left to the outputs)."""
    return {i.name: f"{i.name}_{i.fmu}.fmu" for i in scene.instances}


def _causalities(scene: Scene, fmu_files: dict[str, Path]) -> dict[str, str]:
    from fmpy import read_model_description
    mds = {f: read_model_description(str(fmu_files[f])) for f in {i.fmu for i in scene.instances}}
    return {f"{i.name}.{v.name}": v.causality for i in scene.instances for v in mds[i.fmu].modelVariables}


def _json_value(v):
    if isinstance(v, bool):
        return v
    if isinstance(v, (int, float, str)):
        return v
    return float(v)


def _toolbox() -> str:
    exe = Path(sys.executable).parent / "fmucontainer"
    if exe.is_file():
        return str(exe)
    found = shutil.which("fmucontainer")
    if found is None:
        raise ContainerError(f"{TOOL} is not installed (pip install {TOOL})")
    return found


def tool_version() -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return f"{TOOL} {version('fmu_manipulation_toolbox')}"
    except PackageNotFoundError:
        return TOOL


def export_container(scene: Scene, fmu_files: dict[str, Path], path: Path | str,
                     tables_at_start: bool = False, fmi_version: int = 2) -> ContainerSummary:
    """Write the container FMU of ``scene`` to ``path``; what went in. ``fmu_files``: the FMUs of
    ``fmi_version`` (2 or 3), which is also the container's own FMI version."""
    from harness.common.outputs import private_path

    path = Path(path)
    if fmi_version not in (2, 3):
        raise ContainerError(f"FMI version {fmi_version!r}: allowed 2 or 3")
    exe = _toolbox()
    _check_versions(scene, fmu_files, fmi_version)
    desc = description(scene, tables_at_start, _causalities(scene, fmu_files))
    with tempfile.TemporaryDirectory(prefix="spurdiff_container_") as tmp:
        work = Path(tmp)
        for spec in scene.instances:
            shutil.copyfile(fmu_files[spec.fmu], work / embedded_names(scene)[spec.name])
        (work / "container.json").write_text(json.dumps(desc, indent=1))
        r = subprocess.run([exe, "-container", "container.json", "-fmu-directory", str(work),
                            "-fmi", str(fmi_version)], cwd=work, capture_output=True, text=True, timeout=600)
        built = work / desc["name"]
        if r.returncode != 0 or not built.is_file():
            tail = [ln for ln in (r.stdout + r.stderr).splitlines() if "ERROR" in ln or "Error" in ln][-3:]
            raise ContainerError(f"fmucontainer failed (exit {r.returncode}): "
                                 + ("; ".join(tail) or (r.stdout + r.stderr).strip()[-300:]))
        warnings = toolbox_warnings(r.stdout + r.stderr, desc)
        with private_path(path) as partial:
            _write_with_experiment(built, partial, desc, fmi_version, scene.duration)
    return ContainerSummary(path, len(desc["fmu"]), len(desc["link"]), len(desc["start"]), len(desc["output"]),
                            desc["sequential"], scene.step, tool_version(), fmi_version, tuple(warnings))


_ANSI = re.compile(r"\x1b\[[0-9;]*m")
_LEVEL = re.compile(r"^(WARNING|ERROR|CRITICAL)\s*\|\s?(.*)$")
_UNCONNECTED_INPUT = re.compile(r"^Input 'Port (.+?)/(.+)' is not connected$")


def toolbox_warnings(output: str, desc: dict) -> list[str]:
    """The toolbox's WARNING and benign ERROR lines of a build that exited 0, one line each
    (``fmucontainer LEVEL: message``); ContainerError on an ERROR or CRITICAL line that says a part of
    the container was not made: any but "Input '<fmu>/<var>' is not connected" for an input no link
    of ``desc`` feeds (then it keeps its start value, as in our master)."""
    fed = {(ln[2], ln[3]) for ln in desc["link"]}
    starts = {(fmu, var): value for fmu, var, value in desc["start"]}
    warnings = []
    for raw in output.splitlines():
        m = _LEVEL.match(_ANSI.sub("", raw).strip())
        if m is None:
            continue
        level, message = m.groups()
        line = f"fmucontainer {level}: {message}"
        if level != "WARNING":
            unconnected = _UNCONNECTED_INPUT.match(message)
            if unconnected is None or unconnected.groups() in fed:
                raise ContainerError(f"{line} (it exited 0; the container is not written)")
            start = starts.get(unconnected.groups())
            line += (" (no link of the scene feeds it: it keeps "
                     + ("the FMU's start value)" if start is None else f"the scene's start value {start!r})"))
        warnings.append(line)
    return warnings


def _check_versions(scene: Scene, fmu_files: dict[str, Path], fmi_version: int) -> None:
    """Every embedded FMU is of the container's FMI version (the toolbox only warns otherwise)."""
    for name in sorted({i.fmu for i in scene.instances}):
        with zipfile.ZipFile(fmu_files[name]) as z:
            got = ET.fromstring(z.read("modelDescription.xml")).get("fmiVersion", "")
        if got.split(".")[0] != str(fmi_version):
            raise ContainerError(f"{Path(fmu_files[name]).name} is an FMI {got} FMU; an FMI {fmi_version}.0 "
                                 f"container takes FMI {fmi_version}.0 FMUs")


def _write_with_experiment(built: Path, out: Path, desc: dict, fmi_version: int, stop: float) -> None:
    """Copy the toolbox's container to ``out`` with the scene's stop time in its DefaultExperiment,
    after checking its modelDescription (FMI version, every output asked for)."""
    with zipfile.ZipFile(built) as zin, zipfile.ZipFile(out, "w") as zout:
        root = ET.fromstring(zin.read("modelDescription.xml"))
        if root.get("fmiVersion", "").split(".")[0] != str(fmi_version):
            raise ContainerError(f"fmucontainer wrote an FMI {root.get('fmiVersion')} container, "
                                 f"not FMI {fmi_version}.0")
        _check_description(root, desc)
        exp = root.find("DefaultExperiment")
        if exp is None:   # before ModelVariables, where both schemas put it
            exp = ET.Element("DefaultExperiment")
            root.insert(list(root).index(root.find("ModelVariables")), exp)
        exp.set("stopTime", repr(float(stop)))
        for info in zin.infolist():
            data = zin.read(info)
            if info.filename == "modelDescription.xml":
                data = b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8")
            zout.writestr(info, data)


def _check_description(root: ET.Element, desc: dict) -> None:
    """The container's modelDescription has every output the description asked for."""
    names = {sv.get("name") for sv in root.iter("ScalarVariable")} | {
        el.get("name") for el in root.find("ModelVariables") if el.get("name")}
    missing = [o[2] for o in desc["output"] if o[2] not in names]
    if missing:
        raise ContainerError(f"the container has no output(s) {', '.join(missing)}")


def default_output(scene: Scene) -> Path:
    name = safe_name("scene name", scene.name)
    return results_dir(name) / f"{name}.fmu"


__all__ = ["ContainerError", "ContainerSummary", "default_output", "description", "export_container", "tool_version",
           "toolbox_warnings"]
