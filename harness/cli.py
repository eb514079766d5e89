"""The `spurdiff` command line: a thin layer over the harness library functions."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from harness.paths import results_dir



def _fail(msg: str, code: int = 2) -> int:
    print(f"spurdiff: {msg}", file=sys.stderr)
    return code


def cmd_info(args) -> int:
    from harness.info import info_text
    print(info_text())
    return 0


def cmd_scenes(args) -> int:
    from harness.scene import describe_all
    for name, desc in describe_all():
        print(f"{name:22s} {desc}")
    return 0


class Progress:
    """A one-line progress bar on stderr for runs longer than a few seconds."""

    def __init__(self, label: str, delay: float = 2.0):
        self.label, self.delay, self.t0, self.shown = label, delay, time.perf_counter(), False
        self.enabled = sys.stderr.isatty()
        self.last = 0.0

    def __call__(self, frac: float) -> None:
        if not self.enabled:
            return
        el = time.perf_counter() - self.t0
        if (el < self.delay or el - self.last < 0.2) and frac < 1.0:
            return
        self.last = el
        if frac >= 1.0 and not self.shown:
            return
        self.shown = True
        n = int(30 * frac)
        eta = el / frac - el if frac > 0 else 0.0
        sys.stderr.write(f"\r{self.label} [{'#' * n}{'.' * (30 - n)}] {100 * frac:5.1f} %  {el:6.1f} s  eta {eta:5.1f} s")
        if frac >= 1.0:
            sys.stderr.write("\n")
        sys.stderr.flush()


def cmd_run(args) -> int:
    from harness.build import build
    from harness.plots import plot_result
    from harness.master import Interrupted, stop_on_sigint
    from harness.report import CsvStream, evaluate_checks, format_checks, format_couplings, format_table, writable_dir
    from harness.runner import explain_failure, fmu_files_for, prepare_scene, typed_parameters

    scene = prepare_scene(args.scene, mesh=args.mesh, step=args.step, duration=args.duration,
                          algorithm=args.algorithm, sets=args.set)
    if scene.fidelity.get("mode") == "auto":
        if args.mesh or args.step:
            print("fidelity auto: overridden by --mesh/--step")
        else:
            from harness.accuracy import apply_choice, choose
            pick, reason = choose(scene)
            scene = apply_choice(scene, pick)
            print(reason)
    out_dir = Path(args.out) if args.out else results_dir(scene.name)
    writable_dir(out_dir, "--out" if args.out else "results folder")   # before running, not after
    csv_path = out_dir / f"{scene.name}.csv"
    files = fmu_files_for(scene, build_missing=True)
    typed_parameters(scene, files)
    with CsvStream(csv_path, ["time"] + list(scene.record)) as stream, stop_on_sigint():   # rows as they come
        result = __import__("harness.master", fromlist=["run_scene"]).run_scene(scene, files, Progress(scene.name),
                                                                                 sink=stream.write)
    if isinstance(result.failure, Interrupted):
        return _fail(f"{result.failure}; the {len(result.time)} samples recorded so far are in {csv_path}", 130)
    print(f"scene {scene.name}: {scene.description}")
    fid = ", ".join(f"{k} = {v}" for k, v in scene.effects.items()) or "defaults"
    print(f"fidelity: {fid}; step {scene.step:g} s, {scene.algorithm}; simulated {result.time[-1] if len(result.time) else 0:g} s "
          f"in {result.wall_time:.3f} s wall ({(result.time[-1] / result.wall_time) if result.wall_time > 0 and len(result.time) else 0:.1f}x real time; "
          f"setup {result.setup_time:.2f} s)")
    table = format_table(result)
    if table:
        print()
        print(table)
    extra = getattr(result, "summary", None)
    if extra:
        print()
        print(extra)
    cp = format_couplings(result)
    if cp:
        print()
        print(cp)
    outcomes = evaluate_checks(result) if result.ok else []
    if outcomes:
        print()
        print(format_checks(outcomes))
    print()
    print(f"results: {csv_path}" if stream.rows else "results: nothing recorded")
    if not args.no_plots and len(result.time) > 1:
        for p in plot_result(result, out_dir):
            print(f"plot: {p}")
    if result.failure is not None:
        return _fail(f"run stopped: {explain_failure(scene, result.failure)}"
                     + (f" (results so far kept in {csv_path})" if stream.rows else " (nothing recorded)"), 1)
    if any(not o.passed for o in outcomes):
        return _fail("some physical checks failed", 1)
    return 0


def cmd_fmu(args) -> int:
    """The path of a built FMU (built first if needed), for scripts and other hosts."""
    from harness.build import FMUS, BuildError, build
    if args.name not in FMUS:
        return _fail(f"unknown FMU {args.name!r}; allowed: {', '.join(FMUS)}")
    try:
        (path,) = build([args.name], args.out, quiet=True)
    except BuildError as e:
        return _fail(str(e))
    print(path)
    return 0


def build_parser() -> argparse.ArgumentParser:
    from harness.paths import package_version

    ap = argparse.ArgumentParser(prog="spurdiff", description="Spur-gear planetary differential FMUs and co-simulation harness")
    ap.add_argument("--version", action="version", version=f"spurdiff {package_version()}")
    sub = ap.add_subparsers(dest="command", required=True)
    sub.add_parser("build", help="build the FMUs (build/fmus in a checkout, else the per-user cache; "
                                 "--out DIR, --force); prints where")
    sub.add_parser("bench", help="measured cost ratios: FMI vs direct, each fidelity vs rigid, real-time factors")
    sub.add_parser("check", help="FMI 2.0 compliance checks of any co-simulation FMU, JUnit report (docs/compliance.md)")
    sub.add_parser("export-ssp", help="write a scene as an SSP file other masters run (docs/interoperability.md)")
    sub.add_parser("accuracy", help="accuracy versus wall time over fidelities, steps and tolerances (docs/accuracy.md)")
    sub.add_parser("sweep", help="design sweep of a scene on a local or remote Dask cluster, resumable (docs/sweeps.md)")
    p = sub.add_parser("info", help="derived geometry, design checks and the paper's theory table beside ours")
    p.set_defaults(func=cmd_info)
    p = sub.add_parser("scenes", help="list the scenes")
    p.set_defaults(func=cmd_scenes)
    p = sub.add_parser("fmu", help="print the path of a built FMU, building it if needed")
    p.add_argument("name", help="SpurDifferential, WheelLoad or Vehicle")
    p.add_argument("--out", type=Path, default=None, help="build into DIR instead of the default place")
    p.set_defaults(func=cmd_fmu)
    p = sub.add_parser("run", help="run a scene: results table, checks, CSV and plots")
    p.add_argument("scene", help="scene name (see `spurdiff scenes`) or path to a .toml file")
    p.add_argument("--mesh", help="differential mesh model (overrides the scene's effects.meshModel)")
    p.add_argument("--step", type=float, help="communication step, s")
    p.add_argument("--duration", type=float, help="simulated time, s")
    p.add_argument("--algorithm", choices=["gauss-seidel", "jacobi"])
    p.add_argument("--set", action="append", default=[], metavar="INST.PARAM=VALUE",
                   help="override a parameter, e.g. --set diff.mu_pin=0.1")
    p.add_argument("--out", help="output directory (default ./results/<scene> under the current folder)")
    p.add_argument("--no-plots", action="store_true")
    p.set_defaults(func=cmd_run)
    return ap


def main(argv: list[str] | None = None) -> int:
    from harness.scene import SceneError
    from harness.master import RunFailure
    from spurdiff.errors import ParameterError

    argv = list(sys.argv[1:] if argv is None else argv)
    delegated = {"build": "harness.build", "bench": "harness.bench", "accuracy": "harness.accuracy",
                 "check": "harness.check.runner", "export-ssp": "harness.ssp", "sweep": "harness.sweep"}
    if argv[:1] and argv[0] in delegated:  # these parse their own options
        import importlib
        try:
            return importlib.import_module(delegated[argv[0]]).main(argv[1:])
        except (SceneError, ParameterError, RunFailure) as e:
            return _fail(str(e))
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (SceneError, ParameterError, RunFailure) as e:
        return _fail(str(e))
    except KeyboardInterrupt:
        return _fail("interrupted", 130)


if __name__ == "__main__":
    sys.exit(main())
