"""``spurdiff export-container SCENE``: the coupled scene as one FMU, an FMU container of
fmu-manipulation-toolbox that steps the scene's FMUs inside it (:mod:`harness.interop.container`)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from harness.scene.schema import SceneError


def main(argv: list[str] | None = None) -> int:
    """``spurdiff export-container SCENE [-o FILE] [--step H] [--duration T] [--mesh M] [--set I.P=V]
    [--fmi-version 2|3] [--compare]``."""
    from harness.cli import add_scene_export_arguments, fail
    from harness.common.outputs import OutputError
    from harness.interop.container import ContainerError, default_output, export_container
    from harness.run.runner import fmu_files_for, prepare_scene

    prog = "spurdiff export-container"
    ap = argparse.ArgumentParser(prog=prog, description="Write a scene (its FMUs, connections, parameters and step) "
                                 "as one container FMU (fmu-manipulation-toolbox)")
    add_scene_export_arguments(ap, "FMU to write (default results/<scene>/<scene>.fmu)",
                               "inside the container (its default experiment's)")
    ap.add_argument("--tables-at-start", action="store_true",
                    help="accept time-table inputs, carried as their value at t = 0")
    ap.add_argument("--fmi-version", dest="fmi_version", type=int, choices=(2, 3), default=2,
                    help="an FMI 2.0 container of the FMI 2.0 FMUs (NAME.fmu, the default) or an FMI 3.0 one "
                         "of the FMI 3.0 FMUs (NAME-fmi3.fmu)")
    ap.add_argument("--compare", action="store_true",
                    help="then run the container in fmpy and libcosim (FMI 2.0, where libcosimpy is installed) "
                         "and the scene in our master; print them side by side (means over the second half)")
    args = ap.parse_args(argv)
    try:
        scene = prepare_scene(args.scene, mesh=args.mesh, step=args.step, duration=args.duration, sets=args.set)
        files = fmu_files_for(scene, build_missing=True, fmi_version=args.fmi_version)
        out = Path(args.output) if args.output else default_output(scene)
        s = export_container(scene, files, out, tables_at_start=args.tables_at_start, fmi_version=args.fmi_version)
    except (SceneError, ContainerError, OutputError) as e:
        return fail(prog, str(e))
    for line in s.warnings:   # the toolbox's WARNING lines and benign ERROR lines, one line each
        print(f"{prog}: warning: {line}", file=sys.stderr)
    mode = "sequential (Gauss-Seidel, the scene's order)" if s.sequential else "parallel (Jacobi)"
    print(f"wrote {s.path}: FMI {s.fmi_version}.0, {s.fmus} FMU(s), {s.links} link(s), {s.starts} start value(s), "
          f"{s.outputs} output(s); step {s.step:g} s, stop time {scene.duration:g} s, {mode}; made with {s.tool}")
    if args.compare:
        from harness.interop.container_compare import compare, start_differences, table
        hosts = ("fmpy",) + _libcosim_host(s.fmi_version)
        try:
            rows = compare(scene, files, s.path, hosts=hosts)
        except RuntimeError as e:
            return fail(prog, str(e))
        print(table(rows, 0.5 * scene.duration, scene.duration))
        print(start_differences(rows))
    return 0


def _libcosim_host(fmi_version: int) -> tuple[str, ...]:
    """("libcosim",) where it can run the container; else a note why not and ()."""
    import importlib.util
    if fmi_version != 2:
        print("note: libcosim not run: libcosimpy 0.0.6 imports FMI 1.0 and 2.0 FMUs only")
        return ()
    if importlib.util.find_spec("libcosimpy") is None:
        print("note: libcosim not run: libcosimpy is not installed (pip install libcosimpy)")
        return ()
    return ("libcosim",)


if __name__ == "__main__":
    sys.exit(main())
