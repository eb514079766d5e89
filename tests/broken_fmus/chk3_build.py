"""Building the compliance kit's FMI 3.0 test FMUs, once: Chk3C (chk3c.c, co-simulation and model exchange),
compiled with gcc against the FMI 3.0 headers fmpy ships, cached under build/test-fmus/ by a hash of its
sources (:func:`chk_build._cached`), the FMI 3.0 counterpart of ChkC:

* :func:`chk3c_fmu`: Chk3C plainly or with one ``BREAK_*`` macro of chk3c.c (the call-sequence rules), its
  modelDescription.xml optionally edited;
* :func:`static_variant`: Chk3C with its modelDescription.xml edited (each edit must match exactly once),
  members left out or added, for the ``static3`` rules.

Nothing here comes from the Reference FMUs: the model, its description and its breakages are ours.
"""
from __future__ import annotations

import re
import subprocess
import zipfile
from pathlib import Path

from chk_build import _cached, _digest

HERE = Path(__file__).resolve().parent
TOKEN = "{c0ffee00-5b0d-4c1e-9a1e-000000000003}"
XML = f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="3.0" modelName="Chk3C" instantiationToken="{TOKEN}"
  description="x' = k u, y = k u (compliance-kit test FMU in C, FMI 3.0)" generationTool="tests/broken_fmus/chk3_build.py"
  variableNamingConvention="structured">
  <ModelExchange modelIdentifier="Chk3C" canGetAndSetFMUState="true" canSerializeFMUState="true"
    providesDirectionalDerivatives="true"/>
  <CoSimulation modelIdentifier="Chk3C" canHandleVariableCommunicationStepSize="true" canGetAndSetFMUState="true"
    canSerializeFMUState="true" providesDirectionalDerivatives="true" maxOutputDerivativeOrder="1"
    mightReturnEarlyFromDoStep="true" hasEventMode="true" providesIntermediateUpdate="true"/>
  <UnitDefinitions>
    <Unit name="1"/>
    <Unit name="s"><BaseUnit s="1"/></Unit>
    <Unit name="N.m"><BaseUnit kg="1" m="2" s="-2"/></Unit>
    <Unit name="N.m.s"><BaseUnit kg="1" m="2" s="-1"/></Unit>
  </UnitDefinitions>
  <LogCategories>
    <Category name="logEvents" description="events"/>
    <Category name="logStatusError" description="errors"/>
  </LogCategories>
  <DefaultExperiment startTime="0" stopTime="1" stepSize="0.01"/>
  <ModelVariables>
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
    text = XML
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
    import fmpy
    from fmpy import platform_tuple
    src = HERE / "chk3c.c"
    xml = _edited(name, edits)
    key = _digest("chk3c", src.read_bytes(), xml, breaks, drop, sorted((add or {}).items()), Path(__file__).read_bytes())

    def make(tmp: Path) -> Path:
        binary = tmp / "Chk3C.so"
        include = Path(fmpy.__file__).parent / "c-code"
        cmd = ["gcc", "-shared", "-fPIC", "-O1", "-std=c99", "-Wall", f"-I{include}", "-o", str(binary), str(src)]
        if breaks == "LIBM":
            cmd[1:1] = ["-fno-builtin", "-Wl,--no-as-needed"]
        else:
            cmd.append("-lm")
        if breaks == "MISSING_LIB":   # a library the binary declares (DT_NEEDED) and the FMU does not carry
            (tmp / "missing.c").write_text("int chk3_missing(void) { return 0; }\n")
            subprocess.run(["gcc", "-shared", "-fPIC", "-o", str(tmp / "libchk3missing.so"), str(tmp / "missing.c")],
                           check=True, capture_output=True)
            cmd += ["-Wl,--no-as-needed", f"-L{tmp}", "-lchk3missing"]
        elif breaks:
            cmd.insert(1, f"-DBREAK_{breaks}")
        subprocess.run(cmd, check=True, capture_output=True)
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
