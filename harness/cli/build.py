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
    from harness.build import FMUS, BuildError, build
    from harness.outputs import output_error
    from harness.paths import fmu_cache_dir

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
        _remove_staged(Path(args.dest) if args.dest else fmu_cache_dir())
        return fail("spurdiff build", str(e))
    except OSError as e:   # a read-only or full output place: one line with the place and the errno
        dest = Path(args.dest) if args.dest else fmu_cache_dir()
        _remove_staged(dest)
        return fail("spurdiff build", str(output_error(getattr(e, "filename2", None) or e.filename or dest, e)), 1)
    return 0
