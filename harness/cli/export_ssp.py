"""``spurdiff export-ssp SCENE``: the coupled system as an SSP 1.0 file (SystemStructure.ssd and the FMUs)
for other masters (:mod:`harness.interop.ssp`)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from harness.scene.schema import SceneError


def main(argv: list[str] | None = None) -> int:
    """``spurdiff export-ssp SCENE [-o FILE] [--step H] [--duration T] [--mesh M] [--set I.P=V]``."""
    from harness.cli import add_scene_export_arguments
    from harness.run.runner import fmu_files_for, prepare_scene
    from harness.interop.ssp import SCENE_ANNOTATION, SspError, default_output, export_ssp_summary

    ap = argparse.ArgumentParser(prog="spurdiff export-ssp",
                                 description="Write a scene as an SSP 1.0 file (SystemStructure.ssd + FMUs) for other masters")
    add_scene_export_arguments(ap, "SSP file to write (default results/<scene>/<scene>.ssp)", "written to the SSP")
    ap.add_argument("--fmi-version", dest="fmi_version", type=int, choices=(2, 3), default=2,
                    help="put the FMI 2.0 FMUs (NAME.fmu, the default) or the FMI 3.0 ones (NAME-fmi3.fmu) in the SSP")
    args = ap.parse_args(argv)
    try:
        scene = prepare_scene(args.scene, mesh=args.mesh, step=args.step, duration=args.duration, sets=args.set)
        files = fmu_files_for(scene, build_missing=True, fmi_version=args.fmi_version)
        out = Path(args.output) if args.output else default_output(scene)
        s = export_ssp_summary(scene, files, out)
    except (SceneError, SspError) as e:
        print(f"spurdiff export-ssp: {e}", file=sys.stderr)
        return 2
    except ImportError as e:
        print(f"spurdiff export-ssp: {e.name} is not installed (pip install pyssp-standard)", file=sys.stderr)
        return 2
    print(f"wrote {s.path}: {s.components} component(s), {s.connections} connection(s), {s.values} start value(s); "
          f"stop time {scene.duration:g} s, step {scene.step:g} s (osp:FixedStepAlgorithm)")
    for ref in s.tables:
        print(f"note: input {ref} is a time table; the SSP binds its value at t = 0 "
              f"(the table is kept only in the {SCENE_ANNOTATION} annotation)")
    if scene.connections and scene.algorithm != "jacobi":
        print(f"note: the scene's algorithm is {scene.algorithm}; SSP masters such as libcosim step Jacobi")
    return 0


if __name__ == "__main__":
    sys.exit(main())
