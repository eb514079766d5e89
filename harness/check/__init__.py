"""FMU compliance kit (``spurdiff check``) for any FMI 2.0 or FMI 3.0 FMU, co-simulation and model exchange.

Packages, by job:

* :mod:`.rules`: every rule as data (``rules/table.toml``: one entry per meaning, each FMI version's id,
  section, severity and sentence); imports nothing of the kit;
* :mod:`.static`: the archive and modelDescription.xml rules, no binary loaded (``static/fmi2.py``,
  ``static/fmi3.py``, what they share in ``static/common.py``);
* :mod:`.worker`: what runs inside a check process: the FMI session of either version (``worker/fmi2.py``,
  ``worker/fmi3.py``) and the call-sequence rules, by id (``worker/tasks.py``);
* :mod:`.processes`: the processes an FMU runs in (:mod:`.processes.isolation`: one task in a fresh
  process, killed with its group at the timeout; :mod:`.processes.reaper`: ending all the FMU started;
  :mod:`.processes.native`: the binary outside Python, the ``load.*`` rules);
* :mod:`.crosscheck`: results against references: the cross-check suite's files and rule, ``--compare``,
  ``--reference-results`` and the cross-check mode (``--cross-check DIR``).

Modules at the top, parent side:

* :mod:`.archive`: reading a possibly hostile FMU archive within limits, safe extraction;
* :mod:`.selection`: which rules run on which FMU (select/ignore, [tool.spurdiff.check]);
* :mod:`.lifecycle`: scheduling the call-sequence rules, ``jobs`` processes at a time, preconditions, one
  finding per crash or hang;
* :mod:`.report`: PASS/ERROR/WARN/INFO/SKIP lines, JUnit XML, exit code;
* :mod:`.runner`: every rule for several FMUs (the command line is :mod:`harness.cli.check`).

May import: :mod:`harness.common`, :mod:`harness.fmi` (the worker and the cross-check hosts), fmpy and numpy;
never the scene, run, sweep, measure, interop or command-line packages. Inside, imports run one way:
rules <- report <- archive, static <- processes <- crosscheck, lifecycle <- runner; the worker package
is imported only inside a check process (by :mod:`.processes.isolation`'s command line), never by the
parent; it may import :mod:`.crosscheck.formats` and :mod:`.crosscheck.reference_task`.

Rules and CI recipes: docs/compliance.md.
"""
from .lifecycle import LifecycleOptions, lifecycle_rules, run_lifecycle_checks, run_lifecycle_checks_many
from .crosscheck.compare import ColumnComparison, Tolerance, compare_checks, compare_results
from .crosscheck.formats import read_cross_check_csv, read_ref_opt
from .crosscheck.reference import safe_model_name, write_reference_results
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
