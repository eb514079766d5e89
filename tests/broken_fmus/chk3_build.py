"""Broken FMI 3.0 FMUs for the compliance kit's tests, made from the FMI 3.0 Reference FMUs
(../shared/hosts/reference-fmus-3, see its README):

* :func:`static_variant`: the Reference FMU with its modelDescription.xml edited (text replaced, each edit
  must match exactly once), for the ``static3`` rules;
* :func:`shim_variant`: the Reference FMU whose binary is wrapped by ``chk3_shim.c`` built with one
  ``BREAK_x`` (gcc), for the ``cs3`` / ``me3`` rules.

Both write into a folder the caller gives (the tests use a pytest tmp folder shared by the module).
"""
from __future__ import annotations

import re
import shutil
import subprocess
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REF3 = HERE.parents[2] / "shared" / "hosts" / "reference-fmus-3"


def reference(name: str) -> Path:
    return REF3 / f"{name}.fmu"


def _rewrite(src: Path, dest: Path, md: bytes | None = None, drop: tuple[str, ...] = (),
             add: dict[str, bytes] | None = None, replace: dict[str, bytes] | None = None) -> Path:
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dest, "w", zipfile.ZIP_DEFLATED) as zout:
        for info in zin.infolist():
            if info.filename.startswith(drop) and drop:
                continue
            data = zin.read(info.filename)
            if info.filename == "modelDescription.xml" and md is not None:
                data = md
            if replace and info.filename in replace:
                data = replace[info.filename]
            zout.writestr(info, data)
        for name, data in (add or {}).items():
            zout.writestr(name, data)
    return dest


def static_variant(name: str, base: str, edits: list[tuple[str, str]], out: Path, drop: tuple[str, ...] = (),
                   add: dict[str, bytes] | None = None) -> Path:
    """``base`` Reference FMU with ``edits`` (old, new) applied to modelDescription.xml, members starting with
    ``drop`` left out and ``add`` members added, written as ``out/name.fmu``."""
    with zipfile.ZipFile(reference(base)) as z:
        text = z.read("modelDescription.xml").decode("utf-8")
    for old, new in edits:
        n = len(re.findall(re.escape(old), text))
        if n != 1:
            raise ValueError(f"{name}: edit {old!r} matches {n} times in {base}'s modelDescription.xml")
        text = text.replace(old, new)
    return _rewrite(reference(base), out / f"{name}.fmu", text.encode("utf-8"), drop, add)


def shim_variant(name: str, base: str, breaks: str, out: Path, defines: dict[str, str] | None = None,
                 edits: list[tuple[str, str]] | None = None) -> Path:
    """``base`` Reference FMU whose binary is wrapped by chk3_shim.c built with ``-DBREAK_<breaks>``, its
    modelDescription.xml with ``edits`` (old, new) applied (each must match once)."""
    from fmpy import platform_tuple, read_model_description
    work = out / f"{name}.build"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    md = read_model_description(str(reference(base)), validate=False)
    mid = (md.coSimulation or md.modelExchange).modelIdentifier
    member = f"binaries/{platform_tuple}/{mid}.so"
    with zipfile.ZipFile(reference(base)) as z:
        so = z.read(member)
    soname = f"{mid}.so".encode()
    renamed = (mid[:-1] + ("_" if mid[-1] != "_" else "Z") + ".so")   # same length: the SONAME is patched in place
    if so.count(soname + b"\0") != 1:
        raise ValueError(f"{base}: SONAME {soname!r} not found once in {member}")
    (work / renamed).write_bytes(so.replace(soname + b"\0", renamed.encode() + b"\0"))
    flags = [f"-DBREAK_{breaks}", f'-DORIG_LIB="{renamed}"', f'-DTOKEN="{md.guid}"']
    flags += [f"-D{k}={v}" for k, v in (defines or {}).items()]
    shim = work / f"{mid}.so"
    subprocess.run(["gcc", "-shared", "-fPIC", "-O1", *flags, "-o", str(shim), str(HERE / "chk3_shim.c"),
                    f"-L{work}", "-Wl,--no-as-needed", f"-l:{renamed}", "-Wl,-rpath,$ORIGIN", "-ldl"], check=True, capture_output=True)
    md_text = None
    if edits:
        with zipfile.ZipFile(reference(base)) as z:
            text = z.read("modelDescription.xml").decode("utf-8")
        for old, new in edits:
            if len(re.findall(re.escape(old), text)) != 1:
                raise ValueError(f"{name}: edit {old!r} does not match once in {base}'s modelDescription.xml")
            text = text.replace(old, new)
        md_text = text.encode("utf-8")
    return _rewrite(reference(base), out / f"{name}.fmu", md_text, replace={member: shim.read_bytes()},
                    add={f"binaries/{platform_tuple}/{renamed}": (work / renamed).read_bytes()})
