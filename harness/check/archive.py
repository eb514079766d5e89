"""Reading an FMU archive that may be hostile: limits, member names, safe extraction.

An FMU is a zip file (FMI 2.0, section 2.3). Before anything is parsed or unpacked the kit checks:

* at most :data:`MAX_MEMBERS` members, no two of the same name (which one an importer unpacks would be up
  to its zip library), and at most :data:`MAX_UNPACKED_BYTES` unpacked in total: refused before anything
  is unpacked when the members' declared sizes add up to more (a few milliseconds whatever the archive's
  size), and counted again while reading, so a zip whose headers understate the sizes is caught too;
* ``modelDescription.xml`` at the root, at most :data:`MAX_DESCRIPTION_BYTES`;
* member names relative, '/'-separated (the zip format's separator), without ``..`` parts, ``:``
  (a drive or stream on Windows) or ``\\``, and without control characters.

Any violation is an :class:`ArchiveError` with a one-line reason naming the limit; the FMU then
fails ``static.archive`` and nothing else is attempted on it (the other FMUs of a batch go on).
"""
from __future__ import annotations

import os
import shutil
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

MAX_MEMBERS = 10_000
MAX_UNPACKED_BYTES = 256 * 1024 ** 2      # 256 MiB, all members together (the largest FMU of ../shared: 8 MiB)
MAX_DESCRIPTION_BYTES = 64 * 1024 ** 2    # 64 MiB for modelDescription.xml
_CHUNK = 1024 ** 2


class ArchiveError(ValueError):
    """The FMU archive cannot be read safely (one-line reason)."""


def member_name_problem(name: str) -> str | None:
    """Why a zip member name is unsafe or illegal, or None."""
    if not name:
        return "an empty member name"
    if any(ord(c) < 32 or ord(c) == 127 for c in name):
        return f"member name {name!r} contains control characters"
    if "\\" in name:
        return f"member name {name!r} contains '\\' (zip paths use '/')"
    if ":" in name:
        return f"member name {name!r} contains ':' (a drive or stream name on Windows)"
    if name.startswith("/"):
        return f"member name {name!r} is absolute"
    if ".." in name.split("/"):
        return f"member name {name!r} leaves the archive's folder ('..')"
    return None


def open_checked(path: str | Path, max_members: int = MAX_MEMBERS) -> zipfile.ZipFile:
    """Open the zip and check its member names and count (raises ArchiveError)."""
    try:
        zf = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError, ValueError) as e:
        raise ArchiveError(f"not a readable zip archive: {e}") from None
    infos = zf.infolist()
    if len(infos) > max_members:
        zf.close()
        raise ArchiveError(f"{len(infos)} members, more than the limit of {max_members}")
    seen: set[str] = set()
    for info in infos:
        problem = member_name_problem(info.filename)
        if problem is None and info.filename in seen:
            problem = (f"two members named {info.filename!r}: which one an importer unpacks is up to its zip library "
                       f"(FMI 2.0 2.3: a zip file with a pre-defined structure)")
        seen.add(info.filename)
        if problem:
            zf.close()
            raise ArchiveError(problem)
    return zf


def _check_declared(zf: zipfile.ZipFile, max_bytes: int) -> None:
    """Refuse before unpacking when the members' declared sizes add up to more than ``max_bytes``."""
    total = sum(i.file_size for i in zf.infolist() if not i.is_dir())
    if total > max_bytes:
        raise ArchiveError(f"its members declare {total} bytes, more than {max_bytes} bytes unpacked (limit): "
                           f"refused before unpacking")


def _read_limited(zf: zipfile.ZipFile, info: zipfile.ZipInfo, limit: int, what: str, already: int = 0):
    """Yield the member's data in chunks, raising ArchiveError once ``already`` + the bytes read
    exceed ``limit``."""
    n = already
    try:
        with zf.open(info) as f:
            while True:
                chunk = f.read(_CHUNK)
                if not chunk:
                    return
                n += len(chunk)
                if n > limit:
                    raise ArchiveError(f"{what}: more than {limit} bytes unpacked (limit)")
                yield chunk
    except (zipfile.BadZipFile, OSError, EOFError, NotImplementedError, RuntimeError) as e:  # CRC, encryption, ...
        raise ArchiveError(f"{info.filename}: cannot be unpacked: {e}") from None


def scan(path: str | Path, max_bytes: int = MAX_UNPACKED_BYTES, max_members: int = MAX_MEMBERS) -> int:
    """Unpack every member in memory, chunk by chunk, without writing: the total unpacked size
    (raises ArchiveError past the limits, for a bad name or a corrupt member)."""
    total = 0
    with open_checked(path, max_members) as zf:
        _check_declared(zf, max_bytes)
        for info in zf.infolist():
            if info.is_dir():
                continue
            for chunk in _read_limited(zf, info, max_bytes, "the archive unpacked", total):
                total += len(chunk)
    return total


def read_model_description_bytes(path: str | Path, max_bytes: int = MAX_DESCRIPTION_BYTES,
                                 max_members: int = MAX_MEMBERS) -> tuple[list[str], bytes]:
    """(member names, modelDescription.xml bytes) of a checked archive (raises ArchiveError)."""
    with open_checked(path, max_members) as zf:
        names = zf.namelist()
        try:
            info = zf.getinfo("modelDescription.xml")
        except KeyError:
            raise ArchiveError("the archive has no modelDescription.xml at its root") from None
        if info.file_size > max_bytes:
            raise ArchiveError(f"modelDescription.xml: more than {max_bytes} bytes (it declares {info.file_size})")
        data = b"".join(_read_limited(zf, info, max_bytes, "modelDescription.xml"))
    return names, data


def extract(path: str | Path, dest: str | Path | None = None, max_bytes: int = MAX_UNPACKED_BYTES,
            max_members: int = MAX_MEMBERS) -> Path:
    """Unpack a checked archive into ``dest`` (default: a new temporary folder) within the limits.

    Raises ArchiveError (and removes what it unpacked) when a limit is exceeded."""
    own = dest is None
    dest = Path(tempfile.mkdtemp(prefix="spurdiff-fmu-")) if own else Path(dest)
    total = 0
    try:
        with open_checked(path, max_members) as zf:
            _check_declared(zf, max_bytes)
            root = dest.resolve()
            for info in zf.infolist():
                target = (dest / info.filename).resolve()
                if target != root and root not in target.parents:  # belt and braces after the name check
                    raise ArchiveError(f"member name {info.filename!r} leaves the archive's folder")
                if info.is_dir():
                    target.mkdir(parents=True, exist_ok=True)
                    continue
                target.parent.mkdir(parents=True, exist_ok=True)
                with open(target, "wb") as out:
                    for chunk in _read_limited(zf, info, max_bytes, "the archive unpacked", total):
                        out.write(chunk)
                        total += len(chunk)
                mode = (info.external_attr >> 16) & 0o777
                if mode:
                    os.chmod(target, mode | 0o600)
    except BaseException:
        if own:
            shutil.rmtree(dest, ignore_errors=True)
        raise
    return dest


def peek_fmi_version(path: str | Path) -> str | None:
    """The fmiVersion attribute of an archive's modelDescription.xml even when the archive fails the checks
    of :func:`open_checked` (so a broken FMI 3.0 FMU is reported under the FMI 3.0 rules); None when there
    is none to read. Reads at most the description's first 64 KiB."""
    import re
    try:
        with zipfile.ZipFile(path) as zf:
            with zf.open(zf.getinfo("modelDescription.xml")) as f:
                head = f.read(64 * 1024).decode("utf-8", "replace")
    except Exception:
        return None
    m = re.search(r"<fmiModelDescription\b[^>]*?\bfmiVersion\s*=\s*[\"']([^\"']*)[\"']", head)
    return m.group(1) if m else None


@dataclass
class FmuArchive:
    """What the static rules need from an FMU file: its member names and parsed XML."""

    path: Path
    members: list[str] = field(default_factory=list)
    root: ET.Element | None = None
    error: str = ""             # why the archive could not be read (static.archive)
    xml_error: str = ""         # why modelDescription.xml could not be parsed (static.fmi2)
    unpacked: int = 0           # bytes, all members unpacked

    def interface(self, kind: str) -> ET.Element | None:
        """The CoSimulation ("cs") or ModelExchange ("me") element, or None."""
        if self.root is None:
            return None
        return self.root.find({"cs": "CoSimulation", "me": "ModelExchange"}[kind])

    def model_identifier(self, kind: str) -> str | None:
        el = self.interface(kind)
        return el.get("modelIdentifier") if el is not None else None

    @property
    def model_name(self) -> str | None:
        return None if self.root is None else self.root.get("modelName")

    def variables(self) -> list[ET.Element]:
        return [] if self.root is None else self.root.findall("ModelVariables/ScalarVariable")


def read_archive(path: str | Path) -> FmuArchive:
    """Open the FMU zip within the kit's limits and parse ``modelDescription.xml``."""
    arc = FmuArchive(Path(path))
    try:
        arc.members, data = read_model_description_bytes(arc.path)
        arc.unpacked = scan(arc.path)
    except ArchiveError as e:
        arc.error = str(e)
        return arc
    try:
        arc.root = ET.fromstring(data)
    except ET.ParseError as e:
        arc.xml_error = f"modelDescription.xml is not well-formed XML: {e}"
    return arc
