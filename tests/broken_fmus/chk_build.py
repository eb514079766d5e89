"""Building the compliance kit's test FMUs, once: cached under build/test-fmus/ by a hash of their
sources and build options (rebuilt only when these change).

* pythonfmu FMUs from the small scripts in this folder (ChkGood and broken variants, each a subclass
  of ChkGood, whose script is packed beside it), with their
  modelDescription.xml completed the way ``spurdiff build`` does it for ours (units,
  UnitDefinitions, output dependencies, InitialUnknowns);
* ChkC, a small C FMU (chkc.c, co-simulation and model exchange) compiled with gcc against the
  FMI 2.0 headers fmpy ships, once plainly and once per BREAK_* macro: the API-level breakages that
  pythonfmu's C++ layer does not let a Python script express (version strings, the logger's
  arguments, the GUID, status calls, fmi2FreeFMUstate, input/directional derivatives, ME calls);
* Chk3C, its FMI 3.0 counterpart (chk3c.c, co-simulation and model exchange), against fmpy's FMI 3.0
  headers: :func:`chk3c_fmu` plainly or with one ``BREAK_*`` macro of chk3c.c (the call-sequence rules),
  its modelDescription.xml optionally edited; :func:`static_variant` with the description edited (each
  edit must match exactly once), members left out or added, for the ``static3`` rules.

ChkC and Chk3C share their C code (chk_common.h) and their build (:func:`_gcc`). Nothing here comes
from the Reference FMUs: the models, their descriptions and their breakages are ours.
"""
from __future__ import annotations

import hashlib
import os
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
CACHE = ROOT / "build" / "test-fmus"
COMMON = HERE / "chk_common.h"   # included by chkc.c and chk3c.c

# unit of every Real in the pythonfmu test FMUs, and (SI base-unit exponents) of each unit
UNITS = {"u": "N.m", "k": "1", "x": "N.m.s", "y": "N.m", "phase": "1"}
BASE_UNITS = {"N.m": {"kg": "1", "m": "2", "s": "-2"}, "N.m.s": {"kg": "1", "m": "2", "s": "-1"}, "1": {}}
FEEDTHROUGH = {"y"}  # outputs with direct feedthrough from the inputs

# the end of both test FMUs' UnitDefinitions, their log categories and default experiment
UNITS_LOG_EXPERIMENT = """    <Unit name="N.m"><BaseUnit kg="1" m="2" s="-2"/></Unit>
    <Unit name="N.m.s"><BaseUnit kg="1" m="2" s="-1"/></Unit>
  </UnitDefinitions>
  <LogCategories>
    <Category name="logEvents" description="events"/>
    <Category name="logStatusError" description="errors"/>
  </LogCategories>
  <DefaultExperiment startTime="0" stopTime="1" stepSize="0.01"/>
"""

CHKC_GUID = "{c0ffee00-5b0d-4c1e-9a1e-000000000001}"
CHKC_XML = f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="ChkC" guid="{CHKC_GUID}" description="x' = k u, y = k u (compliance-kit test FMU in C)"
  generationTool="tests/broken_fmus/chk_build.py" variableNamingConvention="structured" numberOfEventIndicators="0">
  <ModelExchange modelIdentifier="ChkC" canGetAndSetFMUstate="true" canSerializeFMUstate="true" providesDirectionalDerivative="true"/>
  <CoSimulation modelIdentifier="ChkC" canHandleVariableCommunicationStepSize="true" canInterpolateInputs="true"
    canGetAndSetFMUstate="true" canSerializeFMUstate="true" providesDirectionalDerivative="true"/>
  <UnitDefinitions>
    <Unit name="1"/>
{UNITS_LOG_EXPERIMENT}  <ModelVariables>
    <ScalarVariable name="u" valueReference="0" description="input" causality="input" variability="continuous"><Real start="1" unit="N.m"/></ScalarVariable>
    <ScalarVariable name="k" valueReference="1" description="gain" causality="parameter" variability="fixed" initial="exact"><Real start="2" unit="1"/></ScalarVariable>
    <ScalarVariable name="x" valueReference="2" description="integral of k u" causality="output" variability="continuous" initial="exact"><Real start="0" unit="N.m.s"/></ScalarVariable>
    <ScalarVariable name="y" valueReference="3" description="k u" causality="output" variability="continuous" initial="calculated"><Real unit="N.m"/></ScalarVariable>
    <ScalarVariable name="der(x)" valueReference="4" description="derivative of x" causality="local" variability="continuous" initial="calculated"><Real derivative="3" unit="N.m"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs>
      <Unknown index="3" dependencies=""/>
      <Unknown index="4" dependencies="1" dependenciesKind="dependent"/>
    </Outputs>
    <Derivatives>
      <Unknown index="5" dependencies="1" dependenciesKind="dependent"/>
    </Derivatives>
    <InitialUnknowns>
      <Unknown index="4" dependencies="1 2" dependenciesKind="dependent dependent"/>
      <Unknown index="5" dependencies="1 2" dependenciesKind="dependent dependent"/>
    </InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"""

# ChkC variants: name -> BREAK_* / other macro (None: the well-behaved one)
CHKC_VARIANTS = {
    "ChkC": None,
    "ChkCVersion": "BREAK_VERSION",
    "ChkCTypes": "BREAK_TYPES",
    "ChkCLogger": "BREAK_LOGGER",
    "ChkCGuid": "BREAK_GUID",
    "ChkCDebugLogging": "BREAK_DEBUG_LOGGING",
    "ChkCInitGet": "BREAK_INIT_GET",
    "ChkCTerminatedGet": "BREAK_TERMINATED_GET",
    "ChkCStopTime": "BREAK_STOP_TIME",
    "ChkCDiscardAtStop": "DISCARD_AT_STOP",
    "ChkCWarnAtStop": "WARN_AT_STOP",
    "ChkCStrictInputs": "STRICT_INPUTS",
    "ChkCStatus": "BREAK_STATUS",
    "ChkCFreeState": "BREAK_FREE_STATE",
    "ChkCInterpolate": "BREAK_INTERPOLATE",
    "ChkCDirDer": "BREAK_DIRDER",
    "ChkCJacobian": "BREAK_JACOBIAN",
    "ChkCModelExchange": "BREAK_ME",
    "ChkCLateStep": "BREAK_LATE_STEP",
    "ChkCStaleOutput": "BREAK_STALE_Y",
    "ChkCOwnClock": "BREAK_CLOCK",
    "ChkCLostHistory": "BREAK_HISTORY",
    "ChkCNoLibm": "BREAK_LIBM",
    "ChkCStartRange": None,
    "ChkCNanHang": "BREAK_NAN_HANG",
}
# ChkC variants with another modelDescription.xml: name -> (old, new) replaced in CHKC_XML
CHKC_XML_EDITS = {
    # the gain's start value 2 lies above its declared max 1.5
    "ChkCStartRange": ('<Real start="2" unit="1"/>', '<Real start="2" min="0" max="1.5" unit="1"/>'),
}
NO_LIBM = {"ChkCNoLibm"}   # linked without -lm although it calls exp()


def _digest(*parts) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(p if isinstance(p, bytes) else str(p).encode())
        h.update(b"\0")
    return h.hexdigest()[:16]


def _gcc(src: Path, binary: Path, no_libm: bool, extra: list[str]) -> list[str]:
    """The gcc command that builds the test FMU ``src`` into the shared library ``binary`` against the FMI
    headers fmpy ships (2.0 and 3.0), linked with -lm unless ``no_libm`` (then libm is not declared
    although the code calls it); ``extra`` goes before the sources (macros) or, for -l/-L/-Wl, after."""
    import fmpy
    include = Path(fmpy.__file__).parent / "c-code"
    flags = [a for a in extra if a.startswith("-D")]
    libs = [a for a in extra if not a.startswith("-D")]
    return ["gcc", *flags, *(["-fno-builtin", "-Wl,--no-as-needed"] if no_libm else []), "-shared", "-fPIC", "-O1",
            "-std=c99", "-Wall", f"-I{include}", "-o", str(binary), str(src), *([] if no_libm else ["-lm"]), *libs]


def _cached(key: str, name: str, make) -> Path:
    """build/test-fmus/<key>/<name>.fmu, made by ``make(tmpdir) -> Path`` when missing."""
    target = CACHE / key / f"{name}.fmu"
    if target.exists():
        return target
    tmp = CACHE / f"tmp-{key}-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    try:
        built = make(tmp)
        target.parent.mkdir(parents=True, exist_ok=True)
        os.replace(built, target)  # atomic: concurrent sessions never see half a file
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return target


def rewrite_description(src: Path, dst: Path, edit) -> Path:
    """Copy the FMU ``src`` to ``dst`` with ``edit(root)`` applied to its modelDescription.xml."""
    with zipfile.ZipFile(src) as zin:
        root = ET.fromstring(zin.read("modelDescription.xml"))
        edit(root)
        with zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
            for item in zin.infolist():
                data = zin.read(item.filename)
                if item.filename == "modelDescription.xml":
                    data = ET.tostring(root, encoding="utf-8", xml_declaration=True)
                zout.writestr(item, data)
    return dst


def add_units_and_structure(root: ET.Element, drop_unit: str | None = None) -> None:
    """What pythonfmu leaves out: units with UnitDefinitions, output dependencies, InitialUnknowns."""
    variables = root.findall("ModelVariables/ScalarVariable")
    used = set()
    for sv in variables:
        real = sv.find("Real")
        if real is not None and sv.get("name") != drop_unit:
            real.set("unit", UNITS[sv.get("name")])
            used.add(UNITS[sv.get("name")])
    ud = ET.Element("UnitDefinitions")
    for name in sorted(used):
        ET.SubElement(ET.SubElement(ud, "Unit", name=name), "BaseUnit", BASE_UNITS[name])
    root.insert(list(root).index(root.find("CoSimulation")) + 1, ud)
    inputs = [str(i) for i, sv in enumerate(variables, 1) if sv.get("causality") == "input"]
    structure = root.find("ModelStructure")
    initial = ET.SubElement(structure, "InitialUnknowns")
    for u in structure.findall("Outputs/Unknown"):
        deps = inputs if variables[int(u.get("index")) - 1].get("name") in FEEDTHROUGH else []
        u.set("dependencies", " ".join(deps))
        if deps:
            u.set("dependenciesKind", " ".join("dependent" for _ in deps))
        ET.SubElement(initial, "Unknown", index=u.get("index"))


def pythonfmu_fmu(name: str, flags: list[str], complete: bool = True) -> Path:
    """The pythonfmu FMU built from ``<name>.py`` (completed description unless ``complete`` is False)."""
    import pythonfmu
    src, base = HERE / f"{name}.py", HERE / "ChkGood.py"
    key = _digest("pythonfmu", pythonfmu.__version__, sys.version, src.read_bytes(), base.read_bytes(), flags,
                  complete, (Path(__file__).read_bytes()))

    def make(tmp: Path) -> Path:
        subprocess.run([sys.executable, "-m", "pythonfmu", "build", "-f", str(src), "--dest", str(tmp), *flags,
                        *([str(base)] if src != base else [])],
                       check=True, capture_output=True)
        raw = tmp / f"{name}.fmu"
        if not complete:
            return raw
        return rewrite_description(raw, tmp / f"{name}-complete.fmu", add_units_and_structure)

    return _cached(key, name + ("" if complete else "-plain"), make)


def chkc_fmu(variant: str) -> Path:
    """A ChkC variant (see CHKC_VARIANTS), compiled with gcc (raises FileNotFoundError without it)."""
    import fmpy
    macro = CHKC_VARIANTS[variant]
    src = HERE / "chkc.c"
    xml = CHKC_XML
    if variant in CHKC_XML_EDITS:
        old, new = CHKC_XML_EDITS[variant]
        assert old in xml, variant
        xml = xml.replace(old, new)
    key = _digest("chkc", src.read_bytes(), COMMON.read_bytes(), xml, macro, variant in NO_LIBM,
                  Path(__file__).read_bytes())

    def make(tmp: Path) -> Path:
        binary = tmp / "binaries" / fmpy.platform / f"ChkC{fmpy.sharedLibraryExtension}"
        binary.parent.mkdir(parents=True)
        subprocess.run(_gcc(src, binary, variant in NO_LIBM, [f"-D{macro}"] if macro else []),
                       check=True, capture_output=True)
        out = tmp / f"{variant}.fmu"
        with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("modelDescription.xml", xml)
            z.write(binary, f"binaries/{fmpy.platform}/{binary.name}")
        return out

    return _cached(key, variant, make)


# ---- Chk3C (chk3c.c), the FMI 3.0 counterpart of ChkC
CHK3C_TOKEN = "{c0ffee00-5b0d-4c1e-9a1e-000000000003}"
CHK3C_XML = f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="3.0" modelName="Chk3C" instantiationToken="{CHK3C_TOKEN}"
  description="x' = k u, y = k u (compliance-kit test FMU in C, FMI 3.0)" generationTool="tests/broken_fmus/chk_build.py"
  variableNamingConvention="structured">
  <ModelExchange modelIdentifier="Chk3C" canGetAndSetFMUState="true" canSerializeFMUState="true"
    providesDirectionalDerivatives="true"/>
  <CoSimulation modelIdentifier="Chk3C" canHandleVariableCommunicationStepSize="true" canGetAndSetFMUState="true"
    canSerializeFMUState="true" providesDirectionalDerivatives="true" maxOutputDerivativeOrder="1"
    mightReturnEarlyFromDoStep="true" hasEventMode="true" providesIntermediateUpdate="true"/>
  <UnitDefinitions>
    <Unit name="1"/>
    <Unit name="s"><BaseUnit s="1"/></Unit>
{UNITS_LOG_EXPERIMENT}  <ModelVariables>
    <Float64 name="time" valueReference="0" description="time" causality="independent" variability="continuous" unit="s"/>
    <Float64 name="u" valueReference="1" description="input" causality="input" variability="continuous" start="1" unit="N.m"/>
    <Float64 name="k" valueReference="2" description="gain" causality="parameter" variability="fixed" start="2" unit="1"/>
    <Float64 name="x" valueReference="3" description="integral of k u" causality="output" variability="continuous" initial="exact" start="0" unit="N.m.s"/>
    <Float64 name="y" valueReference="4" description="k u" causality="output" variability="continuous" initial="calculated" unit="N.m"/>
    <Float64 name="der(x)" valueReference="5" description="derivative of x" causality="local" variability="continuous" initial="calculated" derivative="3" unit="N.m"/>
    <UInt64 name="n" valueReference="6" description="internal substeps per doStep" causality="structuralParameter" variability="fixed" start="1"/>
  </ModelVariables>
  <ModelStructure>
    <Output valueReference="3"/>
    <Output valueReference="4" dependencies="1" dependenciesKind="dependent"/>
    <ContinuousStateDerivative valueReference="5" dependencies="1" dependenciesKind="dependent"/>
    <InitialUnknown valueReference="4" dependencies="1 2" dependenciesKind="dependent dependent"/>
    <InitialUnknown valueReference="5" dependencies="1 2" dependenciesKind="dependent dependent"/>
  </ModelStructure>
</fmiModelDescription>
"""


def _edited(name: str, edits: list[tuple[str, str]] | None) -> str:
    text = CHK3C_XML
    for old, new in edits or []:
        n = len(re.findall(re.escape(old), text))
        if n != 1:
            raise ValueError(f"{name}: edit {old!r} matches {n} times in Chk3C's modelDescription.xml")
        text = text.replace(old, new)
    return text


def chk3c_fmu(name: str, breaks: str | None = None, edits: list[tuple[str, str]] | None = None,
              drop: tuple[str, ...] = (), add: dict[str, bytes] | None = None) -> Path:
    """Chk3C built with ``-DBREAK_<breaks>`` (None: the well-behaved one), its modelDescription.xml with ``edits``
    (old, new) applied, members starting with ``drop`` left out and ``add`` added, as ``<name>.fmu`` (gcc; raises
    FileNotFoundError without it). ``breaks="LIBM"`` links without -lm (libm not declared); ``breaks="MISSING_LIB"``
    declares a library (libchk3missing.so) that is packed nowhere."""
    from fmpy import platform_tuple
    src = HERE / "chk3c.c"
    xml = _edited(name, edits)
    key = _digest("chk3c", src.read_bytes(), COMMON.read_bytes(), xml, breaks, drop, sorted((add or {}).items()),
                  Path(__file__).read_bytes())

    def make(tmp: Path) -> Path:
        binary = tmp / "Chk3C.so"
        extra = [f"-DBREAK_{breaks}"] if breaks and breaks != "MISSING_LIB" else []
        if breaks == "MISSING_LIB":   # a library the binary declares (DT_NEEDED) and the FMU does not carry
            (tmp / "missing.c").write_text("int chk3_missing(void) { return 0; }\n")
            subprocess.run(["gcc", "-shared", "-fPIC", "-o", str(tmp / "libchk3missing.so"), str(tmp / "missing.c")],
                           check=True, capture_output=True)
            extra = ["-Wl,--no-as-needed", f"-L{tmp}", "-lchk3missing"]
        subprocess.run(_gcc(src, binary, breaks == "LIBM", extra), check=True, capture_output=True)
        out = tmp / f"{name}.fmu"
        with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("modelDescription.xml", xml)
            member = f"binaries/{platform_tuple}/Chk3C.so"
            if not member.startswith(drop) or not drop:
                z.write(binary, member)
            for arcname, data in (add or {}).items():
                z.writestr(arcname, data)
        return out

    return _cached(key, name, make)


def static_variant(name: str, edits: list[tuple[str, str]], drop: tuple[str, ...] = (),
                   add: dict[str, bytes] | None = None) -> Path:
    """The well-behaved Chk3C with its modelDescription.xml edited, for the static rules."""
    return chk3c_fmu(name, None, edits, drop, add)
