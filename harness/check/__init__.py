"""FMU compliance kit (``spurdiff check``) for any FMI 2.0 or FMI 3.0 FMU, co-simulation and model exchange.

* :mod:`.rules`: every rule as data (id, FMI version and section, severity, calls, what passes, the
  standard's sentence); the FMI 3.0 rules in :mod:`.rules3`;
* :mod:`.archive`: reading a possibly hostile FMU archive within limits, safe extraction;
* :mod:`.static`: the archive and modelDescription.xml rules (no binary loaded), :mod:`.static3` for FMI 3.0;
* :mod:`.native`: the binary outside Python (ELF symbols against DT_NEEDED, a bare C host);
* :mod:`.selection`: which rules run on which FMU (select/ignore, [tool.spurdiff.check]);
* :mod:`.isolation`: one task in a fresh process, killed with its whole group at the timeout;
* :mod:`.worker`, :mod:`.driver`: the worker process and its FMI session (on :mod:`harness.fmi`);
* :mod:`.tasks`: what a worker process can run, by id: the co-simulation rules (:mod:`.cs_lifecycle`,
  :mod:`.cs_state`, :mod:`.cs_steps`), the model-exchange rules (:mod:`.me_checks`), the FMI 3.0 ones
  (:mod:`.driver3`, :mod:`.cs3_checks`, :mod:`.me3_checks`) and the
  reference simulation (:mod:`.reference_task`);
* :mod:`.lifecycle`: scheduling those rules, ``jobs`` processes at a time, preconditions, one finding
  per crash or hang;
* :mod:`.crosscheck`: the cross-check file formats (CSV, ``_ref.opt``);
* :mod:`.reference`: writing reference results (parent side); :mod:`.compare`: per-column comparison;
* :mod:`.report`: PASS/ERROR/WARN/INFO/SKIP lines, JUnit XML, exit code;
* :mod:`.runner`: every rule for several FMUs (the command line is :mod:`harness.cli.check`).

Rules and CI recipes: docs/compliance.md.
"""
from .lifecycle import LifecycleOptions, lifecycle_rules, run_lifecycle_checks, run_lifecycle_checks_many
from .compare import ColumnComparison, Tolerance, compare_checks, compare_results
from .crosscheck import read_cross_check_csv, read_ref_opt
from .reference import safe_model_name, write_reference_results
from .report import FAIL, PASS, SKIP, CheckResult, exit_code, format_line, format_report, summary, write_junit
from .rules import ERROR, INFO, RULES, WARNING, Rule
from .static import is_structured_name, run_static_checks

__all__ = [
    "CheckResult", "PASS", "FAIL", "SKIP", "format_line", "format_report", "summary", "exit_code", "write_junit",
    "Rule", "RULES", "ERROR", "WARNING", "INFO",
    "run_static_checks", "is_structured_name",
    "LifecycleOptions", "lifecycle_rules", "run_lifecycle_checks", "run_lifecycle_checks_many",
    "write_reference_results", "compare_results", "compare_checks", "read_cross_check_csv", "read_ref_opt",
    "safe_model_name", "Tolerance", "ColumnComparison",
]
