"""``spurdiff run SCENE``: run a scene; results table, physical checks, coupling power balance, CSV
(streamed as the run goes) and PNG plots."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from harness.cli import fail
from harness.common.messages import printable
from harness.common.outputs import refuse_symlink
from harness.common.paths import results_dir


def say(text: str = "") -> None:
    """Print text that may come from a scene file: control characters escaped (no escape codes)."""
    print(printable(text))


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="spurdiff run", description="run a scene: results table, checks, CSV and plots")
    p.add_argument("scene", help="scene name (see `spurdiff scenes`) or path to a .toml file")
    p.add_argument("--mesh", help="differential mesh model (overrides the scene's effects.meshModel)")
    p.add_argument("--step", type=float, help="communication step, s")
    p.add_argument("--duration", type=float, help="simulated time, s")
    p.add_argument("--algorithm", choices=["gauss-seidel", "jacobi"])
    p.add_argument("--set", action="append", default=[], metavar="INST.PARAM=VALUE",
                   help="override a parameter, e.g. --set diff.mu_pin=0.1")
    p.add_argument("--out", help="output directory (default ./results/<scene> under the current folder)")
    p.add_argument("--no-plots", action="store_true")
    p.add_argument("--fmi-version", dest="fmi_version", type=int, choices=(2, 3), default=2,
                   help="run the FMI 2.0 FMUs (NAME.fmu, the default) or the FMI 3.0 ones (NAME-fmi3.fmu)")
    p.add_argument("--max-steps", type=int, default=None, metavar="N",
                   help="refuse a run of more than N communication steps (default 1,000,000; the estimate is "
                        "said before the run starts)")
    return p


def main(argv: list[str] | None = None) -> int:
    return run(build_parser().parse_args(argv))


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


def run(args) -> int:
    from harness.common.outputs import OutputLock
    from harness.scene.recording import MAX_STEPS
    from harness.run.report import writable_dir
    from harness.run.runner import prepare_scene

    if args.max_steps is not None and args.max_steps < 1:
        return fail("spurdiff", f"--max-steps = {args.max_steps}: allowed an integer >= 1")
    scene = prepare_scene(args.scene, mesh=args.mesh, step=args.step, duration=args.duration,
                          algorithm=args.algorithm, sets=args.set, max_steps=args.max_steps or MAX_STEPS)
    if scene.fidelity.get("mode") == "auto":
        if args.mesh or args.step:
            print("fidelity auto: overridden by --mesh/--step")
        else:
            from harness.measure.accuracy import apply_choice, choose
            pick, reason = choose(scene)
            scene = apply_choice(scene, pick)
            say(reason)
    out_dir = Path(args.out) if args.out else results_dir(scene.name)
    writable_dir(out_dir, "--out" if args.out else "results folder")   # before running, not after
    with OutputLock(out_dir, f"spurdiff run {scene.name}"):   # one writer per output folder
        return _run_into(args, scene, out_dir)


def _run_into(args, scene, out_dir: Path) -> int:
    """The run of :func:`run` with the lock on ``out_dir`` held: CSV, report and plots."""
    from harness.run.master import Interrupted, run_scene, stop_on_sigint
    from harness.run.plots import plot_result
    from harness.run.report import CsvStream, evaluate_checks, format_checks, format_couplings, format_table
    from harness.run.runner import explain_failure, fmu_files_for, typed_parameters

    csv_path = out_dir / f"{scene.name}.csv"
    refuse_symlink(csv_path)   # before running, not at the first row
    files = fmu_files_for(scene, build_missing=True, fmi_version=getattr(args, "fmi_version", 2))
    typed_parameters(scene, files)
    with CsvStream(csv_path, ["time"] + list(scene.record)) as stream, stop_on_sigint():   # rows as they come
        result = run_scene(scene, files, Progress(scene.name), sink=stream.write)
    if isinstance(result.failure, Interrupted):
        return fail("spurdiff", f"{result.failure}; the {len(result.time)} samples recorded so far are in {csv_path}", 130)
    say(f"scene {scene.name}: {scene.description}")
    fid = ", ".join(f"{k} = {v}" for k, v in scene.effects.items()) or "defaults"
    say(f"fidelity: {fid}; step {scene.step:g} s, {scene.algorithm}; simulated {result.time[-1] if len(result.time) else 0:g} s "
          f"in {result.wall_time:.3f} s wall ({(result.time[-1] / result.wall_time) if result.wall_time > 0 and len(result.time) else 0:.1f}x real time; "
          f"setup {result.setup_time:.2f} s)")
    table = format_table(result)
    if table:
        say()
        say(table)
    extra = getattr(result, "summary", None)
    if extra:
        say()
        say(extra)
    cp = format_couplings(result)
    if cp:
        say()
        say(cp)
    outcomes = evaluate_checks(result) if result.ok else []
    if outcomes:
        say()
        say(format_checks(outcomes))
    say()
    say(f"results: {csv_path}" if stream.rows else "results: nothing recorded")
    if not args.no_plots and len(result.time) > 1:
        for p in plot_result(result, out_dir):
            say(f"plot: {p}")
    if result.failure is not None:
        return fail("spurdiff", f"run stopped: {explain_failure(scene, result.failure)}"
                     + (f" (results so far kept in {csv_path})" if stream.rows else " (nothing recorded)"), 1)
    if any(not o.passed for o in outcomes):
        return fail("spurdiff", "some physical checks failed", 1)
    return 0
