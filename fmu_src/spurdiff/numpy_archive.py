"""numpy carried as one archive, unpacked once per user and version (issue 44 item 1).

An FMU's runtimes carry numpy not as some 200 files a host's unzip writes on every extraction but
as one member each, ``resources/python/numpy.zip`` (Linux) and ``resources/python-win64/numpy.zip``
(Windows; :data:`HOMES`), stored (the host copies it, it does not inflate it), with its SHA-256 in
``numpy.zip.sha256`` beside it. Only the mesh levels and gear
sets other than the FMU's default import numpy (the car, the wheel and the rigid level never do),
so :func:`install` (called by the FMU's entry module) puts a finder on ``sys.meta_path`` that acts on
the first ``import numpy`` a model makes when the process has no numpy of its own: it unpacks the
archive into the user's cache, ``$XDG_CACHE_HOME/spurdiff/numpy-<sha256[:16]>`` (``~/.cache`` by
default; on Windows ``%LOCALAPPDATA%\\spurdiff\\``; where that cannot be made or is not private,
``$TMPDIR/spurdiff-<uid>`` as the loader's runtime folder), and imports numpy from there. Every FMU and
process of the same numpy shares that folder.

The folder is made private and atomically: the archive's digest checked first, unpacked into a
temporary folder (mode 0700) beside the target, every member's path checked to stay inside, then
renamed into place (a concurrent process that renamed first wins; its folder is used). A folder
found there is used only when it is a directory (not a link) owned by this user with mode 0700, every
folder above it is this user's or root's and writable by others only when sticky, and it
holds the marker naming this digest (each use touches it; before an unpack, other numpys' folders no
start used for 30 days are removed); anything else is refused with one line naming it. On Windows,
where a folder has an access list rather than an owner and mode, the check is that it is a
directory and not a reparse point (a link or junction); %LOCALAPPDATA% is the user's own.

The module imports only ``os`` and ``sys`` at load (it is imported at every FMU start, numpy or
not): hashing, unpacking and the import machinery's classes are imported when numpy is wanted.
"""
from __future__ import annotations

import os
import stat
import sys
from pathlib import Path

ARCHIVE = "numpy.zip"          # in resources/<home>/
HOMES = {"posix": "python", "nt": "python-win64"}   # the runtime's folder in resources/, by os.name
MARKER = ".spurdiff-numpy"     # in the unpacked folder: the archive's digest
REPARSE_POINT = 0x400          # FILE_ATTRIBUTE_REPARSE_POINT (Windows: a link or a junction)


def cache_root() -> Path:
    if os.name == "nt":
        base = os.environ.get("LOCALAPPDATA") or os.path.join(os.path.expanduser("~"), "AppData", "Local")
        return Path(base) / "spurdiff"
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "spurdiff"


def _private_dir(p: Path) -> str | None:
    """Why ``p`` is not a folder of ours with mode 0700 (Windows: a folder, not a reparse point), or None."""
    try:
        st = os.lstat(p)
    except OSError as e:
        return f"{p}: {e.strerror}"
    if not stat.S_ISDIR(st.st_mode) or getattr(st, "st_file_attributes", 0) & REPARSE_POINT:
        return f"{p} is not a folder (a link or a file)"
    if os.name == "nt":
        return None
    if st.st_uid != os.getuid():
        return f"{p} belongs to uid {st.st_uid}, not to this user ({os.getuid()})"
    if stat.S_IMODE(st.st_mode) & 0o077:
        return f"{p} has mode {stat.S_IMODE(st.st_mode):o}: others can write or read it (0700 expected)"
    return _open_above(p)


def _open_above(p: Path) -> str | None:
    """Why a folder above ``p`` would let another user move ``p`` away and put another in its place
    (not this user's or root's, or writable by others and not sticky; writable by this user's own
    group allowed), or None: as the FMU's loader checks the runtime's folder (runtime_unpack.h)."""
    for parent in Path(os.path.abspath(p)).parents:
        try:
            st = os.stat(parent)        # a link above is judged by its target
        except OSError:
            continue
        if st.st_uid not in (0, os.geteuid()):
            return f"the folder above it, {parent}, belongs to uid {st.st_uid}, not to this user or root"
        open_to = st.st_mode & 0o002 or (st.st_mode & 0o020 and st.st_gid != os.getegid())
        if open_to and not st.st_mode & stat.S_ISVTX:
            return (f"the folder above it, {parent}, is writable by others "
                    f"(mode {stat.S_IMODE(st.st_mode):o}, not sticky)")
    return None


def _usable_root() -> Path:
    """:func:`cache_root`, made if missing, when it is private (:func:`_private_dir`); else, as the
    loader does for the runtime's folder (runtime_unpack.h), ``$TMPDIR`` (or /tmp) ``/spurdiff-<uid>``
    when that is; else OSError naming both."""
    first = cache_root()
    try:
        first.mkdir(parents=True, exist_ok=True, mode=0o700)
        why = _private_dir(first)
    except OSError as e:
        why = f"{first} cannot be made: {e.strerror or e}"
    if why is None:
        return first
    if os.name == "nt":
        raise OSError(f"numpy cache refused: {why}")
    tmp = os.environ.get("TMPDIR", "")
    second = Path(tmp if os.path.isabs(tmp) else "/tmp") / f"spurdiff-{os.getuid()}"
    try:
        second.mkdir(exist_ok=True, mode=0o700)
        why2 = _private_dir(second)
    except OSError as e:
        why2 = f"{second} cannot be made: {e.strerror or e}"
    if why2 is None:
        return second
    raise OSError(f"numpy cache refused: {why}; {why2}")


def unpacked(archive: Path, digest: str, root: Path | None = None) -> Path:
    """The folder holding numpy unpacked from ``archive`` (SHA-256 ``digest``), made if needed.
    OSError (with one line naming the place) when it cannot be made or found safely."""
    import hashlib
    import tempfile
    import zipfile

    root = Path(root) if root else _usable_root()
    target = root / f"numpy-{digest[:16]}"
    if os.path.lexists(target):
        why = _private_dir(target)
        if why is None and (target / MARKER).is_file() and (target / MARKER).read_text().strip() == digest:
            try:
                os.utime(target / MARKER)    # used now: _sweep keeps it
            except OSError:
                pass
            return target
        raise OSError(f"numpy cache refused: {why or f'{target} does not hold this numpy ({MARKER} differs)'}")
    root.mkdir(parents=True, exist_ok=True, mode=0o700)
    why = _private_dir(root)
    if why is not None:
        raise OSError(f"numpy cache refused: {why}")
    h = hashlib.sha256()
    with open(archive, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    if h.hexdigest() != digest:
        raise OSError(f"{archive}: SHA-256 {h.hexdigest()} is not the {digest} the FMU was built with")
    _sweep(root)
    tmp = Path(tempfile.mkdtemp(prefix=".numpy-", dir=root))     # mode 0700
    try:
        with zipfile.ZipFile(archive) as z:
            for info in z.infolist():
                dest = (tmp / info.filename).resolve()
                if not str(dest).startswith(str(tmp.resolve()) + os.sep):
                    raise OSError(f"{archive}: member {info.filename!r} leaves its folder")
                z.extract(info, tmp)
                mode = (info.external_attr >> 16) & 0o755
                if mode and not info.is_dir():
                    os.chmod(dest, mode | 0o400)
        (tmp / MARKER).write_text(digest)
        try:
            os.rename(tmp, target)
        except OSError:
            if _private_dir(target) is not None:
                raise
    finally:
        if tmp.exists():
            import shutil
            shutil.rmtree(tmp, ignore_errors=True)
    why = _private_dir(target)
    if why is not None:
        raise OSError(f"numpy cache refused: {why}")
    return target


UNUSED_S = 30 * 24 * 3600   # another numpy's folder no start used for this long is removed at an unpack


def _sweep(root: Path) -> None:
    """Other numpys' folders in ``root`` (``numpy-<16 hex>``, this user's, not links) whose marker no
    start touched for :data:`UNUSED_S` removed (each use touches its marker: :func:`unpacked`)."""
    import shutil
    import time

    try:
        names = os.listdir(root)
    except OSError:
        return
    for name in names:
        if not (name.startswith("numpy-") and len(name) == 22 and all(c in "0123456789abcdef" for c in name[6:])):
            continue
        folder = root / name
        try:
            st = os.lstat(folder)
            used = os.lstat(folder / MARKER).st_mtime
        except OSError:
            continue
        ours = (not getattr(st, "st_file_attributes", 0) & REPARSE_POINT if os.name == "nt"
                else st.st_uid == os.getuid())
        if stat.S_ISDIR(st.st_mode) and ours and time.time() - used > UNUSED_S:
            shutil.rmtree(folder, ignore_errors=True)


class _Finder:
    """``import numpy`` with no numpy on the path: from the archive, unpacked into the cache (a
    meta path finder: ``find_spec`` is all the import system asks of one)."""

    def __init__(self, archive: Path, digest: str):
        self.archive, self.digest = archive, digest

    def find_spec(self, name, path=None, target=None):
        if name != "numpy":
            return None
        import importlib.machinery
        if importlib.machinery.PathFinder.find_spec(name, sys.path) is not None:
            return None           # the process's own numpy comes first
        folder = str(unpacked(self.archive, self.digest))
        if folder not in sys.path:
            sys.path.append(folder)
        return importlib.machinery.PathFinder.find_spec(name, [folder])


def install(resources: str | Path) -> bool:
    """The finder for the FMU whose resources folder is ``resources``, when this platform's runtime
    carries numpy as an archive; False when it does not (numpy is then where the process finds it)."""
    archive = Path(resources) / HOMES.get(os.name, HOMES["posix"]) / ARCHIVE
    sha = archive.with_name(ARCHIVE + ".sha256")
    if not archive.is_file() or not sha.is_file():
        return False
    if any(isinstance(f, _Finder) for f in sys.meta_path):
        return True
    sys.meta_path.append(_Finder(archive, sha.read_text().split()[0]))
    return True


__all__ = ["install", "unpacked", "cache_root", "ARCHIVE"]
