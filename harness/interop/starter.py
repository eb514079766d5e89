"""``spurdiff starter``: a ready-to-run starting point for SpurDifferential.fmu in your own tool,
for one interface (``shaftCoupling`` wheel or torque) and one kind of host (docs/use-the-fmu.md):

* ``fmpy``: the FMU and ``fmpy_differential.py`` (fmpy and numpy only);
* ``c``:    the FMU unzipped and ``host.c``, an FMI 2.0 host in C with the FMU's folder, GUID and
  value references filled in (``cc -O2 -o host host.c -ldl``);
* ``ssp``:  ``vehicle-cornering.ssp``, the main job's four FMUs coupled with that interface (wheel:
  the scene as it is, 5 ms; torque: the wheels owning the half-shafts, 0.2 ms), and
  ``libcosim_ssp.py`` that runs it in libcosim.

The recipes live in :mod:`harness.interop.recipes` and import nothing from this package; what they need
is copied or written into the starter's folder. :func:`write_starter` returns the files written
and the command that runs the starter.
"""
from __future__ import annotations

import re
import shutil
import zipfile
from importlib import resources
from pathlib import Path

from harness.common.outputs import output_folder, write_text
from harness.scene.schema import SceneError

HOSTS = ("fmpy", "c", "ssp")
INTERFACES = ("wheel", "torque")
STEPS = {"wheel": 5e-3, "torque": 2e-4}    # s: what each interface needs (docs/fmus.md, "Which shaft coupling")
SSP_SCENE = "vehicle-cornering"


def recipe_text(name: str) -> str:
    return resources.files("harness.interop.recipes").joinpath(name).read_text(encoding="utf-8")


def c_host_source(fmu_dir: Path, interface: str, step: float | None = None) -> str:
    """``fmi2_host.c`` for the unzipped FMU in ``fmu_dir``: its folder, GUID, model identifier and
    the value references of the variables the host uses filled in from its modelDescription.xml."""
    from fmpy import read_model_description

    md = read_model_description(str(fmu_dir))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    text = recipe_text("fmi2_host.c")
    fills = {"FMU_DIR": str(Path(fmu_dir).resolve()), "MODEL_ID": md.coSimulation.modelIdentifier, "GUID": md.guid,
             "INTERFACE": interface, "STEP": repr(step or STEPS[interface])}
    for key, value in fills.items():
        if '"' in value or "\\" in value:
            raise SceneError(f"{key} = {value!r}: a path or name with a quote or backslash cannot go into C source")
        text = text.replace(f"@{key}@", value)

    def ref(m: re.Match) -> str:
        if m.group(1) not in vr:
            raise SceneError(f"{fmu_dir}: the FMU has no variable {m.group(1)!r} (is it SpurDifferential?)")
        return str(vr[m.group(1)])
    return re.sub(r"@VR:([^@]+)@", ref, text)


def write_starter(host: str, interface: str, out: Path, duration: float | None = None) -> tuple[list[Path], str]:
    """Write the starter into folder ``out`` (created); returns the files and the command to run."""
    from harness.build.fmu import build

    if host not in HOSTS:
        raise SceneError(f"host {host!r}: allowed {', '.join(HOSTS)}")
    if interface not in INTERFACES:
        raise SceneError(f"interface {interface!r}: allowed {', '.join(INTERFACES)}")
    out = output_folder(Path(out))
    written: list[Path] = []
    if host == "ssp":
        return _ssp_starter(interface, out, duration)
    (fmu,) = build(["SpurDifferential"], None, quiet=True)
    stop = f" {duration:g}" if duration else ""
    if host == "fmpy":
        target = out / "SpurDifferential.fmu"
        shutil.copyfile(fmu, target)
        written += [target, write_text(out / "fmpy_differential.py", recipe_text("fmpy_differential.py"))]
        cmd = (f"python fmpy_differential.py --interface {interface} --fmu SpurDifferential.fmu"
               + (f" --stop{stop}" if stop else ""))
        return written, cmd
    fmu_dir = out / "SpurDifferential"
    if fmu_dir.exists():
        shutil.rmtree(fmu_dir)
    with zipfile.ZipFile(fmu) as z:
        z.extractall(fmu_dir)
    for so in (fmu_dir / "binaries").rglob("*.so"):   # zip files do not keep the executable bit
        so.chmod(so.stat().st_mode | 0o111)
    written += [fmu_dir, write_text(out / "host.c", c_host_source(fmu_dir, interface))]
    return written, f"cc -O2 -o host host.c -ldl && ./host{stop}"


def _ssp_starter(interface: str, out: Path, duration: float | None) -> tuple[list[Path], str]:
    from harness.measure.bench.coupling import torque_coupled
    from harness.run.runner import fmu_files_for
    from harness.scene.spec import parse_scene, read_scene_data
    from harness.interop.ssp import export_ssp_summary

    if interface == "wheel":
        data = read_scene_data(SSP_SCENE)
    else:   # the wheels own the half-shafts, every input held over the step, 0.2 ms
        data = torque_coupled(SSP_SCENE, step=STEPS["torque"], output_interval=STEPS["torque"])
    if duration:   # the scene's results table and checks (windows up to its 3 s) do not go into an SSP
        data.update(duration=duration, table=[], checks=[])
    scene = parse_scene(data)
    files = fmu_files_for(scene, build_missing=True)
    ssp = out / f"{SSP_SCENE}-{interface}.ssp"
    export_ssp_summary(scene, files, ssp)
    script = write_text(out / "libcosim_ssp.py", recipe_text("libcosim_ssp.py"))
    return [ssp, script], f"python libcosim_ssp.py {ssp.name}"
