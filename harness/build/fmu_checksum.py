"""The files a build leaves beside an FMU: ``<name>.sha256``, the FMU's own SHA-256 in ``sha256sum``'s
format (``sha256sum -c SpurDifferential.sha256`` checks a download), and a hidden
``.<name>.source-digest``, the digest of the sources it was built from (what tells the build
whether the FMU is current; it is not the FMU's checksum and is not shipped)."""
from __future__ import annotations

import hashlib
import os
from pathlib import Path


def checksum_path(fmu: Path) -> Path:
    return Path(fmu).with_suffix(".sha256")


def stamp_path(fmu: Path) -> Path:
    fmu = Path(fmu)
    return fmu.with_name(f".{fmu.stem}.source-digest")


_MEMO: dict[tuple, str] = {}   # (path, inode, size, mtime) -> digest: a file read once per process


def file_sha256(path: Path) -> str:
    st = os.stat(path)
    key = (str(path), st.st_ino, st.st_size, st.st_mtime_ns)
    if key not in _MEMO:
        _MEMO[key] = _digest(path)
    return _MEMO[key]


def _digest(path: Path) -> str:
    with open(path, "rb") as f:
        return stream_sha256(f)


def stream_sha256(f) -> str:
    """The SHA-256 of the open binary file ``f`` from its start (left at its end): the bytes of that
    file, even if another build renames a new one over its path meanwhile."""
    f.seek(0)
    h = hashlib.sha256()
    for block in iter(lambda: f.read(1 << 20), b""):
        h.update(block)
    return h.hexdigest()


def _replace(path: Path, text: str) -> None:
    staged = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    staged.write_text(text)
    os.replace(staged, path)     # a reader sees the old file or the new one


def write(fmu: Path, source_digest: str) -> None:
    """After ``fmu`` is in place: its checksum file and its source stamp."""
    fmu = Path(fmu)
    _replace(checksum_path(fmu), f"{file_sha256(fmu)}  {fmu.name}\n")
    _replace(stamp_path(fmu), source_digest + "\n")


def is_current(fmu: Path, source_digest: str) -> bool:
    """``fmu`` exists, was built from sources of ``source_digest``, and its checksum file matches it
    (an FMU changed after its build is rebuilt)."""
    fmu, stamp, check = Path(fmu), stamp_path(fmu), checksum_path(fmu)
    if not (fmu.exists() and stamp.exists() and check.exists()):
        return False
    if stamp.read_text().strip() != source_digest:
        return False
    return check.read_text().split()[:1] == [file_sha256(fmu)]
