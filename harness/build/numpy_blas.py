"""The numpy an FMU carries, without OpenBLAS and numpy.linalg's LAPACK (issue 44 item 1).

numpy's wheels link their core against OpenBLAS (``numpy.libs/libscipy_openblas64_-<hash>.so``, with
libgfortran and libquadmath on Linux; ``.dll`` on Windows): 8 of the 14 MB the two platforms' numpy
archives took in every SpurDifferential FMU, bytes a host's unzip wrote at each extraction. What the
FMU's models do with numpy needs neither: products of matrices of at most 10 x 10, and their small
systems solved by :func:`spurdiff.numerics.lu_solve` (tests/harness/test_numpy_trim.py: the models name no
``numpy.linalg``). So the archive of :func:`harness.build.fmu_contents.numpy_archive` takes numpy's
files through :func:`members`:

* OpenBLAS is replaced, under its own file name (where numpy's core looks for it), by
  ``fmu_src/native/numpy/numpy_blas.c``: the 22 BLAS routines the core calls, compiled here for the
  platform (gcc, or mingw-w64 for win64), about 20 kB;
* numpy.linalg's extension modules (``_umath_linalg``, ``lapack_lite``: LAPACK through OpenBLAS) are
  replaced by the stand-in :data:`LINALG_STANDIN`, which numpy.linalg imports as it imports them
  and which raises, naming the cause, when a function of numpy.linalg is called;
* a library of ``numpy.libs`` that no kept binary needs (the ELF files' DT_NEEDED, the PE files'
  import tables: OpenBLAS's libgfortran and libquadmath) is left out.

tests/fmus/test_numpy_blas.py compares the library's routines, through the FMU's numpy, with numpy's
OpenBLAS, and checks the stand-in's error.
"""
from __future__ import annotations

import hashlib
import shutil
import struct
import subprocess
from pathlib import Path

from harness.build import elf, runtime_win64
from harness.common.paths import fmu_sources

SOURCE = fmu_sources() / "native" / "numpy" / "numpy_blas.c"
BLAS_PREFIX = "libscipy_openblas"          # numpy's wheels' OpenBLAS, in numpy.libs/
LINALG_EXTENSIONS = ("_umath_linalg", "lapack_lite")    # numpy/linalg/<name>.<abi>.so|.pyd
FLAGS = ["-shared", "-O2", "-Wall", "-s"]
LINUX_FLAGS = ["-fPIC", "-Wl,--build-id=none"]
WIN64_FLAGS = ["-static-libgcc", "-Wl,--no-insert-timestamp"]     # the same bytes for the same source

LINALG_STANDIN = '''"""A stand-in for numpy.linalg's {name} in the numpy an FMU of spurdiff carries.

That numpy has no LAPACK (harness/build/numpy_blas.py): its models solve their small systems with
spurdiff.numerics.lu_solve. numpy.linalg imports this module as it imports the extension module;
a function of numpy.linalg that would call it raises instead.
"""


def __getattr__(name):
    if name.startswith("__"):
        raise AttributeError(name)
    raise RuntimeError(f"numpy.linalg is not carried in this FMU's numpy (no LAPACK): {{name}} of "
                       "numpy.linalg.{name} was called; spurdiff's models solve with spurdiff.numerics.lu_solve")
'''


def key() -> str:
    """What the archive's numpy changes with here: the library's source, the stand-in, the flags, the
    stripping."""
    h = hashlib.sha256(SOURCE.read_bytes())
    h.update(repr((LINALG_STANDIN, FLAGS, LINUX_FLAGS, WIN64_FLAGS, LINALG_EXTENSIONS, "strip-unneeded")).encode())
    return h.hexdigest()[:16]


class BlasBuildError(RuntimeError):
    """numpy's files cannot be made into the FMU's (harness.build.fmu_contents raises it as BuildError)."""


def blas_file(site: Path) -> Path:
    """numpy's OpenBLAS in ``site``'s numpy.libs (exactly one); BlasBuildError naming what is there."""
    libs = site / "numpy.libs"
    found = sorted(libs.glob(BLAS_PREFIX + "*")) if libs.is_dir() else []
    if len(found) != 1:
        raise BlasBuildError(f"numpy's OpenBLAS ({BLAS_PREFIX}*) not found once in {libs}: "
                     f"{sorted(p.name for p in libs.iterdir()) if libs.is_dir() else 'no such folder'}")
    return found[0]


def compile_blas(out: Path, windows: bool, cc: str) -> Path:
    """``numpy_blas.c`` compiled into ``out`` (its file name is its soname) for win64 (mingw-w64) or
    this machine with the C compiler ``cc``; BlasBuildError with the compiler's message when that fails."""
    if windows:
        cmd = [runtime_win64.compiler(), *FLAGS, *WIN64_FLAGS]
    else:
        cmd = [cc, *FLAGS, *LINUX_FLAGS, f"-Wl,-soname,{out.name}"]
    r = subprocess.run([*cmd, str(SOURCE), "-o", str(out)], capture_output=True, text=True)
    if r.returncode != 0:
        raise BlasBuildError(f"compiling numpy's BLAS ({SOURCE.name}) failed:\n{r.stderr.strip()}")
    return out


def pe_imports(path: Path) -> list[str]:
    """The DLL names in the import table of the PE file ``path`` (a Windows DLL or .pyd)."""
    data = Path(path).read_bytes()
    if data[:2] != b"MZ":
        raise BlasBuildError(f"{path} is not a PE file")
    pe, = struct.unpack_from("<I", data, 0x3C)
    if data[pe:pe + 4] != b"PE\0\0":
        raise BlasBuildError(f"{path} is not a PE file")
    nsect, optsize = struct.unpack_from("<H", data, pe + 6)[0], struct.unpack_from("<H", data, pe + 20)[0]
    opt = pe + 24
    magic, = struct.unpack_from("<H", data, opt)
    dirs = opt + (112 if magic == 0x20B else 96)        # PE32+ or PE32: the data directories
    rva, _size = struct.unpack_from("<II", data, dirs + 8)   # directory 1: the imports
    sections = [struct.unpack_from("<IIII", data, opt + optsize + 40 * i + 8) for i in range(nsect)]

    def offset(r: int) -> int:
        for vsize, vaddr, rawsize, rawptr in sections:
            if vaddr <= r < vaddr + max(vsize, rawsize):
                return rawptr + r - vaddr
        raise BlasBuildError(f"{path}: RVA {r:#x} is in no section")

    names = []
    if not rva:
        return names
    at = offset(rva)
    while True:
        desc = struct.unpack_from("<IIIII", data, at)
        if not any(desc):
            return names
        name_at = offset(desc[3])
        names.append(data[name_at:data.index(b"\0", name_at)].decode("ascii", "replace"))
        at += 20


def needed(path: Path) -> list[str]:
    """The libraries the binary ``path`` names (ELF: DT_NEEDED; PE: its imports); [] for others."""
    if elf.is_elf(path):
        return elf.dynamic(path).needed
    if path.suffix.lower() in (".dll", ".pyd"):
        return pe_imports(path)
    return []


def members(site: Path, scratch: Path, cc: str) -> list[tuple[str, Path]]:
    """numpy's files of ``site`` (numpy/ and numpy.libs/) as they go into the FMU's archive, (name in the
    archive, file) sorted by name: OpenBLAS replaced by :data:`SOURCE` compiled into ``scratch`` (with ``cc``
    for Linux, mingw-w64 for win64),
    numpy.linalg's extension modules by :data:`LINALG_STANDIN` (``.py``; the caller byte-compiles it),
    and the libraries of numpy.libs no kept binary needs left out."""
    blas = blas_file(site)
    windows = blas.suffix.lower() == ".dll"
    files = {}
    for top in ("numpy", "numpy.libs"):
        for p in sorted((site / top).rglob("*")):
            if p.is_file():
                files[p.relative_to(site).as_posix()] = p
    linalg = [r for r in files if r.startswith("numpy/linalg/") and r.count("/") == 2
              and r.split("/")[2].split(".")[0] in LINALG_EXTENSIONS and r.endswith((".so", ".pyd"))]
    if not linalg:
        raise BlasBuildError(f"numpy.linalg's extension modules {LINALG_EXTENSIONS} not found in {site / 'numpy' / 'linalg'}")
    for r in linalg:
        del files[r]
        stem = r.split("/")[2].split(".")[0]
        standin = scratch / f"{stem}.py"
        standin.write_text(LINALG_STANDIN.format(name=stem))
        files[f"numpy/linalg/{stem}.py"] = standin
    scratch_libs = scratch / "libs"
    scratch_libs.mkdir(exist_ok=True)
    files[f"numpy.libs/{blas.name}"] = compile_blas(scratch_libs / blas.name, windows, cc)
    # numpy.libs: what the kept binaries need, transitively
    libs = {r.split("/", 1)[1]: r for r in files if r.startswith("numpy.libs/")}
    lower = {n.lower(): n for n in libs}
    want, todo = set(), [p for r, p in files.items() if not r.startswith("numpy.libs/")]
    while todo:
        for n in needed(todo.pop()):
            n = lower.get(n.lower()) if windows else (n if n in libs else None)
            if n is not None and n not in want:
                want.add(n)
                todo.append(files[libs[n]])
    for n, r in libs.items():
        if n not in want:
            del files[r]
    if not windows:
        _stripped(files, scratch / "stripped")
    return sorted(files.items())


def _stripped(files: dict[str, Path], folder: Path) -> None:
    """The wheel's ELF libraries in ``files`` (name in the archive -> file) replaced by copies in
    ``folder`` without their symbol tables (:func:`harness.build.elf.strip_symbols`; numpy's core loses
    0.5 MB, 90 kB of the archive); left as they are without strip."""
    if shutil.which("strip") is None:
        return
    for rel, p in files.items():
        if (rel.endswith(".so") or ".so." in rel.rsplit("/", 1)[-1]) and elf.is_elf(p):
            out = folder / rel
            out.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(p, out)
            elf.strip_symbols(out)
            files[rel] = out
