"""The FMU files a sweep runs from: snapshots named by their sha256, so a rebuild during a sweep
cannot change or truncate the file its runs load; a worker on another machine writes the bytes
the job carries to a snapshot of its own."""
from __future__ import annotations

import hashlib
import io
import os
import socket
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
    """The FMU ``data`` as a file named by its sha256 in the user's private cache (written once,
    atomically; see :mod:`harness.common.private_dir`: the folder 0700, owner and mode checked; a file
    found there is used only when its own sha256 is the digest, whatever its size).

    A sweep runs from such snapshots, never from ``build/fmus``: a rebuild during a sweep cannot
    change or truncate the file its runs load."""
    from harness.common.private_dir import PrivatePlaceError, cache_dir, verified_file, write_private
    digest = digest or hashlib.sha256(data).hexdigest()
    if hashlib.sha256(data).hexdigest() != digest:
        raise SceneError(f"{name}: the FMU bytes do not match their digest {digest[:16]}")
    try:
        d = cache_dir(f"sweep-fmus/{digest}")
    except PrivatePlaceError as e:
        raise SceneError(str(e)) from None
    p = d / f"{name}.fmu"
    if not verified_file(p, digest):
        write_private(p, data)
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
