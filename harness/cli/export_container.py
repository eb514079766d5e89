"""``spurdiff export-container SCENE``: the coupled scene as one FMU, an FMU container of
fmu-manipulation-toolbox that steps the scene's FMUs inside it (:mod:`harness.interop.container`)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from harness.scene.schema import SceneError


def main(argv: list[str] | None = None) -> int:
    """``spurdiff export-container SCENE [-o FILE] [--step H] [--duration T] [--mesh M] [--set I.P=V] [--compare]``."""
    from harness.cli import add_scene_export_arguments, fail
    from harness.interop.container import ContainerError, default_output, export_container
    from harness.run.runner import fmu_files_for, prepare_scene

    prog = "spurdiff export-container"
    ap = argparse.ArgumentParser(prog=prog, description="Write a scene (its FMUs, connections, parameters and step) "
                                 "as one container FMU (fmu-manipulation-toolbox)")
    add_scene_export_arguments(ap, "FMU to write (default results/<scene>/<scene>.fmu)",
                               "inside the container (its default experiment's)")
    ap.add_argument("--tables-at-start", action="store_true",
                    help="accept time-table inputs, carried as their value at t = 0")
    ap.add_argument("--compare", action="store_true",
                    help="then run the container in fmpy and the scene in our master; print both (means over the second half)")
    args = ap.parse_args(argv)
    try:
        scene = prepare_scene(args.scene, mesh=args.mesh, step=args.step, duration=args.duration, sets=args.set)
        files = fmu_files_for(scene, build_missing=True)
        out = Path(args.output) if args.output else default_output(scene)
        s = export_container(scene, files, out, tables_at_start=args.tables_at_start)
    except (SceneError, ContainerError) as e:
        return fail(prog, str(e))
    mode = "sequential (Gauss-Seidel, the scene's order)" if s.sequential else "parallel (Jacobi)"
    print(f"wrote {s.path}: {s.fmus} FMU(s), {s.links} link(s), {s.starts} start value(s), {s.outputs} output(s); "
          f"step {s.step:g} s, {mode}; made with {s.tool}")
    if args.compare:
        from harness.interop.container_compare import compare, table
        rows = compare(scene, files, s.path)
        print(table(rows, 0.5 * scene.duration, scene.duration))
    return 0


if __name__ == "__main__":
    sys.exit(main())
