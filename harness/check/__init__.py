"""FMU compliance kit (``spurdiff check``) for any FMI 2.0 co-simulation FMU.

* :mod:`.static`: modelDescription.xml checks (fmpy's validation plus units, output
  dependencies, descriptions, structured names, host binary);
* :mod:`.lifecycle`: the FMI call sequence, each check in a fresh process;
* :mod:`.reference`: reference results in the FMI cross-check layout and per-column comparison;
* :mod:`.report`: PASS/FAIL/SKIP lines, JUnit XML, exit code;
* :mod:`.runner`: the command line, ``main(argv) -> int``.

Rules and a CI recipe: docs/compliance.md.
"""
from .lifecycle import LIFECYCLE_CHECKS, LifecycleOptions, run_lifecycle_checks, run_lifecycle_checks_many
from .reference import (ColumnComparison, Tolerance, compare_checks, compare_results, read_cross_check_csv,
                        read_ref_opt, write_reference_results)
from .report import FAIL, PASS, SKIP, CheckResult, exit_code, format_line, format_report, write_junit
from .static import STATIC_CHECKS, is_structured_name, run_static_checks

__all__ = [
    "CheckResult", "PASS", "FAIL", "SKIP", "format_line", "format_report", "exit_code", "write_junit",
    "STATIC_CHECKS", "run_static_checks", "is_structured_name",
    "LIFECYCLE_CHECKS", "LifecycleOptions", "run_lifecycle_checks", "run_lifecycle_checks_many",
    "write_reference_results", "compare_results", "compare_checks", "read_cross_check_csv", "read_ref_opt",
    "Tolerance", "ColumnComparison",
    "main",
]


def main(argv=None) -> int:
    """``spurdiff check`` (see :func:`harness.check.runner.main`)."""
    from .runner import main as _main
    return _main(argv)
