"""Finding and loading a compiled kernel of this package (the mesh levels' ``mesh_kernel*.c``, the
rigid level's ``rigid_kernel.c``, the half-shaft step's ``shaft_kernel.c``, the car's and the
wheel's ``vehicle_kernel.c``; all in
``fmu_src/native/kernels``), written once for all.

Where a kernel is found (first hit that loads and passes the kernel's own check):

1. beside its binding module, under its shipped name (``harness/build.py`` puts it there inside each
   FMU that runs it; the FMU's package is an archive, its kernels files in the same folders beside it:
   :func:`shipped_folder`);
2. in the folders of the binding's ``SEARCH_PATH`` (``harness.build`` adds the FMU folder, where it
   compiles the kernels for direct runs and the tests), ``$SPURDIFF_KERNEL_DIR``,
   ``$SPURDIFF_FMU_DIR`` and a checkout's ``build/fmus``, as ``<stem>-<digest>.so``: the digest of
   the C sources beside this package, so a stale library is never used (with no sources at hand,
   under the shipped name). On Windows the shipped name ends in ``.dll``.

:class:`Binding` is what the binding modules share beyond the search: the library's check (ABI
version and sizes, then the functions' types), the cached ``load`` and its ``reset``, and the
switch ``solver.kernel`` (python; compiled, refused without a library; auto, the Python reference
without one, the reason logged once).
"""
from __future__ import annotations

import ctypes as C
import os
import sys
from pathlib import Path
from typing import Callable, NamedTuple, Sequence

from spurdiff.errors import ParameterError

_PACKAGE = Path(__file__).resolve().parent
_SOURCES = (_PACKAGE.parent / "native" / "kernels",                      # checkout: fmu_src/native/kernels
            _PACKAGE.parent / "spurdiff_fmus" / "native" / "kernels")    # installed wheel


def source_digest(native: Path, stem: str) -> str:
    """Digest of a kernel's sources (``<stem>*.c`` and ``.h`` in the folder ``native``)."""
    import hashlib      # (a checkout's sources only: an FMU carries none, and starts without hashlib)
    h = hashlib.sha256()
    for p in sorted(native.glob(f"{stem}*.[ch]")):
        h.update(p.name.encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def shipped_folder(module) -> Path:
    """The folder a kernel ships in beside its binding ``module``: the module's own; for a module an
    FMU imports from its package archive (``resources/spurdiff.zip``: a library cannot be loaded from
    inside an archive), the same folders beside the archive (``resources/spurdiff/...``)."""
    folder = os.path.dirname(module.__file__)
    archive = getattr(getattr(module, "__loader__", None), "archive", None)     # zipimport's
    if archive and folder.startswith(archive + os.sep):
        folder = os.path.join(os.path.dirname(archive), folder[len(archive) + 1:])
    return Path(folder).resolve()


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


class _Logger:
    """The logger ``name`` (:func:`logging.getLogger`), imported at its first use: the logging
    module is needed only when auto falls back to the Python reference, so an FMU starts without it.
    Every attribute is the logger's own."""

    __slots__ = ("name",)

    def __init__(self, name: str):
        self.name = name

    def __getattr__(self, attr: str):
        import logging
        return getattr(logging.getLogger(self.name), attr)


KERNELS = ("auto", "compiled", "python")     # the switch solver.kernel: the compiled kernel when it loads | it or refuse | the reference


class Check(NamedTuple):
    """Functions of a library that return numbers (its ABI version, its sizes; ``restype``), the
    numbers a binding needs, and why not when they differ (``why``, formatted with ``got`` and
    ``want``, the two tuples)."""
    names: tuple[str, ...]
    want: tuple[int, ...]
    why: str = "ABI and sizes {got} (this module needs {want})"
    restype: type = C.c_int64


class Binding:
    """What the binding module ``module`` (by name) of the kernel ``stem`` shares with the others:
    its library's search, check and cache, and the switch ``solver.kernel`` (auto | compiled | python).

    The module takes its ``MISSING``, ``log``, ``source_digest``, ``_check``, ``_candidates``,
    ``load`` and ``reset`` from :meth:`exports` and keeps its settings and state as its own names,
    read at each call (``harness.build`` and the tests change them): ``LIB_NAME`` (the shipped
    name, beside the module), ``SEARCH_PATH``, ``MISSING``, ``_LIB`` (the cached search),
    ``_REPORTED`` (the reasons logged), ``_candidates``, ``_check``, ``load``.

    ``logger``: the name of the logger that says why auto runs the Python reference (``fallback``,
    then the reason); ``checks``: the :class:`Check` the library passes, in order; ``functions``:
    name -> (argtypes, restype) of the functions the binding calls, declared once the checks pass,
    or only the names: functions whose arguments are always the kernel's ctypes arrays and which
    return an int64 (no argtypes: ctypes passes the arrays as pointers as they are, where declared
    argtypes would convert them at each call, 0.6 us more a call); ``label`` and ``sources``
    (default ``<stem>.c``) name the kernel in :attr:`missing`; ``param`` and ``values``: the
    switch's name and values (``values`` None: checked elsewhere)."""

    def __init__(self, module: str, stem: str, label: str, logger: str, checks: Sequence[Check],
                 functions: dict | Sequence[str], fallback: str, sources: str = "", param: str = "solver.kernel",
                 values: tuple[str, ...] | None = KERNELS):
        self.module, self.stem, self.checks = module, stem, tuple(checks)
        self.functions = (dict(functions) if isinstance(functions, dict)
                          else dict.fromkeys(functions, (None, C.c_int64)))
        self.log = _Logger(logger)     # (logging imported when a fallback is logged)
        self.fallback, self.param, self.values = fallback, param, values
        self.missing = (f"no compiled {label} kernel found (build it with `spurdiff build`, which compiles "
                        f"fmu_src/native/kernels/{sources or stem + '.c'})")

    def exports(self) -> tuple:
        """What the binding module names ``MISSING``, ``log``, ``source_digest``, ``_check``,
        ``_candidates``, ``load`` and ``reset``, in that order."""
        return self.missing, self.log, self.source_digest, self.check, self.candidates, self.load, self.reset

    def _binding(self):
        return sys.modules[self.module]

    def source_digest(self, native: Path) -> str:
        """Digest of the kernel's sources (``<stem>*.c`` and ``.h`` in the folder ``native``)."""
        return source_digest(native, self.stem)

    def check(self, lib: C.CDLL) -> str | None:
        """None if ``lib`` is the kernel the module speaks to (its function types then declared), else why not."""
        for c in self.checks:
            fns = [getattr(lib, n) for n in c.names]
            for f in fns:
                f.restype = c.restype
            got = tuple(f() for f in fns)
            if got != c.want:
                return c.why.format(got=got, want=c.want)
        for name, (argtypes, restype) in self.functions.items():
            f = getattr(lib, name)
            f.argtypes, f.restype = argtypes, restype
        return None

    def candidates(self) -> list[Path]:
        """The files to try, in order (:func:`candidates`)."""
        m = self._binding()
        return candidates(self.stem, shipped_folder(m) / m.LIB_NAME, m.SEARCH_PATH)

    def load(self) -> tuple[C.CDLL | None, str]:
        """(library, where it came from) or (None, why not). Cached per process."""
        return load_cached(self._binding())

    def reset(self) -> None:
        """Forget the cached search result (after the search path changed)."""
        self._binding()._LIB = None

    def library(self, want: str) -> tuple[C.CDLL | None, str]:
        """(the library, "compiled") for the switch value ``want``, or (None, a note saying why the
        Python reference runs: python, or auto without a loadable library, logged once per reason);
        ParameterError for a value not in ``values`` or for compiled without a library."""
        note = self.switch(want)
        return (None, note) if note is not None else self.compiled(want)

    def switch(self, want: str) -> str | None:
        """The note when ``want`` is python, else None; ParameterError for a value not in ``values``."""
        if self.values is not None and want not in self.values:
            raise ParameterError(self.param, want, " | ".join(self.values))
        return "python (kernel = python)" if want == "python" else None

    def compiled(self, want: str) -> tuple[C.CDLL | None, str]:
        """:meth:`library` for auto or compiled."""
        m = self._binding()
        lib, where = m.load()
        if lib is not None:
            return lib, "compiled"
        out = self.refuse(want, where)
        if where not in m._REPORTED:
            m._REPORTED.add(where)
            self.log.warning(self.fallback + ": %s", where)
        return out

    def refuse(self, want: str, why: str) -> tuple[None, str]:
        """No compiled kernel for the reason ``why``: ParameterError when ``want`` is compiled, else
        (None, the note)."""
        if want == "compiled":
            raise ParameterError(self.param, want, f"auto | python here: {why}")
        return None, f"python ({why})"
