"""Writing results safely: every file a command writes goes through here.

* **No symlink followed, no file shared.** An output path that is a symbolic link is refused; a
  whole file is written to a private temporary name in the same folder (created with
  ``O_CREAT | O_EXCL | O_NOFOLLOW``, so nothing planted there is opened) and renamed over the
  output at the end (:func:`atomic_file`, :func:`write_text`, :func:`write_bytes`,
  :func:`save_figure`). A file streamed as a run goes (:class:`StreamFile`) is created anew the
  same way under its own name, so a hard link planted there is replaced, never written through.
* **One writer per output place.** :class:`OutputLock` takes an exclusive ``fcntl.flock`` on a
  hidden file in the output folder and writes who holds it there; a second command writing the
  same folder is refused with that name. The holder removes the file when it is done; the kernel
  drops the lock when its holder exits, however it exits (a killed holder leaves only the file).
* **One line per failure.** A write that fails (full disk, read-only place, a symlink) raises
  :class:`OutputError` with the place and the errno; the command line turns it into one line and a
  non-zero exit. The temporary file is removed; what was completely written before is kept (a
  streamed file is cut back to its last complete row).
"""
from __future__ import annotations

import contextlib
import errno as _errno
import os
import socket
import stat
import time
import uuid
from pathlib import Path

from harness.common.messages import printable
from typing import IO, Iterator

LOCK_NAME = ".spurdiff.lock"


class OutputError(Exception):
    """A result could not be written at ``place`` (a path); ``errno`` is the OS error number (or
    None for a refusal without one). ``str()`` is the one line a command prints."""

    def __init__(self, place: Path | str, reason: str, errno: int | None = None, kept: str = "",
                 message: str | None = None):
        self.place, self.reason, self.errno, self.kept = str(place), reason, errno, kept
        code = f" [errno {errno} {_errno.errorcode.get(errno, '?')}]" if errno else ""
        super().__init__(message or f"cannot write {self.place}: {reason}{code}" + (f"; {kept}" if kept else ""))


def output_error(place: Path | str, e: OSError, kept: str = "") -> OutputError:
    """An :class:`OutputError` from an ``OSError`` met writing ``place``."""
    return OutputError(place, e.strerror or str(e), e.errno, kept)


_FLAGS = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)


def refuse_symlink(path: Path) -> None:
    """Refuse an output path that is a symbolic link (it would send the output elsewhere)."""
    if os.path.islink(path):
        raise OutputError(path, "it is a symbolic link (to " + os.readlink(path)[:200] + "); remove it or "
                          "write elsewhere", _errno.ELOOP)


def output_folder(folder: Path) -> Path:
    """``folder`` created if missing; an OutputError naming it otherwise."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise output_error(folder, e) from None
    return folder


def _private(path: Path) -> tuple[int, Path]:
    """A new file beside ``path`` under a private temporary name, created without following links."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")
    try:
        return os.open(tmp, _FLAGS, 0o666), tmp
    except OSError as e:
        raise output_error(path, e) from None


def probe(path: Path | str) -> Path:
    """Check before long work that ``path`` can be written: its folder made or there, the path not a
    symbolic link, a private file created there and removed; an OutputError otherwise."""
    path = Path(path)
    output_folder(path.parent)
    refuse_symlink(path)
    fd, tmp = _private(path)
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(tmp)
    return path


@contextlib.contextmanager
def atomic_file(path: Path | str, mode: str = "w", **open_kw) -> Iterator[IO]:
    """A file object to write ``path`` whole: written to a private temporary name beside it and
    renamed over ``path`` when the block ends without an error. On any error the temporary file is
    removed and ``path`` is left as it was; an OSError becomes an :class:`OutputError`."""
    path = Path(path)
    output_folder(path.parent)
    refuse_symlink(path)
    fd, tmp = _private(path)
    fh = None
    try:
        fh = os.fdopen(fd, mode, **open_kw)
        yield fh
        fh.close()   # flushes: a full disk shows here
        os.replace(tmp, path)   # rename replaces a link planted meanwhile, never follows it
    except BaseException as e:
        if fh is not None:
            with contextlib.suppress(OSError):
                fh.close()
        else:
            with contextlib.suppress(OSError):
                os.close(fd)
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(e, OSError):
            raise output_error(path, e) from None
        raise


@contextlib.contextmanager
def private_path(path: Path | str) -> Iterator[Path]:
    """For a writer that needs a file name (a library writing an archive): a private temporary
    file beside ``path``, created empty without following links, renamed over ``path`` when the
    block ends without an error; on any error removed (an OSError becomes an :class:`OutputError`)."""
    path = Path(path)
    output_folder(path.parent)
    refuse_symlink(path)
    fd, tmp = _private(path)
    os.close(fd)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException as e:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(e, OSError):
            raise output_error(path, e) from None
        raise


def write_text(path: Path | str, text: str, encoding: str = "utf-8") -> Path:
    with atomic_file(path, "w", encoding=encoding) as fh:
        fh.write(text)
    return Path(path)


def write_bytes(path: Path | str, data: bytes) -> Path:
    with atomic_file(path, "wb") as fh:
        fh.write(data)
    return Path(path)


def save_figure(fig, path: Path | str, **savefig_kw) -> Path:
    """``fig.savefig`` to ``path`` through :func:`atomic_file` (format from the suffix). The image is
    made in memory first: the PNG writer fails with an AttributeError, not the OSError, when the file
    object it writes meets a full disk."""
    import io

    path = Path(path)
    savefig_kw.setdefault("format", path.suffix.lstrip(".") or "png")
    buf = io.BytesIO()
    fig.savefig(buf, **savefig_kw)
    return write_bytes(path, buf.getvalue())


class StreamFile:
    """A file written as a run goes, row by row: created anew under its own name (a link planted
    there, symbolic or hard, is replaced, never written through), rows kept in memory and written
    with :meth:`flush`. A write that fails cuts the file back to its last complete row and raises an
    :class:`OutputError` saying how many rows are kept; :meth:`close` never raises a second error
    after the first."""

    def __init__(self, path: Path | str):
        self.path = Path(path)
        self.rows = 0              # lines completely written
        self.size = 0              # bytes completely written (a row boundary)
        self._buf: list[str] = []
        self.failed: OutputError | None = None
        output_folder(self.path.parent)
        refuse_symlink(self.path)
        try:
            if os.path.lexists(self.path):
                os.unlink(self.path)   # the link itself, never what it points to
            self.fd = os.open(self.path, _FLAGS, 0o666)
        except OSError as e:
            raise output_error(self.path, e) from None

    def write(self, line: str) -> None:
        """One or more complete lines (each with its line end)."""
        if self.failed is not None:
            raise self.failed
        self._buf.append(line)

    def flush(self) -> None:
        if self.failed is not None:
            raise self.failed
        if not self._buf:
            return
        data = "".join(self._buf).encode("utf-8")
        self._buf.clear()
        view, done = memoryview(data), 0
        try:
            while done < len(data):
                done += os.write(self.fd, view[done:])
        except OSError as e:
            cut = data.rfind(b"\n", 0, done) + 1   # the complete lines of a partial write stay
            self.size += cut
            self.rows += data.count(b"\n", 0, cut)
            with contextlib.suppress(OSError):
                os.ftruncate(self.fd, self.size)   # drop the torn line
                os.lseek(self.fd, self.size, os.SEEK_SET)
            self.failed = output_error(self.path, e, f"its first {self.rows} lines, written before, are kept")
            raise self.failed from None
        self.size += len(data)
        self.rows += data.count(b"\n")

    def close(self) -> None:
        """Flush what is left and close; raises the first write error if this flush meets one."""
        if self.fd is None:
            return
        try:
            if self.failed is None:
                self.flush()
        finally:
            with contextlib.suppress(OSError):
                os.close(self.fd)
            self.fd = None


class OutputLock:
    """An exclusive lock on an output folder (``fcntl.flock`` on :data:`LOCK_NAME` in it), naming
    its holder (``what``, pid, host, since when) in that file; a second holder is refused with an
    :class:`OutputError` (or ``error(message)`` when given) that names the first. The lock file is
    opened without following links and must be a plain file of its own."""

    def __init__(self, folder: Path | str, what: str, error: type[Exception] | None = None):
        self.folder = Path(folder)
        self.path = self.folder / LOCK_NAME
        self.what, self.error = what, error
        self.fd: int | None = None
        self._tries = 0

    def _refuse(self, reason: str, err: int | None, busy: bool = False) -> Exception:
        code = f" [errno {err} {_errno.errorcode.get(err, '?')}]" if err else ""
        text = f"results folder {self.folder} {reason}" if busy else f"results folder {self.folder}: {reason}{code}"
        return self.error(text) if self.error is not None else OutputError(self.folder, reason, err, message=text)

    def acquire(self) -> "OutputLock":
        import fcntl

        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0)
                         | getattr(os, "O_CLOEXEC", 0), 0o644)
        except OSError as e:
            raise self._refuse(f"cannot write there: {e.strerror}", e.errno) from None
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode) or st.st_nlink != 1:
            os.close(fd)
            raise self._refuse(f"{LOCK_NAME} is not a plain file of its own (a link?); remove it", _errno.EEXIST)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = os.pread(fd, 500, 0).decode("utf-8", "replace").strip() or "another process"
            os.close(fd)
            raise self._refuse(f"is in use by {printable(holder)}; wait for it to finish or give another --out",
                               None, busy=True) from None
        try:
            same = os.path.samestat(os.fstat(fd), os.lstat(self.path))
        except OSError:
            same = False
        if not same:   # its holder removed it on release after we opened it: take the new one
            os.close(fd)
            if self._tries > 3:
                raise self._refuse("the lock file keeps changing; try again", None)
            self._tries += 1
            return self.acquire()
        stamp = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime())
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{self.what} (pid {os.getpid()} on {socket.gethostname()}, since {stamp})\n".encode(), 0)
        except OSError:
            pass   # a full disk: the lock holds, only the holder's name is missing
        self.fd = fd
        return self

    def release(self) -> None:
        import fcntl

        if self.fd is not None:
            with contextlib.suppress(OSError):
                os.unlink(self.path)   # while held: a process that opened it sees it gone and retries
            fcntl.flock(self.fd, fcntl.LOCK_UN)
            os.close(self.fd)
            self.fd = None

    def __enter__(self) -> "OutputLock":
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()
