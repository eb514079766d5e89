"""``spurdiff check``: the command line of the FMU compliance kit.

Three modes::

    spurdiff check PATH.fmu [...] [--junit FILE]                   static + lifecycle checks
    spurdiff check --reference-results DIR PATH.fmu [...]          write cross-check references
    spurdiff check --compare RESULT.csv --reference REF.csv        compare a result by the cross-check rule
    spurdiff check --cross-check DIR [--results OUT]               the FMI cross-check, verdicts filed in OUT

Exit code: 1 when a rule of severity error failed (``--strict``: or a warning; ``--cross-check``: a
verdict ``failed``), 0 otherwise, 2 for a usage error (unknown option, missing file, bad input table, unknown rule). ``--profile spurdiff``
adds the project's own conventions (units, descriptions, ...) as errors. Rule selection as Python
linters do it: ``--select``, ``--ignore``, ``--extend-select``, ``--per-fmu-ignore`` and
``[tool.spurdiff.check]`` in pyproject.toml (see :mod:`harness.check.selection`).
``--list-rules`` prints the rules; ``--rule-table`` the table of docs/compliance.md. Help:
``spurdiff check -h``.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Sequence

from harness.check.crosscheck.compare import DEFAULT_RTOL, Tolerance, compare_checks, opt_beside, suite_checks
from harness.check.crosscheck.formats import CsvFormatError, read_cross_check_csv, read_ref_opt
from harness.check.lifecycle import LifecycleOptions
from harness.check.crosscheck.reference import ReferenceUsageError, write_reference_results
from harness.check.report import EXIT_USAGE, FAIL, CheckResult, exit_code, format_report, write_junit
from harness.check.rules import PROFILES, RULES, rule_table_markdown
from harness.check.runner import run_checks_selected
from harness.check.selection import SelectionError, find_config, read_config, resolve


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
    ap.add_argument("--timeout", type=float, default=None, metavar="S",
                    help="wall-clock limit per lifecycle check process, s (default 60)")
    ap.add_argument("--jobs", type=int, default=None, metavar="N",
                    help="check processes run at once (default: number of CPUs)")
    ap.add_argument("--steps", type=int, default=None, metavar="N",
                    help="doSteps per lifecycle run (default 10, at least 2)")
    ap.add_argument("--static-only", action="store_true", help="only the static (modelDescription) checks")
    ap.add_argument("--strict", action="store_true", default=None,
                    help="warnings count as failures (exit code, JUnit)")
    g = ap.add_argument_group("rule selection (rule ids, kinds, groups or ALL; see --list-rules)")
    g.add_argument("--select", metavar="RULES", help="comma-separated rules/groups to run (replaces the "
                   "config's select; default ALL)")
    g.add_argument("--ignore", metavar="RULES", action="append", default=[],
                   help="comma-separated rules/groups not to run (adds to the config's ignore)")
    g.add_argument("--extend-select", metavar="RULES", action="append", default=[],
                   help="comma-separated rules/groups to run in addition")
    g.add_argument("--per-fmu-ignore", metavar="GLOB=RULES", action="append", default=[],
                   help="rules/groups not to run on the FMUs GLOB matches (path or file name; repeatable)")
    g.add_argument("--config", metavar="FILE", help="read [tool.spurdiff.check] from FILE (default: the "
                   "nearest pyproject.toml with that table, from the current folder upwards)")
    g.add_argument("--isolated", action="store_true", help="read no configuration file")
    g.add_argument("--list-rules", action="store_true", help="print every rule (id, groups, severity) and exit")
    g.add_argument("--rule-table", action="store_true", help="print the rule table of docs/compliance.md and exit")
    g.add_argument("--write-rule-table", metavar="FILE", help="regenerate the rule table in FILE (between its "
                   "rule-table markers, e.g. docs/compliance.md) and exit")
    ap.add_argument("--profile", action="append", default=None, choices=PROFILES,
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
    g.add_argument("--ref-opt", metavar="FILE",
                   help="_ref.opt for --reference-results (StartTime, StopTime, StepSize, RelTol; default: the "
                        "<Model>_ref.opt beside the FMU, else its DefaultExperiment) and for --compare (default: "
                        "the _ref.opt beside REF.csv)")
    g = ap.add_argument_group("cross-check (the FMI cross-check suite's layout and rule)")
    g.add_argument("--cross-check", metavar="DIR",
                   help="run every co-simulation FMU of DIR (<FMI version>/cs/<platform>/<Tool>/<version>/<Model>/) "
                        "with its _ref.opt and _in.csv in each host, judge by the suite's rule, file passed / "
                        "failed / rejected with the result CSV and a README under --results, print the verdicts")
    g.add_argument("--results", metavar="OUT", default="xcheck-results",
                   help="where --cross-check files its verdicts (default ./xcheck-results)")
    g.add_argument("--hosts", metavar="HOSTS", default="fmpy,spurdiff",
                   help="comma-separated hosts for --cross-check (default fmpy,spurdiff)")
    g = ap.add_argument_group("comparison")
    g.add_argument("--compare", metavar="RESULT.csv", help="an importer's result to compare with --reference")
    g.add_argument("--rule", choices=("suite", "tube"), default=None,
                   help="suite: the cross-check suite's band (default); tube: |error| <= atol + rtol |ref| at every "
                        "reference sample (the default when --rtol, --atol or --tolerance is given)")
    g.add_argument("--reference", metavar="REF.csv", help="the reference CSV (e.g. DIR/<Model>/<Model>_ref.csv)")
    g.add_argument("--rtol", type=float, default=None,
                   help=f"relative tolerance of the tube for every column (default {DEFAULT_RTOL:g})")
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


def _finish(results: Sequence[CheckResult], junit: str | None, strict: bool = False,
            deselected: dict | None = None) -> int:
    print(format_report(results, deselected))
    if junit:
        path = write_junit(junit, results, strict, deselected)
        print(f"JUnit report: {path}")
    return exit_code(results, strict)


def _split(items: Sequence[str]) -> list[str]:
    return [x.strip() for item in items for x in item.split(",") if x.strip()]


def _list_rules() -> str:
    lines = [f"{'rule':<28} {'severity':<8} groups"]
    for r in RULES:
        sev = r.severity + (f" (profile {r.profile})" if r.profile else "")
        lines.append(f"{r.id:<28} {sev:<8} {', '.join((r.kind,) + r.groups)}")
    return "\n".join(lines)


def _beside(fmu: str) -> dict[str, Path]:
    """The cross-check files beside ``<Model>.fmu`` (``<Model>_ref.opt``, ``_in.csv``, ``_ref.csv``) that exist:
    ``--reference-results`` then runs with the same options and inputs and writes the same columns."""
    f = Path(fmu)
    found = {k: f.with_name(f"{f.stem}_{k}") for k in ("ref.opt", "in.csv", "ref.csv")}
    return {k: p for k, p in found.items() if p.is_file()}


def _cross_check(args) -> int:
    from harness.check.crosscheck.xcheck import HOSTS, find_models, run_cross_check, verdict_table
    root = Path(args.cross_check)
    if not root.is_dir():
        raise UsageError(f"--cross-check {root}: not a folder")
    hosts = _split([args.hosts])
    unknown = [h for h in hosts if h not in HOSTS]
    if not hosts or unknown:
        raise UsageError(f"--hosts {args.hosts!r}: allowed {', '.join(HOSTS)}")
    if not find_models(root):
        raise UsageError(f"--cross-check {root}: no <Model>/<Model>.fmu in the layout "
                         "<FMI version>/<type>/<platform>/<Tool>/<version>/<Model>/")
    rows = run_cross_check(root, args.results, hosts, timeout=args.timeout * 10, jobs=args.jobs)
    print(verdict_table(rows))
    print(f"verdicts, result CSVs and READMEs: {Path(args.results).resolve()}")
    return 1 if any(r.verdict == "failed" for r in rows) else 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``spurdiff check`` with ``argv`` (without the program name); returns the exit code."""
    parser = build_parser()
    try:
        args = parser.parse_args(list(sys.argv[1:] if argv is None else argv))
    except SystemExit as e:  # argparse: --help (0) or a usage error (2)
        return int(e.code) if isinstance(e.code, int) else EXIT_USAGE
    if args.list_rules or args.rule_table:
        print(_list_rules() if args.list_rules else rule_table_markdown())
        return 0
    if args.write_rule_table:
        from harness.check.rules import with_rule_table
        doc = Path(args.write_rule_table)
        try:
            doc.write_text(with_rule_table(doc.read_text(encoding="utf-8")), encoding="utf-8")
        except (OSError, ValueError) as e:
            print(f"spurdiff check: error: --write-rule-table {doc}: {e}", file=sys.stderr)
            return EXIT_USAGE
        print(f"rule table written to {doc} ({len(RULES)} rules)")
        return 0
    try:
        config, config_path = {}, None
        if not args.isolated:
            config_path = args.config or find_config()
            if config_path is not None:
                config = read_config(config_path)
        for name, default in (("timeout", 60.0), ("jobs", LifecycleOptions().jobs), ("steps", 10), ("strict", False)):
            if getattr(args, name) is None:
                setattr(args, name, config.get(name, default))
        if args.profile is None:
            args.profile = list(config.get("profile", []))
        unknown = [p for p in args.profile if p not in PROFILES]
        if unknown:
            raise UsageError(f"profile {unknown[0]!r} in {config_path}: allowed {', '.join(PROFILES)}")
        per_fmu = []
        for item in args.per_fmu_ignore:
            glob, sep, sels = item.rpartition("=")
            if not sep or not glob or not sels.strip():
                raise UsageError(f"--per-fmu-ignore {item!r}: expected GLOB=RULE[,RULE...]")
            per_fmu.append((glob, _split([sels])))
        selection = resolve(config, str(config_path) if config_path else None,
                            _split([args.select]) if args.select is not None else None,
                            _split(args.ignore), _split(args.extend_select), per_fmu)
        if args.timeout <= 0 or args.jobs < 1 or args.steps < 2:
            raise UsageError("--timeout must be > 0, --jobs >= 1, --steps >= 2")
        if args.compare or args.reference:
            if not (args.compare and args.reference):
                raise UsageError("--compare RESULT.csv and --reference REF.csv go together")
            if args.fmus or args.reference_results:
                raise UsageError("--compare takes no FMUs and no --reference-results")
            _existing_files([args.compare, args.reference], "file")
            tube = args.rule == "tube" or (args.rule is None and (args.rtol is not None or args.atol is not None
                                                                  or bool(args.tolerance)))
            if args.rule == "suite" and (args.rtol is not None or args.atol is not None or args.tolerance):
                raise UsageError("--rtol, --atol and --tolerance belong to --rule tube")
            rtol = DEFAULT_RTOL if args.rtol is None else args.rtol
            per_column = _parse_tolerances(args.tolerance, rtol, args.atol)
            if rtol < 0 or (args.atol is not None and args.atol < 0):
                raise UsageError("--rtol and --atol must be >= 0")
            if args.ref_opt is not None:
                _existing_files([args.ref_opt], "--ref-opt")
            try:
                read_cross_check_csv(args.reference)
                opt = args.ref_opt or opt_beside(args.reference)
                if opt is not None and not tube:
                    read_ref_opt(opt)
            except CsvFormatError as e:
                raise UsageError(f"--reference: {e}") from None
            try:
                results = (compare_checks(args.compare, args.reference, rtol, args.atol, per_column) if tube
                           else suite_checks(args.compare, args.reference, args.ref_opt))
            except CsvFormatError as e:
                results = [CheckResult(args.compare, "compare.read", FAIL, str(e))]
            return _finish(results, args.junit, args.strict)
        if args.cross_check:
            if args.fmus or args.reference_results or args.input:
                raise UsageError("--cross-check DIR takes no FMUs, --reference-results or --input")
            return _cross_check(args)
        if not args.fmus:
            raise UsageError("no FMU given (spurdiff check PATH.fmu ...; -h for help)")
        fmus = _existing_files(args.fmus, "FMU")
        if args.reference_results:
            if args.input is not None:
                _existing_files([args.input], "input table")
                if len(fmus) != 1:
                    raise UsageError("--input applies to exactly one FMU")
            if args.ref_opt is not None:
                _existing_files([args.ref_opt], "--ref-opt")
                if len(fmus) != 1:
                    raise UsageError("--ref-opt applies to exactly one FMU")
            results = []
            for f in fmus:
                side = _beside(f)
                opt = args.ref_opt or side.get("ref.opt")
                inp = args.input or side.get("in.csv")
                try:
                    columns = read_cross_check_csv(side["ref.csv"])[0][1:] if "ref.csv" in side else None
                except CsvFormatError as e:
                    raise UsageError(f"{side['ref.csv']}: {e}") from None
                if any((Path(args.reference_results) / Path(f).stem).resolve() == Path(x).resolve().parent
                       for x in side.values()):
                    raise UsageError(f"--reference-results {args.reference_results}: would overwrite the cross-check "
                                     f"files beside {f}; choose another folder")
                if side:
                    print(f"{f}: with {', '.join(str(side[k]) if k in side and (k != 'ref.opt' or not args.ref_opt) else k + ' given' for k in side)}")
                try:
                    results.append(write_reference_results(f, args.reference_results, inp,
                                                           timeout=args.timeout * 10, subject=f, ref_opt=opt,
                                                           columns=columns))
                except ReferenceUsageError as e:
                    raise UsageError(str(e)) from None
                except Exception as e:  # unreadable model description
                    results.append(CheckResult(f, "reference.write", FAIL, f"{type(e).__name__}: {e}"))
            return _finish(results, args.junit, args.strict)
        if args.input is not None:
            raise UsageError("--input goes with --reference-results")
        options = LifecycleOptions(steps=args.steps, timeout=args.timeout, jobs=args.jobs,
                                   profiles=tuple(dict.fromkeys(args.profile)))
        results, deselected = run_checks_selected(fmus, options, args.static_only, selection)
        return _finish(results, args.junit, args.strict, deselected)
    except (UsageError, SelectionError) as e:
        print(f"spurdiff check: error: {e}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
