"""``spurdiff check``: the command line of the FMU compliance kit.

Three modes::

    spurdiff check PATH.fmu [...] [--junit FILE]                   static + lifecycle checks
    spurdiff check --reference-results DIR PATH.fmu [...]          write cross-check references
    spurdiff check --compare RESULT.csv --reference REF.csv        compare a result, per column

Exit code: 1 when a rule of severity error failed (``--strict``: or a warning), 0 otherwise, 2 for
a usage error (unknown option, missing file, bad input table). ``--profile spurdiff`` adds the
project's own conventions (units, descriptions, ...) as errors. Help: ``spurdiff check -h``.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Sequence

from harness.check.compare import DEFAULT_RTOL, Tolerance, compare_checks
from harness.check.crosscheck import CsvFormatError, read_cross_check_csv
from harness.check.lifecycle import LifecycleOptions
from harness.check.reference import ReferenceUsageError, write_reference_results
from harness.check.report import EXIT_USAGE, FAIL, CheckResult, exit_code, format_report, write_junit
from harness.check.rules import PROFILES
from harness.check.runner import run_checks


class UsageError(Exception):
    pass


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="spurdiff check",
        description="Compliance checks of any FMI 2.0 FMU (co-simulation and model exchange): the archive "
                    "and modelDescription.xml, and the FMI call sequence, each rule in a fresh process. Every "
                    "rule cites its FMI 2.0 section and has a severity (error, warning, info). "
                    "See docs/compliance.md.",
        epilog="exit code: 0 no error (warnings and info allowed), 1 an error (--strict: or a warning), 2 usage error")
    ap.add_argument("fmus", nargs="*", metavar="PATH.fmu", help="FMUs to check")
    ap.add_argument("--junit", metavar="FILE", help="also write a JUnit XML report (one testsuite per FMU)")
    ap.add_argument("--timeout", type=float, default=60.0, metavar="S",
                    help="wall-clock limit per lifecycle check process, s (default 60)")
    ap.add_argument("--jobs", type=int, default=LifecycleOptions().jobs, metavar="N",
                    help="check processes run at once (default: number of CPUs)")
    ap.add_argument("--steps", type=int, default=10, metavar="N",
                    help="doSteps per lifecycle run (default 10, at least 2)")
    ap.add_argument("--static-only", action="store_true", help="only the static (modelDescription) checks")
    ap.add_argument("--strict", action="store_true", help="warnings count as failures (exit code, JUnit)")
    ap.add_argument("--profile", action="append", default=[], choices=PROFILES,
                    help="also enforce a profile's conventions, as errors (spurdiff: a unit on every Real, "
                         "descriptions, dependencies on every output, fixed parameters refused after "
                         "initialization)")
    g = ap.add_argument_group("reference results (FMI cross-check layout)")
    g.add_argument("--reference-results", metavar="DIR",
                   help="simulate each FMU over its default experiment and write DIR/<Model>/<Model>_ref.csv, "
                        "_ref.opt and (with inputs) _in.csv")
    g.add_argument("--input", metavar="CSV",
                   help="input table for --reference-results (one FMU only; columns: time and inputs; "
                        "inputs left out stay at their start values)")
    g = ap.add_argument_group("comparison")
    g.add_argument("--compare", metavar="RESULT.csv", help="an importer's result to compare with --reference")
    g.add_argument("--reference", metavar="REF.csv", help="the reference CSV (e.g. DIR/<Model>/<Model>_ref.csv)")
    g.add_argument("--rtol", type=float, default=DEFAULT_RTOL,
                   help=f"relative tolerance for every column (default {DEFAULT_RTOL:g})")
    g.add_argument("--atol", type=float, default=None,
                   help="absolute tolerance for every column, in the column's unit "
                        "(default: rtol x the column's peak |reference|)")
    g.add_argument("--tolerance", action="append", default=[], metavar="COLUMN=RTOL[,ATOL]",
                   help="tolerance for one column (repeatable)")
    return ap


def _parse_tolerances(items: Sequence[str], rtol: float, atol: float | None) -> dict[str, Tolerance]:
    out: dict[str, Tolerance] = {}
    for item in items:
        name, sep, value = item.rpartition("=")
        if not sep or not name:
            raise UsageError(f"--tolerance {item!r}: expected COLUMN=RTOL[,ATOL]")
        parts = value.split(",")
        try:
            r = float(parts[0]) if parts[0] else rtol
            a = float(parts[1]) if len(parts) > 1 and parts[1] else atol
        except ValueError:
            raise UsageError(f"--tolerance {item!r}: RTOL and ATOL must be numbers") from None
        if len(parts) > 2 or r < 0 or (a is not None and a < 0):
            raise UsageError(f"--tolerance {item!r}: expected COLUMN=RTOL[,ATOL] with RTOL, ATOL >= 0")
        out[name] = Tolerance(r, a)
    return out


def _existing_files(paths: Sequence[str], what: str) -> list[str]:
    missing = [p for p in paths if not Path(p).is_file()]
    if missing:
        raise UsageError(f"{what} not found: {', '.join(missing)}")
    return list(dict.fromkeys(paths))  # keep order, drop repeats


def _finish(results: Sequence[CheckResult], junit: str | None, strict: bool = False) -> int:
    print(format_report(results))
    if junit:
        path = write_junit(junit, results, strict)
        print(f"JUnit report: {path}")
    return exit_code(results, strict)


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``spurdiff check`` with ``argv`` (without the program name); returns the exit code."""
    parser = build_parser()
    try:
        args = parser.parse_args(list(sys.argv[1:] if argv is None else argv))
    except SystemExit as e:  # argparse: --help (0) or a usage error (2)
        return int(e.code) if isinstance(e.code, int) else EXIT_USAGE
    try:
        if args.timeout <= 0 or args.jobs < 1 or args.steps < 2:
            raise UsageError("--timeout must be > 0, --jobs >= 1, --steps >= 2")
        if args.compare or args.reference:
            if not (args.compare and args.reference):
                raise UsageError("--compare RESULT.csv and --reference REF.csv go together")
            if args.fmus or args.reference_results:
                raise UsageError("--compare takes no FMUs and no --reference-results")
            _existing_files([args.compare, args.reference], "file")
            per_column = _parse_tolerances(args.tolerance, args.rtol, args.atol)
            if args.rtol < 0 or (args.atol is not None and args.atol < 0):
                raise UsageError("--rtol and --atol must be >= 0")
            try:
                read_cross_check_csv(args.reference)
            except CsvFormatError as e:
                raise UsageError(f"--reference: {e}") from None
            try:
                results = compare_checks(args.compare, args.reference, args.rtol, args.atol, per_column)
            except CsvFormatError as e:
                results = [CheckResult(args.compare, "compare.read", FAIL, str(e))]
            return _finish(results, args.junit, args.strict)
        if not args.fmus:
            raise UsageError("no FMU given (spurdiff check PATH.fmu ...; -h for help)")
        fmus = _existing_files(args.fmus, "FMU")
        if args.reference_results:
            if args.input is not None:
                _existing_files([args.input], "input table")
                if len(fmus) != 1:
                    raise UsageError("--input applies to exactly one FMU")
            results = []
            for f in fmus:
                try:
                    results.append(write_reference_results(f, args.reference_results, args.input,
                                                           timeout=args.timeout * 10, subject=f))
                except ReferenceUsageError as e:
                    raise UsageError(str(e)) from None
                except Exception as e:  # unreadable model description
                    results.append(CheckResult(f, "reference.write", FAIL, f"{type(e).__name__}: {e}"))
            return _finish(results, args.junit, args.strict)
        if args.input is not None:
            raise UsageError("--input goes with --reference-results")
        options = LifecycleOptions(steps=args.steps, timeout=args.timeout, jobs=args.jobs,
                                   profiles=tuple(dict.fromkeys(args.profile)))
        return _finish(run_checks(fmus, options, args.static_only), args.junit, args.strict)
    except UsageError as e:
        print(f"spurdiff check: error: {e}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
