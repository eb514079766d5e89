"""Finding and loading a compiled kernel of this package (the mesh levels' ``mesh_kernel*.c``, the
rigid level's ``rigid_kernel.c``, the car's and the wheel's ``vehicle_kernel.c``; all in
``fmu_src/native/kernels``), written once for all.

Where a kernel is found (first hit that loads and passes the kernel's own check):

1. beside its binding module, under its shipped name (``harness/build.py`` puts it there inside each
   FMU that runs it);
2. in the folders of the binding's ``SEARCH_PATH`` (``harness.build`` adds the FMU folder, where it
   compiles the kernels for direct runs and the tests), ``$SPURDIFF_KERNEL_DIR``,
   ``$SPURDIFF_FMU_DIR`` and a checkout's ``build/fmus``, as ``<stem>-<digest>.so``: the digest of
   the C sources beside this package, so a stale library is never used (with no sources at hand,
   under the shipped name). On Windows the shipped name ends in ``.dll``.
"""
from __future__ import annotations

import ctypes as C
import hashlib
import os
from pathlib import Path
from typing import Callable, Sequence

_PACKAGE = Path(__file__).resolve().parent
_SOURCES = (_PACKAGE.parent / "native" / "kernels",                      # checkout: fmu_src/native/kernels
            _PACKAGE.parent / "spurdiff_fmus" / "native" / "kernels")    # installed wheel


def source_digest(native: Path, stem: str) -> str:
    """Digest of a kernel's sources (``<stem>*.c`` and ``.h`` in the folder ``native``)."""
    h = hashlib.sha256()
    for p in sorted(native.glob(f"{stem}*.[ch]")):
        h.update(p.name.encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def candidates(stem: str, shipped: Path, search_path: Sequence[Path]) -> list[Path]:
    """The files to try, in order, for the kernel ``stem`` shipped as ``shipped`` (on Windows the
    ``.dll`` of the same name: a win64 FMU carries both)."""
    if os.name == "nt":
        shipped = shipped.with_suffix(".dll")
    out = [shipped]
    src = next((p for p in _SOURCES if (p / f"{stem}.c").is_file()), None)
    dirs = list(search_path) + [Path(os.environ[v]) for v in ("SPURDIFF_KERNEL_DIR", "SPURDIFF_FMU_DIR")
                                if os.environ.get(v)]
    if src is not None and src.parent.parent.name == "fmu_src":      # a checkout (fmu_src/native/kernels): its build/fmus
        dirs.append(src.parent.parent.parent / "build" / "fmus")
    if src is not None:
        out += [Path(d) / f"{stem}-{source_digest(src, stem)}.so" for d in dirs]
    else:
        out += [Path(d) / shipped.name for d in dirs]
    return out


def load_first(paths: Sequence[Path], check: Callable[[C.CDLL], str | None],
               missing: str) -> tuple[C.CDLL | None, str]:
    """(library, its path) for the first of ``paths`` that loads and that ``check`` accepts
    (``check`` returns None, or why not, and declares the functions' types), else (None, the
    reasons, or ``missing`` when no file was there)."""
    reasons = []
    for path in paths:
        if not path.is_file():
            continue
        try:
            lib = C.CDLL(str(path))
            why = check(lib)
        except (OSError, AttributeError) as e:
            reasons.append(f"{path}: {e}")
            continue
        if why:
            reasons.append(f"{path}: {why}")
            continue
        return lib, str(path)
    return None, "; ".join(reasons) if reasons else missing


def load_cached(binding) -> tuple[C.CDLL | None, str]:
    """A binding module's ``load()``: its cached ``_LIB`` when a library was found, else the first of
    its ``_candidates()`` that its ``_check`` accepts (``MISSING``: the reason when none is there)."""
    if binding._LIB is not None and binding._LIB[0] is not None:
        return binding._LIB
    binding._LIB = load_first(binding._candidates(), binding._check, binding.MISSING)
    return binding._LIB
