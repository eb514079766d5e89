"""A process's scratch folder in the temporary directory, and the removal of those of dead processes
(the FMU cache of harness/fmi/instance.py, the build's compiled binaries and staged package).

A folder made by :func:`make` (``<tmp>/<prefix><random>``, mode 0700 as :func:`tempfile.mkdtemp`
makes it) holds a lock file, ``.alive``, locked (``flock``) for as long as the process that made it,
or a child it forked, lives. The kernel drops the lock at any end of the process, SIGKILL included,
so a folder whose lock can be taken belongs to no running process: :func:`sweep` removes such
folders, holding their lock while it does. The test takes no pid, so it holds across pid namespaces
(a process in a container sharing ``/tmp`` sees the same lock) and needs no signal to a process.

The lock file is locked before it gets its name (made as ``.alive-new``, locked, renamed): a
sweeper never sees an unlocked ``.alive`` of a folder being made. A folder without ``.alive`` (being
made, or made by a version without it) is left alone, as are symbolic links, folders of other users
and lock files that are not regular files.

Where ``fcntl`` is missing (Windows), :func:`make` takes no lock and :func:`sweep` removes nothing:
a Windows process's extracted DLLs cannot be removed while it runs anyway, and its liveness would
need another test.
"""
from __future__ import annotations

import os
import shutil
import stat
import tempfile
from pathlib import Path

try:
    import fcntl
except ImportError:         # Windows
    fcntl = None

LOCK = ".alive"


class Scratch:
    """A scratch folder (``path``) and the lock that says its process lives (kept open)."""

    def __init__(self, path: Path, lock_fd: int | None):
        self.path, self._fd = path, lock_fd

    def remove(self) -> None:
        """Remove the folder (at the process's exit), then drop the lock."""
        shutil.rmtree(self.path, ignore_errors=True)
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None


def make(prefix: str, root: Path | str | None = None) -> Scratch:
    """A new scratch folder ``<root>/<prefix>*`` (root: the temporary directory), locked as alive."""
    path = Path(tempfile.mkdtemp(prefix=prefix, dir=None if root is None else str(root)))
    if fcntl is None:
        return Scratch(path, None)
    new = path / f"{LOCK}-new"
    fd = os.open(new, os.O_RDWR | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600)
    fcntl.flock(fd, fcntl.LOCK_EX)
    os.rename(new, path / LOCK)
    return Scratch(path, fd)


def process_folder(prefix: str, root: Path | str | None = None) -> Scratch:
    """A scratch folder for this process (:func:`make`), after removing the folders of the same
    prefix that processes killed before they removed theirs left behind (:func:`sweep`)."""
    made = make(prefix, root)
    sweep(prefix, made.path.parent, keep=made.path)
    return made


def sweep(prefix: str, root: Path | str | None = None, keep: Path | None = None) -> list[Path]:
    """Remove the scratch folders ``<root>/<prefix>*`` of processes that no longer run (this user's,
    real folders whose ``.alive`` nobody holds locked); the ones removed."""
    if fcntl is None:
        return []
    root = Path(tempfile.gettempdir() if root is None else root)
    removed = []
    try:
        entries = [e for e in os.scandir(root) if e.name.startswith(prefix)]
    except OSError:
        return []
    for entry in entries:
        path = Path(entry.path)
        if keep is not None and path == keep:
            continue
        try:
            st = os.lstat(path)
        except OSError:
            continue
        if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.geteuid():
            continue
        if _dead(path):
            removed.append(path)
    return removed


def _dead(path: Path) -> bool:
    """Remove ``path`` if its lock can be taken (its process is gone); whether it was."""
    try:
        fd = os.open(path / LOCK, os.O_RDWR | getattr(os, "O_NOFOLLOW", 0))
    except OSError:          # no lock file (being made, or an older layout), or a symbolic link
        return False
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return False
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:      # held: its process (or a child it forked) lives
            return False
        shutil.rmtree(path, ignore_errors=True)
        return True
    finally:
        os.close(fd)


__all__ = ["LOCK", "Scratch", "make", "process_folder", "sweep"]
