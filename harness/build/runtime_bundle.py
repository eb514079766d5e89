"""The Python runtime every FMU carries: ``resources/python/``, made once per interpreter and module
list, cached, and copied into each FMU. It holds the standard library's part the FMUs import and
nothing else: the FMUs' package imports no third-party module (tests/physics/test_numpy_free.py,
and :func:`harness.build.fmu_package.stage_package` refuses a copy that would).

Layout (``X`` the build interpreter's minor version)::

    python/lib/libpython3.X.so.1.0          the build interpreter's shared libpython, stripped
    python/lib/<soname>                     non-glibc libraries the extension modules need (preloaded)
    python/lib/python3X.zip                 the pure-Python standard library modules the FMUs import
    python/lib/python3.X/lib-dynload/       the extension modules among them

Which standard-library modules: the union of (a) the modules loaded at interpreter start-up
(``python -I -S``), (b) a trace: :mod:`harness.build.runtime_probe`, in a subprocess of the build
interpreter with ``sys.path`` the standard library only, loads each FMU's bundled
package under a private alias as the bridge does and runs its model through the adapter (setup,
initialization, steps, get/serialize/deserialize/set FMU state, terminate), and (c)
``modulefinder``'s static closure of the bundled package and the vendored pythonfmu modules
(imports inside functions included; not those of the code a module runs only as a script, its
``__main__`` block: :mod:`harness.build.stdlib_closure`), plus :data:`ALWAYS`. Whole top-level packages are
taken (all of ``encodings``, ``importlib``, ``json``...), without their ``test``/``tests``
folders. Never taken (:data:`DENY`): ``test``, ``idlelib``, ``tkinter``, ``turtledemo``,
``ensurepip``, ``lib2to3``, ``pydoc_data``, ``distutils``, ``venv``, ``site-packages``,
``config-3.X-*`` and ``_sysconfigdata_*`` (the latter two hold the build machine's paths), the
OpenSSL modules ``_hashlib``/``_ssl`` (libcrypto is 4.5 MB; ``hashlib`` then uses its built-in
``_sha256``... modules, which are taken), and the modules that link terminal and database
libraries a model has no use for (``readline``, ``curses``, ``dbm``, ``sqlite3``: the static
closure reaches them through pdb and pydoc, which import them inside ``try``).

Shared libraries: every ELF file of the runtime is read (:mod:`harness.build.elf`) for DT_NEEDED; a
library that is neither inside the runtime nor a system library of :data:`SYSTEM_LIBRARIES` is
copied into ``python/lib/`` under its soname and listed as a ``preload=`` of the runtime
description (the loader dlopens them RTLD_GLOBAL, dependencies first, before starting Python, so
the extension modules find the soname already loaded). System libraries, expected on every target:
glibc's own (libc, libm, libpthread, libdl, librt, libutil, libresolv, the dynamic loader) and
libgcc_s / libstdc++ (which the manylinux policy counts as the system's too). libpython and the
extension modules lose their RUNPATH (the build machine's folder, searched first by the loader: a
library planted there would be loaded) with patchelf when it is installed, and their debug info
and symbol tables with ``strip --strip-unneeded`` when it is (the dynamic symbols stay: a host's
debugger still names the exported functions).

Every ``.py`` is byte-compiled to a sourceless pyc in its place (``module.pyc``, ``UNCHECKED_HASH``)
and the source removed; the pure-Python standard library then goes into one uncompressed zip on
the module path (as CPython's own ``python3X.zip``; zipimport is frozen into libpython). The
interpreter never writes into the FMU's folder, and a host extracting the FMU writes about 430
fewer files and 8 MB less (tracebacks through the standard library name file and line,
without the source text; the FMU's own package keeps its sources). The finished runtime is cached in the FMU folder (:func:`harness.common.paths.fmu_cache_dir`)
as ``runtime-<key>/`` (the key: the interpreter's real path and version, the module list and this
build code), built in a temporary folder and renamed under a file lock
(parallel test workers build at once), with ``runtime.zip``, the same files compressed once under
``resources/python/``, which each FMU build starts its archive from. The module list is cached too
(``runtime-modules-<key>.json``, keyed by the bundled package's files), so a build with an
unchanged package runs no trace. Making
a new runtime removes all but the newest other one (:data:`KEEP_RUNTIMES`).

:func:`run_in_runtime` runs an extracted FMU's package on its runtime's module path only (the
build interpreter's executable standing in for the loader), which the tests use; the loader's
preloading of the libraries is not exercised there.

(Over 400 lines: one runtime from the module list to the cached, checked folder: probing the
modules the FMUs import, copying them with the libraries they need, and the cfg.)
"""
from __future__ import annotations

import compileall
import fcntl
import hashlib
import json
import os
import py_compile
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

from harness.build import elf
from harness.build.fmu_package import ENTRY_MODULE, PACKAGE_NAME, stage_package, write_entry
from harness.build.stdlib_closure import ScriptlessFinder
from harness.common.paths import fmu_cache_dir
from harness.common.private_dir import PrivatePlaceError, private_dir
from harness.common import progress

VERSION = f"{sys.version_info.major}.{sys.version_info.minor}"
STDLIB = Path(sysconfig.get_paths()["stdlib"]).resolve()
DYNLOAD = Path(sysconfig.get_config_var("DESTSHARED") or STDLIB / "lib-dynload").resolve()
HOME = "python"                                   # the runtime's folder in resources/ (PyConfig.home)
LIB = f"{HOME}/lib"
PYLIB = f"{LIB}/python{VERSION}"
STDLIB_ZIP = f"{LIB}/python{VERSION.replace('.', '')}.zip"   # the pure-Python standard library, sourceless
SEARCH_PATH = (STDLIB_ZIP, f"{PYLIB}/lib-dynload")   # the cfg's path= lines
DENY = frozenset({"test", "idlelib", "tkinter", "turtledemo", "ensurepip", "lib2to3", "pydoc_data",
                  "distutils", "venv", "site-packages", "turtle", "_tkinter", "_hashlib", "_ssl",
                  "readline", "curses", "_curses", "_curses_panel", "_dbm", "_gdbm", "dbm", "_sqlite3", "sqlite3"})
DENY_PREFIXES = ("config-", "_sysconfigdata")
TEST_FOLDERS = frozenset({"test", "tests", "idle_test"})
# stdlib modules taken whatever the trace says: site (a host may start the runtime with it) and
# what the bridge itself imports
ALWAYS = ("encodings", "site", "_sitebuiltins", "os", "traceback", "hashlib", "importlib")
SYSTEM_LIBRARIES = frozenset({"libc.so.6", "libm.so.6", "libpthread.so.0", "libdl.so.2", "librt.so.1",
                              "libutil.so.1", "libresolv.so.2", "ld-linux-x86-64.so.2",
                              "ld-linux-aarch64.so.1", "libgcc_s.so.1", "libstdc++.so.6"})
PROBE = Path(__file__).resolve().parent / "runtime_probe.py"
PROBE_STEPS = 20
CODE_FILES = (Path(__file__).resolve(), Path(elf.__file__).resolve(), PROBE,
              Path(__file__).resolve().parent / "fmu_package.py", Path(__file__).resolve().parent / "stdlib_closure.py")


class RuntimeBundleError(RuntimeError):
    """The runtime cannot be made (a message naming the cause)."""


@dataclass(frozen=True)
class Runtime:
    folder: Path            # runtime-<key>/ holding python/ and runtime.zip
    preload: tuple[str, ...]   # resources-relative paths of the libraries to preload, in order
    libpython: str          # resources-relative path of libpython

    @property
    def archive(self) -> Path:
        return self.folder / "runtime.zip"


def libpython() -> Path | None:
    """The build interpreter's shared libpython (INSTSONAME in LIBDIR), or None."""
    libdir = sysconfig.get_config_var("LIBDIR")
    name = sysconfig.get_config_var("INSTSONAME") or sysconfig.get_config_var("LDLIBRARY")
    if not libdir or not name or ".so" not in name:
        return None
    p = Path(libdir) / name
    return p if p.exists() else None


def _digest(*parts) -> str:
    h = hashlib.sha256()
    for part in parts:
        h.update(part if isinstance(part, bytes) else str(part).encode())
        h.update(b"\0")
    return h.hexdigest()


def interpreter_id() -> tuple:
    return (os.path.realpath(sys.executable), sys.version, str(STDLIB),
            *(p.read_bytes() for p in CODE_FILES))


# ---------------------------------------------------------------------------------- the module list
def _run_probe(spec: dict, timeout: float = 300) -> dict:
    """Run :mod:`harness.build.runtime_probe` in ``python -I -S`` with ``spec``; its output, or an error
    naming what failed (the last line of the model's traceback)."""
    with tempfile.TemporaryDirectory(prefix="spurdiff_probe_") as tmp:
        spec_file, out_file = Path(tmp) / "spec.json", Path(tmp) / "out.json"
        spec_file.write_text(json.dumps(spec))
        r = subprocess.run([sys.executable, "-I", "-S", str(PROBE), str(spec_file), str(out_file), *spec["path"]],
                           capture_output=True, text=True, timeout=timeout, cwd=tmp, env={"PATH": os.defpath})
        if r.returncode != 0 or not out_file.is_file():
            last = (r.stderr or r.stdout).strip().splitlines()[-1:] or [f"exit {r.returncode}"]
            raise RuntimeBundleError(f"running the FMUs' models the way the FMU's runtime does failed: {last[0]}")
        return json.loads(out_file.read_text())


def probe_spec(packages: dict[str, tuple[Path, dict]], path: list[str]) -> dict:
    """The probe's input for ``packages`` (class -> (staged package folder, default experiment)) on the
    module path ``path``."""
    return {"path": path,
            "fmus": [{"package": str(pkg), "class": name, "module": ENTRY_MODULE, "experiment": experiment,
                      "steps": PROBE_STEPS} for name, (pkg, experiment) in packages.items()]}


def run_in_runtime(resources: Path, classes: list[str], experiment: dict, steps: int = PROBE_STEPS) -> dict:
    """Load the FMU's package from the extracted ``resources`` folder with ``sys.path`` only the
    runtime's module path (as the cfg gives it) and run the model of each of ``classes`` (the
    build interpreter's executable stands in for the loader: it started up on its own standard
    library; everything imported after start-up comes from ``resources``): the probe's output."""
    resources = Path(resources)
    return _run_probe({"path": [str(resources / p) for p in SEARCH_PATH],
                       "fmus": [{"package": str(resources / PACKAGE_NAME), "class": c, "module": ENTRY_MODULE,
                                 "experiment": experiment, "steps": steps} for c in classes]})


def startup_modules() -> dict[str, str | None]:
    """Modules loaded by ``python -I -S`` starting up: name -> file (None for built-in ones)."""
    code = "import sys, json; print(json.dumps({n: getattr(m, '__file__', None) for n, m in sys.modules.items()}))"
    r = subprocess.run([sys.executable, "-I", "-S", "-c", code], capture_output=True, text=True, check=True)
    modules = json.loads(r.stdout)
    modules.pop("json", None)    # the probe's own
    return modules


def static_modules(roots: list[Path], names: list[str]) -> dict[str, str | None]:
    """modulefinder's closure of the modules ``names`` found in ``roots`` and the standard library, the
    modules' script parts left out (:mod:`harness.build.stdlib_closure`)."""
    finder = ScriptlessFinder(path=[*map(str, roots), str(STDLIB), str(DYNLOAD)], excludes=sorted(DENY))
    for name in names:
        try:
            finder.import_hook(name)
        except ImportError:
            pass
    return {name: m.__file__ for name, m in finder.modules.items()}


def stdlib_items(modules: dict[str, str | None]) -> list[str]:
    """The standard-library entries (top-level file or package names under the stdlib folder,
    ``lib-dynload/<file>`` for extension modules) that hold ``modules`` (name -> file), deny list
    applied; sorted."""
    items = set()
    for name, file in modules.items():
        top = name.partition(".")[0]
        if top in DENY or top.startswith(DENY_PREFIXES) or top in sys.builtin_module_names:
            continue
        if file and file not in ("frozen", "built-in"):
            path = Path(file).resolve()
            if path.is_relative_to(DYNLOAD):
                items.add(f"lib-dynload/{path.name}")
                continue
            if not path.is_relative_to(STDLIB) or path.relative_to(STDLIB).parts[0] == "site-packages":
                continue
            first = path.relative_to(STDLIB).parts[0]
            if first in DENY or first.startswith(DENY_PREFIXES):
                continue
            items.add(first)
        elif (STDLIB / top).is_dir():
            items.add(top)
        elif (STDLIB / f"{top}.py").is_file():
            items.add(f"{top}.py")
    return sorted(items)


def module_list(packages: dict[str, tuple[Path, dict]]) -> list[str]:
    """The stdlib entries the FMUs need: start-up + trace of ``packages`` (class -> (staged package
    folder, default experiment)) + static closure of the package and pythonfmu + :data:`ALWAYS`."""
    traced = _run_probe(probe_spec(packages, [str(STDLIB), str(DYNLOAD)]))
    for name, file in traced["modules"].items():   # what the models load must come from the runtime
        if file and file not in ("frozen", "built-in") and not _carried(Path(file).resolve(), packages):
            raise RuntimeBundleError(f"the FMU's model imported {name} from {file}, which the FMU's runtime "
                                     "does not carry (the standard library only)")
    root = next(iter(packages.values()))[0].parent
    ours = [".".join(p.relative_to(root).with_suffix("").parts).removesuffix(".__init__")
            for p in sorted((root / PACKAGE_NAME).rglob("*.py"))]
    static = static_modules([root], ours)
    found = {**startup_modules(), **traced["modules"], **static}
    for name in ALWAYS:
        found.setdefault(name, None)
    return stdlib_items(found)


def _carried(path: Path, packages: dict) -> bool:
    if path.is_relative_to(STDLIB) and not path.is_relative_to(STDLIB / "site-packages"):
        return True
    if path.is_relative_to(DYNLOAD):
        return True
    return any(path.is_relative_to(Path(pkg).resolve()) for pkg, _ in packages.values())


# ---------------------------------------------------------------------------------- assembling
def _ignore_tests(folder: str, names: list[str]) -> list[str]:
    return [n for n in names if n in TEST_FOLDERS or n == "__pycache__" or n.endswith(".pyc")]


def _tidy_elf(path: Path, notes: list[str]) -> None:
    """Strip the debug info and the symbol table (not the dynamic symbols) and drop the RUNPATH of a
    file copied from the build interpreter."""
    if not elf.strip_symbols(path) and "no strip" not in notes:
        notes.append("no strip")
    info = elf.dynamic(path)
    if info.rpath or info.runpath:
        from harness.build.elf import find_patchelf
        patchelf = find_patchelf()
        if patchelf:
            subprocess.run([patchelf, "--remove-rpath", str(path)], check=True, capture_output=True)
        elif "no patchelf" not in notes:
            notes.append("no patchelf")


def _bundle_libraries(root: Path, sources: dict[Path, Path]) -> list[str]:
    """Copy the non-system libraries the runtime's ELF files need into python/lib/ under their
    sonames; their resources-relative paths, each after the bundled libraries it needs.
    ``sources``: copy -> the file it was copied from (whose RPATH the loader would have used)."""
    elfs = [p for p in sorted(root.rglob("*")) if p.is_file() and elf.is_elf(p)]
    inside = {p.name for p in elfs} | {s for s in (elf.dynamic(p).soname for p in elfs) if s}
    bundled: dict[str, Path] = {}        # soname -> its copy in python/lib
    needs: dict[str, list[str]] = {}     # bundled soname -> the bundled sonames it needs
    todo = [(p, sources.get(p, p), None) for p in elfs]
    while todo:
        copy, original, own = todo.pop()
        for soname in elf.dynamic(original).needed:
            if soname in SYSTEM_LIBRARIES or (soname in inside and soname not in bundled):
                continue
            if soname not in bundled:
                found = elf.locate(soname, original)
                if found is None:
                    raise RuntimeBundleError(f"{original.name} needs {soname}, which is not found on this "
                                             "machine")
                bundled[soname] = root / LIB / soname
                shutil.copyfile(found, bundled[soname])
                needs[soname] = []
                todo.append((bundled[soname], found, soname))
            if own is not None:
                needs[own].append(soname)
    order: list[str] = []

    def visit(s: str, path: tuple = ()) -> None:
        if s in order or s in path:
            return
        for d in needs[s]:
            visit(d, path + (s,))
        order.append(s)

    for s in sorted(bundled):
        visit(s)
    return [f"{LIB}/{s}" for s in order]


def _compile_sourceless(folder: Path) -> None:
    """Byte-compile every ``.py`` under ``folder`` to a pyc in its place (``module.pyc`` beside it,
    the layout the import system loads without a source) and remove the source."""
    ok = compileall.compile_dir(str(folder), quiet=2, workers=1, stripdir=str(folder.parent), prependdir=None,
                                legacy=True, invalidation_mode=py_compile.PycInvalidationMode.UNCHECKED_HASH)
    if not ok:
        raise RuntimeBundleError("byte-compiling the runtime's standard library failed")
    for py in folder.rglob("*.py"):
        py.unlink()


def _zip_pure_stdlib(pylib: Path, archive: Path) -> None:
    """Move the pure-Python standard library (everything in ``pylib`` but ``lib-dynload`` and the
    licence) into ``archive``, stored uncompressed (zipimport then needs no zlib; the FMU's own archive
    compresses it): one file to extract instead of about 430."""
    keep = {"lib-dynload", "LICENSE.txt"}
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_STORED) as z:
        for entry in sorted(pylib.iterdir()):
            if entry.name in keep:
                continue
            files = sorted(entry.rglob("*")) if entry.is_dir() else [entry]
            for f in files:
                if f.is_file():
                    z.write(f, f.relative_to(pylib).as_posix())
            shutil.rmtree(entry) if entry.is_dir() else entry.unlink()


def assemble(dest: Path, items: list[str]) -> dict:
    """Make the runtime in ``dest`` (``dest/python/...`` and ``dest/runtime.zip``); its manifest."""
    notes: list[str] = []
    lib = dest / LIB
    pylib = dest / PYLIB
    (pylib / "lib-dynload").mkdir(parents=True)
    sources: dict[Path, Path] = {}
    src_lib = libpython()
    if src_lib is None:
        raise RuntimeBundleError(f"this Python ({sys.executable}) has no shared libpython: an FMU cannot carry it "
                            "(use a Python built with --enable-shared)")
    target = lib / src_lib.name
    shutil.copyfile(src_lib, target)
    _tidy_elf(target, notes)
    for item in items:
        src = STDLIB / item if not item.startswith("lib-dynload/") else DYNLOAD / item.partition("/")[2]
        if src.is_dir():
            shutil.copytree(src, pylib / item, ignore=_ignore_tests)
        else:
            shutil.copyfile(src, pylib / item)
            if item.startswith("lib-dynload/"):
                sources[pylib / item] = src
                _tidy_elf(pylib / item, notes)
    if (STDLIB / "LICENSE.txt").is_file():
        shutil.copyfile(STDLIB / "LICENSE.txt", pylib / "LICENSE.txt")
    preload = _bundle_libraries(dest, sources)
    sources_size = sum(p.stat().st_size for p in dest.rglob("*.py"))
    _compile_sourceless(dest / HOME)
    pyc_size = sum(p.stat().st_size for p in dest.rglob("*.pyc"))
    _zip_pure_stdlib(pylib, dest / STDLIB_ZIP)
    with zipfile.ZipFile(dest / "runtime.zip", "w", zipfile.ZIP_DEFLATED) as z:
        for p in sorted((dest / HOME).rglob("*")):
            if p.is_file():
                z.write(p, f"resources/{p.relative_to(dest).as_posix()}")
    manifest = {"version": VERSION, "libpython": f"{LIB}/{src_lib.name}", "preload": preload, "items": items,
                "notes": notes, "py_bytes": sources_size, "pyc_bytes": pyc_size,
                "unpacked_bytes": sum(p.stat().st_size for p in (dest / HOME).rglob("*") if p.is_file()),
                "zipped_bytes": (dest / "runtime.zip").stat().st_size}
    (dest / "manifest.json").write_text(json.dumps(manifest, indent=1))
    return manifest


# ---------------------------------------------------------------------------------- the cache
def stage_fmu_packages(fmus: dict[str, tuple[str, dict]], tmp: Path) -> dict[str, tuple[Path, dict]]:
    """One staged package per FMU (name -> (interface module, default experiment)) in ``tmp``."""
    from harness.common.paths import physics_package

    out = {}
    for name, (module, experiment) in fmus.items():
        pkg = stage_package(physics_package(), tmp / name / "resources")
        write_entry(pkg, name, module)
        out[name] = (pkg, experiment)
    return out


_RUNTIMES: dict[str, Runtime] = {}


def _cached_json(path: Path, make):
    """The JSON value cached in ``path``, made (and written atomically) when missing."""
    if path.is_file():
        return json.loads(path.read_text())
    value = make()
    staged = path.with_name(f".{path.name}.{os.getpid()}")
    staged.write_text(json.dumps(value))
    os.replace(staged, path)
    return value


def package_digest(fmus: dict[str, tuple[str, dict]]) -> str:
    """What the module list depends on besides the interpreter: the package's sources, the
    vendored pythonfmu modules and the FMUs' declarations."""
    import pythonfmu

    from harness.build.fmu_package import PYTHONFMU_MODULES
    from harness.common.paths import physics_package

    h = hashlib.sha256()
    root = physics_package()
    for p in sorted(root.rglob("*")):
        if p.is_file() and "__pycache__" not in p.parts and p.suffix not in (".so", ".pyc"):
            h.update(str(p.relative_to(root)).encode() + b"\0" + p.read_bytes() + b"\0")
    vendored = Path(pythonfmu.__file__).resolve().parent
    for m in PYTHONFMU_MODULES:
        h.update((vendored / f"{m}.py").read_bytes())
    h.update(repr(sorted((n, m, sorted(e.items())) for n, (m, e) in fmus.items())).encode())
    return h.hexdigest()


def ensure_runtime(fmus: dict[str, tuple[str, dict]], cache: Path | None = None, quiet: bool = True) -> Runtime:
    """The cached runtime for the FMUs ``fmus`` (name -> (interface module, default experiment)),
    made when missing (the module list first: trace and static closure, each cached)."""
    cache = Path(cache) if cache else fmu_cache_dir()
    try:
        private_dir(cache)   # 0700, ours, nobody else may write (harness.common.private_dir)
    except PrivatePlaceError as e:
        raise RuntimeBundleError(str(e)) from None
    interp = _digest(*interpreter_id())
    key1 = _digest(interp, package_digest(fmus))
    if key1 in _RUNTIMES:
        return _RUNTIMES[key1]

    def listing():
        with tempfile.TemporaryDirectory(prefix="spurdiff_runtime_") as tmp:
            return module_list(stage_fmu_packages(fmus, Path(tmp)))

    def traced():
        with progress.stage("listing the modules the FMUs' Python runtime needs (traced once)", expected=30):
            return listing()

    items = _cached_json(cache / f"runtime-modules-{key1[:16]}.json", traced)
    key2 = _digest(interp, *items)
    folder = cache / f"runtime-{key2[:16]}"
    with open(cache / ".runtime.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (folder / "manifest.json").is_file():
            _prune(cache, keep=folder)
            work = Path(tempfile.mkdtemp(prefix=f".runtime-{key2[:16]}-", dir=cache))
            try:
                with progress.stage("bundling the FMUs' Python runtime (made once, then cached)", expected=60):
                    manifest = assemble(work, items)
                work.chmod(0o755)
                if folder.exists():
                    shutil.rmtree(folder)
                os.replace(work, folder)
            finally:
                shutil.rmtree(work, ignore_errors=True)
            if not quiet:
                print(f"FMU runtime made: {folder} ({manifest['unpacked_bytes'] / 1e6:.1f} MB, "
                      f"{manifest['zipped_bytes'] / 1e6:.1f} MB zipped"
                      + (f"; {', '.join(manifest['notes'])}" if manifest["notes"] else "") + ")")
    manifest = json.loads((folder / "manifest.json").read_text())
    runtime = Runtime(folder, tuple(manifest["preload"]), manifest["libpython"])
    _RUNTIMES[key1] = runtime
    return runtime


KEEP_RUNTIMES = 2     # runtime folders kept in the cache (the newest); older ones are removed


def _prune(cache: Path, keep: Path) -> None:
    """Remove all but the :data:`KEEP_RUNTIMES` newest runtime folders and their module lists
    (under the runtime lock: a build that holds an older one has finished copying from it)."""
    folders = sorted((p for p in cache.glob("runtime-*") if p.is_dir() and p != keep),
                     key=lambda p: p.stat().st_mtime, reverse=True)
    for old in folders[KEEP_RUNTIMES - 1:]:
        shutil.rmtree(old, ignore_errors=True)
    for stale in cache.glob(".runtime-*"):   # a build that died while assembling (it held this lock)
        if stale.is_dir():
            shutil.rmtree(stale, ignore_errors=True)
    lists = sorted(cache.glob("runtime-modules-*.json"), key=lambda p: p.stat().st_mtime, reverse=True)
    for old in lists[KEEP_RUNTIMES:]:
        old.unlink(missing_ok=True)
    for old in cache.glob("runtime-numpy-modules-*.json"):   # earlier builds' numpy closures: none is made now
        old.unlink(missing_ok=True)


def cfg_text(runtime: Runtime, name: str, guid: str) -> str:
    """``resources/python_runtime.cfg``, format 2 (see ``fmu_src/native/fmi/runtime_cfg.h``): every path
    relative to the resources folder."""
    lines = [
        "# The Python runtime this FMU carries (resources/python) and the class it runs;",
        "# every path is relative to the resources folder. Written by harness/build/fmu.py.",
        "format=2",
        f"version={VERSION}",
        f"libpython={runtime.libpython}",
        f"home={HOME}",
        *(f"path={p}" for p in SEARCH_PATH),
        *(f"preload={p}" for p in runtime.preload),
        f"package={PACKAGE_NAME}",
        f"module={ENTRY_MODULE}",
        f"class={name}",
        f"guid={guid}",
    ]
    return "\n".join(lines) + "\n"
