"""Private places for caches and scratch files: nothing another local user plants is used.

Every cache or scratch folder the project keeps between runs goes through :func:`private_dir`:

* created with mode 0700 (parents too, when this call makes them);
* an existing folder is checked before use with ``lstat`` (no symbolic link followed): it must be a
  folder, owned by the user running the command, and writable by no one else; every folder above it
  must be owned by that user or root and writable by no one else unless sticky (``/tmp``; the
  user's own primary group may write there, as with a umask of 002), so nobody can move it away and
  put another in its place. A folder of ours that others can merely
  read is tightened to 0700;
* anything else is refused with :class:`PrivatePlaceError`, one line naming the place and why.

Files inside are trusted by their content only: :func:`verified_file` accepts a regular file (not a
link) of ours whose sha256 is the expected one, never a file whose size merely matches;
:func:`write_private` writes a whole file under a fresh name (``O_EXCL | O_NOFOLLOW``) and renames
it over the target.

:func:`cache_root` is the per-user cache (``$SPURDIFF_CACHE``, else the platform's user cache
folder, e.g. ``~/.cache/spurdiff``); where that cannot be made (no home) it is
``$TMPDIR/spurdiff-<uid>``, checked like any other place. Scratch folders that live for one call
are made with :func:`tempfile.mkdtemp` (a fresh, unpredictable name, mode 0700), which needs no
check.
"""
from __future__ import annotations

import hashlib
import os
import stat
import tempfile
import uuid
from pathlib import Path

_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)


class PrivatePlaceError(RuntimeError):
    """A cache or scratch place that is not private to this user; ``str()`` is one line naming it."""

    def __init__(self, place: Path | str, why: str):
        self.place = str(place)
        super().__init__(f"refusing the cache folder {place}: {why}; remove it or set SPURDIFF_CACHE "
                         f"to a folder of your own")


def _uid() -> int:
    return os.geteuid()


def _owner(st: os.stat_result) -> str:
    return f"owned by uid {st.st_uid}, not by you (uid {_uid()})"


def _check_ancestors(path: Path) -> None:
    """Every folder above ``path``: ours or root's, and writable by others only when sticky."""
    for parent in path.parents:
        try:
            st = os.stat(parent)   # an ancestor may be a link (/tmp -> /private/tmp): its target counts
        except FileNotFoundError:
            continue
        if st.st_uid not in (0, _uid()):
            raise PrivatePlaceError(path, f"the folder above it, {parent}, is {_owner(st)} or root")
        open_to = st.st_mode & 0o002 or (st.st_mode & 0o020 and st.st_gid != os.getegid())
        if open_to and not st.st_mode & stat.S_ISVTX:   # group-writable by the user's own group: allowed
            raise PrivatePlaceError(path, f"the folder above it, {parent}, is writable by others "
                                          f"(mode {stat.S_IMODE(st.st_mode):o}, not sticky)")


def check_private(path: Path | str) -> Path:
    """``path``, an existing folder, checked as described in the module docstring (PrivatePlaceError)."""
    path = Path(os.path.abspath(path))
    st = os.lstat(path)
    if stat.S_ISLNK(st.st_mode):
        raise PrivatePlaceError(path, f"it is a symbolic link (to {os.readlink(path)[:200]})")
    if not stat.S_ISDIR(st.st_mode):
        raise PrivatePlaceError(path, "it is not a folder")
    if st.st_uid != _uid():
        raise PrivatePlaceError(path, f"it is {_owner(st)}")
    mode = stat.S_IMODE(st.st_mode)
    if mode & 0o022:
        raise PrivatePlaceError(path, f"others may write into it (mode {mode:o}; it must be 700)")
    if mode & 0o077:
        os.chmod(path, 0o700)   # ours, readable by others: tightened
    _check_ancestors(path)
    return path


def private_dir(path: Path | str) -> Path:
    """``path`` as a private folder: made with mode 0700 when missing (and its missing parents), then
    checked (:func:`check_private`)."""
    path = Path(os.path.abspath(path))
    missing = []
    p = path
    while not os.path.lexists(p) and p != p.parent:
        missing.append(p)
        p = p.parent
    for d in reversed(missing):
        try:
            os.mkdir(d, 0o700)
        except FileExistsError:
            pass   # made meanwhile by another process: checked below like any other
        except OSError as e:
            raise PrivatePlaceError(d, f"it cannot be made ({e.strerror or e})") from None
    try:
        return check_private(path)
    except FileNotFoundError:
        raise PrivatePlaceError(path, "it vanished while being checked") from None


def cache_root() -> Path:
    """The per-user cache folder (private; see the module docstring)."""
    env = os.environ.get("SPURDIFF_CACHE")
    if env:
        return private_dir(Path(env).expanduser())
    try:
        from platformdirs import user_cache_dir
        home_cache = Path(user_cache_dir("spurdiff"))
    except ImportError:
        home_cache = None
    if home_cache is not None:
        try:
            return private_dir(home_cache)
        except PrivatePlaceError as e:
            if os.path.lexists(home_cache):
                raise   # there, but not ours: refused, never replaced by another place silently
            first = e
    else:
        first = None
    try:
        return private_dir(Path(tempfile.gettempdir()) / f"spurdiff-{_uid()}")
    except PrivatePlaceError:
        if first is not None:
            raise first from None
        raise


def cache_dir(name: str) -> Path:
    """``<cache_root>/<name>``, private."""
    return private_dir(cache_root() / name)


def sha256_of(path: Path | str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def verified_file(path: Path | str, sha256: str) -> bool:
    """True when ``path`` is a regular file (not a link) of ours whose sha256 is ``sha256``."""
    try:
        st = os.lstat(path)
    except OSError:
        return False
    if not stat.S_ISREG(st.st_mode) or st.st_uid != _uid() or stat.S_IMODE(st.st_mode) & 0o022:
        return False
    try:
        fd = os.open(path, os.O_RDONLY | _NOFOLLOW)
    except OSError:
        return False
    h = hashlib.sha256()
    with os.fdopen(fd, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest() == sha256


def write_private(path: Path | str, data: bytes, mode: int = 0o600) -> Path:
    """Write ``data`` to ``path`` (in a private folder) under a fresh name, then rename it over ``path``."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW, mode)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return path
