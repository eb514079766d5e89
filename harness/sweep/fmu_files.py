"""The FMU files a sweep runs from: snapshots named by their sha256, so a rebuild during a sweep
cannot change or truncate the file its runs load; a worker on another machine writes the bytes
the job carries to a snapshot of its own."""
from __future__ import annotations

import hashlib
import io
import os
import socket
import tempfile
import threading
import time
import zipfile
from pathlib import Path

from harness.scene.spec import SceneError
from harness.sweep.jobs import FmuRef

_FILES: dict[str, Path] = {}
_FILES_LOCK = threading.Lock()


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def snapshot(name: str, data: bytes, digest: str | None = None) -> Path:
    """The FMU ``data`` as a file named by its sha256 in a local cache directory (written once, atomically).

    A sweep runs from such snapshots, never from ``build/fmus``: a rebuild during a sweep cannot
    change or truncate the file its runs load."""
    digest = digest or hashlib.sha256(data).hexdigest()
    d = Path(tempfile.gettempdir()) / "spurdiff-sweep-fmus" / digest
    p = d / f"{name}.fmu"
    if not (p.is_file() and p.stat().st_size == len(data)):
        d.mkdir(parents=True, exist_ok=True)
        tmp = d / f".{name}.{os.getpid()}.{threading.get_ident()}.tmp"
        tmp.write_bytes(data)
        os.replace(tmp, p)
    return p


def local_fmu(ref: FmuRef) -> Path:
    """A path on this machine holding exactly the FMU ``ref`` names (checked once per process)."""
    with _FILES_LOCK:
        if ref.digest in _FILES:
            return _FILES[ref.digest]
        p = Path(ref.path)
        if not (p.is_file() and _sha256(p) == ref.digest):
            if ref.data is None:
                raise SceneError(f"{ref.name}: {ref.path} is missing or differs from the driver's FMU on "
                                 f"{socket.gethostname()}, and the job carries no FMU bytes")
            p = snapshot(ref.name, ref.data, ref.digest)
            if _sha256(p) != ref.digest:
                raise SceneError(f"{ref.name}: the copy written to {p} does not match the driver's FMU")
        _FILES[ref.digest] = p
        return p


def complete_fmu(data: bytes) -> bool:
    """A zip archive with a modelDescription.xml whose members all read back."""
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            return "modelDescription.xml" in z.namelist() and z.testzip() is None
    except zipfile.BadZipFile:
        return False


def fmu_ref(name: str, path: Path, wait: float = 20.0) -> FmuRef:
    """The FMU as it is now, copied to a snapshot named by its digest (see :func:`snapshot`).

    A file another process is still writing (a build is not atomic) is read again until complete."""
    t_end = time.monotonic() + wait
    while True:
        data = Path(path).read_bytes()
        if complete_fmu(data):
            break
        if time.monotonic() > t_end:
            raise SceneError(f"{path}: not a complete FMU (a zip with modelDescription.xml) after {wait:g} s; "
                             "is a build writing it? rebuild with `spurdiff build --force`")
        time.sleep(0.5)
    digest = hashlib.sha256(data).hexdigest()
    return FmuRef(name, digest, str(snapshot(name, data, digest)))
