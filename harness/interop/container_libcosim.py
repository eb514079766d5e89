"""A scene's container FMU (:mod:`harness.interop.container`) run in libcosim (``pip install libcosimpy``).

libcosim loads systems from SSP files; a container is one FMU, so it goes in an SSP of one
component (``scene``, the container as ``resources/<file>``, no connections, no bindings: its start
values are inside it) with the scene's step as the ``osp:FixedStepAlgorithm`` step, its duration as
the stop time and the container's outputs as the recording list. :func:`run_container_libcosim` runs
that SSP with :func:`harness.interop.libcosim_run.run_ssp` (in a child process) and returns a
:class:`harness.run.result.Result` whose names are the container's own (``diff.lockingTorque``).

libcosimpy 0.0.6 imports FMI 1.0 and 2.0 FMUs only (an FMI 3.0 FMU added as a slave ends the
process with SIGSEGV, docs/interoperability.md): an FMI 3.0 container is refused here with that reason.
"""
from __future__ import annotations

import tempfile
import zipfile
from pathlib import Path

from lxml import etree as ET

from harness.interop.libcosim_run import NS, SSD_FILE, LibcosimError, run_ssp
from harness.interop.ssp import FMU_TYPE, OSP_ANNOTATION, SCENE_ANNOTATION
from harness.run.result import Result
from harness.scene.spec import Scene

COMPONENT = "scene"


def container_outputs(container: Path) -> tuple[str, list[str]]:
    """The container's FMI version and the names of its Float64 / Real outputs."""
    with zipfile.ZipFile(container) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    version = root.get("fmiVersion", "")
    if version.startswith("2"):
        outs = [sv.get("name") for sv in root.iter("ScalarVariable")
                if sv.get("causality") == "output" and sv.find("Real") is not None]
    else:
        outs = [v.get("name") for v in root.find("ModelVariables")
                if v.tag == "Float64" and v.get("causality") == "output"]
    return version, outs


def ssd_text(scene: Scene, fmu_name: str, outputs: list[str]) -> bytes:
    """The SystemStructure.ssd of the one-component SSP (see the module docstring)."""
    q = lambda prefix, tag: f"{{{NS[prefix]}}}{tag}"  # noqa: E731
    root = ET.Element(q("ssd", "SystemStructureDescription"), version="1.0", name=scene.name,
                      nsmap={"ssd": NS["ssd"], "ssc": NS["ssc"]})
    system = ET.SubElement(root, q("ssd", "System"), name=scene.name)
    elements = ET.SubElement(system, q("ssd", "Elements"))
    ET.SubElement(elements, q("ssd", "Component"), name=COMPONENT, source=f"resources/{fmu_name}",
                  type=FMU_TYPE)
    ann = ET.SubElement(ET.SubElement(system, q("ssd", "Annotations")), q("ssc", "Annotation"), type=SCENE_ANNOTATION)
    sd = ET.SubElement(ann, q("sd", "Scene"), nsmap={"sd": NS["sd"]}, name=scene.name, step=repr(scene.step),
                       algorithm="container", duration=repr(scene.duration))
    for name in outputs:
        ET.SubElement(sd, q("sd", "Record"), variable=f"{COMPONENT}.{name}")
    exp = ET.SubElement(root, q("ssd", "DefaultExperiment"), startTime="0.0", stopTime=repr(scene.duration))
    # the osp prefix is declared on ssc:Annotation: libcosim takes any attribute of osp:Algorithm
    # (an xmlns declaration too) for an algorithm (docs/interoperability.md)
    osp = ET.SubElement(ET.SubElement(exp, q("ssd", "Annotations")), q("ssc", "Annotation"),
                        nsmap={"osp": NS["osp"]}, type=OSP_ANNOTATION)
    ET.SubElement(ET.SubElement(osp, q("osp", "Algorithm")), q("osp", "FixedStepAlgorithm"),
                  baseStepSize=repr(scene.step))
    return ET.tostring(root, xml_declaration=True, encoding="UTF-8", pretty_print=True)


def run_container_libcosim(container: Path | str, scene: Scene, timeout: float | None = None) -> Result:
    """The container in libcosim at the scene's step from 0 to its duration, every Real output
    recorded at every step (names without the component prefix)."""
    container = Path(container)
    version, outputs = container_outputs(container)
    if not version.startswith("2"):
        raise LibcosimError(f"{container.name} is an FMI {version} container; libcosim (libcosimpy 0.0.6) "
                            "imports FMI 1.0 and 2.0 FMUs only")
    with tempfile.TemporaryDirectory(prefix="spurdiff_container_libcosim_") as tmp:
        ssp = Path(tmp) / f"{container.stem}.ssp"
        with zipfile.ZipFile(ssp, "w", compression=zipfile.ZIP_STORED) as z:
            z.writestr(SSD_FILE, ssd_text(scene, container.name, outputs))
            z.write(container, f"resources/{container.name}")
        res = run_ssp(ssp, timeout=timeout)
    prefix = f"{COMPONENT}."
    res.names = [n[len(prefix):] if n.startswith(prefix) else n for n in res.names]
    res.scene = scene
    return res


__all__ = ["COMPONENT", "container_outputs", "run_container_libcosim", "ssd_text"]
