"""Run a scene with the harness's own co-simulation master and write every recorded variable.

The steps of ``spurdiff run`` (prepare_scene, typed_parameters, run_scene) without the build and
the report, so it runs on a Python that can only run the master: the Windows CPython under wine
of tests/harness/test_win64.py, beside the same script on the build's Python for linux64.

    python win64_master.py SCENE OUT.json TMP NAME=FMU_FILE...

TMP is the folder the FMUs are extracted into. OUT.json holds the recorded names, the rows (floats
written as repr: read back bit for bit), the coupling energies, the failure if any, the platform.
"""
from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _importable() -> None:
    """The checkout's harness and physics package on the module path of a Python without them
    installed (the Windows one: its ._pth names only its standard library and its site-packages)."""
    try:
        import harness  # noqa: F401
    except ImportError:
        sys.path[:0] = [str(ROOT), str(ROOT / "fmu_src")]


def main(argv: list[str]) -> int:
    scene_name, out, tmp, *pairs = argv
    tempfile.tempdir = tmp    # before the harness's FMU cache makes its folder in it
    _importable()
    from harness.run.master import run_scene
    from harness.run.runner import prepare_scene, typed_parameters

    files = {name: Path(path) for name, path in (p.split("=", 1) for p in pairs)}
    scene = prepare_scene(scene_name)
    typed_parameters(scene, files)
    result = run_scene(scene, files)
    Path(out).write_text(json.dumps({
        "platform": sys.platform, "python": sys.version.split()[0],
        "names": result.names, "rows": [[repr(float(x)) for x in row] for row in result.data],
        "coupling_energy": {k: {q: repr(float(v)) for q, v in e.items()} for k, e in result.coupling_energy.items()},
        "failure": None if result.failure is None else str(result.failure), "messages": result.messages,
    }), encoding="utf-8")
    print(f"{scene_name}: {len(result.data)} rows of {len(result.names)} variables, "
          f"failure: {result.failure}", flush=True)
    return 0 if result.failure is None else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
