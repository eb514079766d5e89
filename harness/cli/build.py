"""``spurdiff build`` (= ``python build_fmu.py``): build the project's FMUs and say where."""
from __future__ import annotations

import argparse
import os
import re
from pathlib import Path

from harness.cli import fail


_STAGED = re.compile(r"^\.[^.]+\.(\d+)\.(fmu|so|sha256)$")   # .<name>.<pid>.<ext>, renamed into place when done


def _remove_staged(dest: Path) -> None:
    """Half-written files in ``dest`` after a write error: staged by this process, or by one that
    has exited (a build in a fresh process); a live process's own are left to it."""
    try:
        for p in dest.iterdir():
            m = _STAGED.match(p.name)
            if m is None:
                continue
            pid = int(m.group(1))
            if pid != os.getpid():
                try:
                    os.kill(pid, 0)
                    continue   # still running: its file
                except ProcessLookupError:
                    pass
                except PermissionError:
                    continue
            p.unlink(missing_ok=True)
    except OSError:
        pass


def main(argv: list[str] | None = None) -> int:
    from harness.build.fmu import FMUS, BuildError
    from harness.build.fmu3 import build_versions
    from harness.common.outputs import output_error
    from harness.common.paths import fmu_cache_dir

    ap = argparse.ArgumentParser(prog="spurdiff build", description="Build the project's FMUs")
    ap.add_argument("names", nargs="*", help=f"FMUs to build (default: all of {', '.join(FMUS)})")
    ap.add_argument("--out", "--dest", dest="dest", type=Path, default=None,
                    help="output directory (default: build/fmus in a checkout, else the per-user cache)")
    ap.add_argument("--force", action="store_true", help="rebuild even if up to date")
    ap.add_argument("--fmi-version", dest="fmi_version", type=int, choices=(2, 3), action="append", default=None,
                    help="build the FMI 2.0 (NAME.fmu) or 3.0 (NAME-fmi3.fmu) FMUs only (repeatable; default: both)")
    ap.add_argument("--platforms", default=None, metavar="LIST",
                    help="platforms to carry, comma-separated: linux64,win64 (default: both; linux64 always)")
    args = ap.parse_args(argv)
    try:
        from harness.build.fmu import PLATFORMS_ENV, platform_sizes, platforms
        if args.platforms is not None:
            os.environ[PLATFORMS_ENV] = args.platforms
        platforms()                      # a bad list: one line before anything is built
        versions = tuple(sorted(set(args.fmi_version))) if args.fmi_version else (2, 3)
        paths = build_versions(args.names or None, args.dest, args.force, versions=versions)
        for p in paths:
            sizes = platform_sizes(p)
            print(f"{p.name}: {p.stat().st_size / 1e6:.1f} MB: " + ", ".join(
                f"{k} {b / 1e6:.1f} MB ({n} files)" for k, (b, n) in sizes.items() if n))
        print(f"FMUs in {paths[0].parent}" if paths else "nothing to build")
    except BuildError as e:
        _remove_staged(Path(args.dest) if args.dest else fmu_cache_dir())
        return fail("spurdiff build", str(e))
    except OSError as e:   # a read-only or full output place: one line with the place and the errno
        dest = Path(args.dest) if args.dest else fmu_cache_dir()
        _remove_staged(dest)
        return fail("spurdiff build", str(output_error(getattr(e, "filename2", None) or e.filename or dest, e)), 1)
    return 0
