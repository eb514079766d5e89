"""FMU compliance kit (``spurdiff check``) for any FMI 2.0 or FMI 3.0 FMU, co-simulation and model exchange.

Packages, by job:

* :mod:`.rules`: every rule as data (``rules/table.toml``: one entry per meaning, each FMI version's id,
  section, severity and sentence); imports nothing of the kit;
* :mod:`.static`: the archive and modelDescription.xml rules, no binary loaded (``static/fmi2.py``,
  ``static/fmi3.py``, what they share in ``static/common.py``);
* :mod:`.worker`: what runs inside a check process: the FMI session of either version (``worker/fmi2.py``,
  ``worker/fmi3.py``) and the call-sequence rules, by id (``worker/tasks.py``).

Modules at the top, parent side:

* :mod:`.archive`: reading a possibly hostile FMU archive within limits, safe extraction;
* :mod:`.native`: the binary outside Python (ELF symbols against DT_NEEDED, a bare C host);
* :mod:`.selection`: which rules run on which FMU (select/ignore, [tool.spurdiff.check]);
* :mod:`.isolation`: one task in a fresh process (:mod:`.worker`), killed with its whole group at the timeout;
* :mod:`.reaper`: the process every FMU runs under (started by :mod:`.isolation`), ending all the FMU started;
* :mod:`.lifecycle`: scheduling the call-sequence rules, ``jobs`` processes at a time, preconditions, one
  finding per crash or hang;
* :mod:`.crosscheck`: the cross-check file formats (CSV, ``_ref.opt``);
* :mod:`.reference`, :mod:`.reference_task`: writing reference results; :mod:`.compare`: per-column comparison;
* :mod:`.band`: the FMI cross-check suite's rule for a result against a reference; :mod:`.xcheck`: the
  cross-check mode (a suite's folder run in every host, verdicts filed in its results layout), its runs in
  :mod:`.xcheck_host` (inside a check process);
* :mod:`.report`: PASS/ERROR/WARN/INFO/SKIP lines, JUnit XML, exit code;
* :mod:`.runner`: every rule for several FMUs (the command line is :mod:`harness.cli.check`).

Imports run one way: rules <- report <- static, worker <- the parent-side modules <- runner; the worker
package is imported only inside a check process (by :mod:`.isolation`'s command line), never by the parent.

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
