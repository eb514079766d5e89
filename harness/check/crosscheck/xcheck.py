"""``spurdiff check --cross-check DIR``: the FMI cross-check as an importer runs it, in every host the kit
has, with the suite's verdicts filed in the suite's results layout.

DIR holds FMUs in the suite's layout (modelica/fmi-cross-check, FMI-CROSS-CHECK-RULES.md 9.1.5):
``.../<FMI version>/<FMI type>/<platform>/<Tool>/<version>/<Model>/<Model>.fmu`` beside
``<Model>_ref.opt``, ``<Model>_ref.csv`` and, when the FMU has inputs, ``<Model>_in.csv``. Every
co-simulation FMU found is run with those options and inputs in each host (:mod:`.xcheck_host`:
``fmpy`` and ``spurdiff``, each in a fresh process, :mod:`.isolation`) and judged by the suite's rule
(:mod:`.band`). ``_in.csv`` is optional (9.1.4: "optional input signals in case the FMU has inputs"):
without one, the inputs keep the FMU's own start values (fmpy's cross-check script skips such an FMU). The
verdict:

``passed``
    the run reached StopTime and every reference column lies in the band;
``failed``
    the run failed (an FMI call refused, a crash, a hang) or its result is outside the band;
``rejected``
    the FMU was not run, naming why: its folder breaks the suite's submission rules (no ``_ref.opt``,
    no ``_ref.csv``: 9.1.4; reference columns that are not variables of the FMU: appendix B), it is not a
    co-simulation FMU of this platform, or its binary needs a library that neither the FMU nor this machine has (FMI 2.0
    2.3: "Dynamic link libraries must include all referenced resources that are not available on a
    standard target machine"; cross-check rules 9.1.3: FMUs "contain all required files (DLLs, data
    files etc.)").

Each verdict is filed as the suite's importers file theirs (9.2.3, 9.2.4):
``OUT/<FMI version>/<FMI type>/<platform>/<Importer>/<version>/<Tool>/<version>/<Model>/`` with an
empty ``passed`` / ``failed`` / ``rejected``, ``<Model>_out.csv`` (when the run gave one) and
``README.txt`` (host, options, the reason).
"""
from __future__ import annotations

import shutil
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from .band import judge
from .formats import CsvFormatError, read_cross_check_csv, read_ref_opt

HOSTS = ("fmpy", "spurdiff")
VERDICTS = ("passed", "failed", "rejected")
LAYOUT_KEYS = ("fmi_version", "fmi_type", "platform", "tool", "tool_version", "model")


@dataclass(frozen=True)
class Model:
    """One FMU folder of the layout."""

    folder: Path
    fmu: Path
    info: dict          # LAYOUT_KEYS -> path segment

    @property
    def name(self) -> str:
        return self.info["model"]

    def side(self, suffix: str) -> Path:
        return self.folder / f"{self.name}{suffix}"


@dataclass(frozen=True)
class Row:
    """One verdict of the table."""

    model: Model
    host: str
    verdict: str
    reason: str
    folder: Path | None = None
    seconds: float = 0.0


def find_models(root: str | Path) -> list[Model]:
    """Every ``<Model>/<Model>.fmu`` under ``root`` whose folder is six segments deep in the layout
    (``<FMI version>/<type>/<platform>/<Tool>/<version>/<Model>``), sorted by path."""
    root = Path(root)
    out = []
    for fmu in sorted(root.rglob("*.fmu")):
        if fmu.is_symlink() or not fmu.is_file() or fmu.stem != fmu.parent.name:
            continue
        parts = fmu.parent.relative_to(root).parts
        if len(parts) < 6:
            parts = fmu.parent.resolve().parts
        if len(parts) < 6:
            continue
        out.append(Model(fmu.parent, fmu, dict(zip(LAYOUT_KEYS, parts[-6:]))))
    return out


def importer(host: str) -> tuple[str, str]:
    """(importing tool name, version) a host files its results under."""
    from importlib.metadata import PackageNotFoundError, version
    if host == "fmpy":
        import fmpy
        return "FMPy", fmpy.__version__
    try:
        return "spurdiff", version("spurdiff")
    except PackageNotFoundError:
        return "spurdiff", "unknown"


def _why_not_run(m: Model) -> str | None:
    """Why the FMU is rejected without a run (see the module docstring), or None."""
    from fmpy import read_model_description

    from ..archive import ArchiveError, extract
    from ..processes.native import unresolved_symbols
    from ..static import host_platform
    if m.info["fmi_type"] != "cs":
        return f"a {m.info['fmi_type']} entry: the cross-check mode runs co-simulation FMUs"
    if not m.side("_ref.opt").is_file():
        return f"no {m.name}_ref.opt (cross-check rules 9.1.4: the options are required)"
    try:
        read_ref_opt(m.side("_ref.opt"))
    except (CsvFormatError, OSError, UnicodeDecodeError) as e:
        return f"{m.name}_ref.opt cannot be read: {e}"
    if not m.side("_ref.csv").is_file():
        return f"no {m.name}_ref.csv (cross-check rules 9.1.4: the reference result is required): nothing to judge by"
    try:
        unzipdir = extract(m.fmu)
    except ArchiveError as e:
        return f"the FMU cannot be unpacked: {e}"
    try:
        md = read_model_description(str(unzipdir), validate=False)
        if md.fmiVersion != "2.0" or md.coSimulation is None:
            return f"not an FMI 2.0 co-simulation FMU (fmiVersion {md.fmiVersion})"
        known = {v.name for v in md.modelVariables}
        try:
            ref_names, _ = read_cross_check_csv(m.side("_ref.csv"))
        except CsvFormatError as e:
            return f"{m.name}_ref.csv breaks the CSV rules: {e}"
        strangers = [n for n in ref_names[1:] if n not in known]
        if strangers:
            return (f"{m.name}_ref.csv has column(s) that are not variables of the FMU: {', '.join(strangers[:5])}"
                    f"{' ...' if len(strangers) > 5 else ''} (cross-check rules, appendix B: \"All variable names are "
                    f"exactly the same as defined in the modelDescription.xml\"): nothing to judge them by")
        plat, ext = host_platform()
        binary = unzipdir / "binaries" / plat / f"{md.coSimulation.modelIdentifier}{ext}"
        if not binary.is_file():
            return f"no binaries/{plat}/{binary.name} in the FMU"
        try:
            _, missing, _ = unresolved_symbols(binary)
        except Exception:   # not an ELF file we can read: let the run tell
            missing = []
        if missing:
            return (f"{binary.name} needs {', '.join(missing)}, which neither the FMU nor this machine has: it "
                    f"cannot be loaded, no FMI call made (FMI 2.0 2.3: \"Dynamic link libraries must include all "
                    f"referenced resources that are not available on a standard target machine\"; cross-check "
                    f"rules 9.1.3)")
    except Exception as e:  # an unreadable model description
        return f"modelDescription.xml cannot be read: {type(e).__name__}: {e}"
    finally:
        shutil.rmtree(unzipdir, ignore_errors=True)
    return None


def _judge(m: Model, out_csv: Path) -> tuple[str, str]:
    opts = read_ref_opt(m.side("_ref.opt"))
    try:
        names, rows = read_cross_check_csv(out_csv)
        ref_names, ref_rows = read_cross_check_csv(m.side("_ref.csv"))
    except CsvFormatError as e:
        return "failed", f"a CSV cannot be read: {e}"
    v = judge(names, rows, ref_names, ref_rows, opts["StartTime"], opts["StopTime"])
    return ("passed" if v.passed else "failed"), v.reason


def run_model(m: Model, host: str, out_root: Path, timeout: float) -> Row:
    """Run, judge and file one model in one host."""
    from ..processes.isolation import run_isolated
    from ..archive import ArchiveError, extract
    t0 = time.perf_counter()
    name, ver = importer(host)
    i = m.info
    folder = out_root.joinpath(i["fmi_version"], i["fmi_type"], i["platform"], name, ver, i["tool"], i["tool_version"],
                               m.name)
    folder.mkdir(parents=True, exist_ok=True)
    out_csv = folder / f"{m.name}_out.csv"
    for stale in [*(folder / v for v in VERDICTS), out_csv, folder / "README.txt"]:   # a planted link is not followed
        if stale.is_file() or stale.is_symlink():
            stale.unlink()
    opts = {}
    why = _why_not_run(m)
    if why:
        verdict, reason = "rejected", why
    else:
        opts = read_ref_opt(m.side("_ref.opt"))
        ref_names, _ = read_cross_check_csv(m.side("_ref.csv"))
        unzipdir = extract(m.fmu)
        try:
            payload = {"fmu": str(unzipdir), "host": host, "out_csv": str(out_csv),
                       "opt": [opts["StartTime"], opts["StopTime"], opts["StepSize"], opts["RelTol"]],
                       "in_csv": str(m.side("_in.csv")) if m.side("_in.csv").is_file() else None,
                       "columns": ref_names[1:]}
            status, reason, _ = run_isolated("reference", payload, timeout)
        except ArchiveError as e:
            status, reason = "FAIL", str(e)
        finally:
            shutil.rmtree(unzipdir, ignore_errors=True)
        if status != "PASS":
            verdict, reason = "failed", f"the run failed: {reason}"
        else:
            verdict, reason = _judge(m, out_csv)
    (folder / verdict).write_bytes(b"")
    _readme(folder / "README.txt", m, host, (name, ver), opts, verdict, reason)
    return Row(m, host, verdict, reason, folder, time.perf_counter() - t0)


def _readme(path: Path, m: Model, host: str, imp: tuple[str, str], opts: dict, verdict: str, reason: str) -> None:
    lines = [f"{m.name} ({m.info['tool']} {m.info['tool_version']}) imported by {imp[0]} {imp[1]}: {verdict}", "",
             f"Run by `spurdiff check --cross-check` in its `{host}` host (harness/check/crosscheck/xcheck_host.py),",
             "judged by the cross-check suite's rule (harness/check/crosscheck/band.py).", ""]
    if opts:
        lines.append("Options (_ref.opt): " + ", ".join(f"{k} {opts[k]!r}" for k in ("StartTime", "StopTime",
                                                                                      "StepSize", "RelTol")))
        lines.append(f"Inputs: {m.name}_in.csv" if m.side("_in.csv").is_file() else "Inputs: none")
    lines += ["", f"Reason: {reason}", ""]
    path.write_text("\n".join(lines), encoding="utf-8")


def run_cross_check(root: str | Path, out_root: str | Path, hosts: Sequence[str] = HOSTS, timeout: float = 600.0,
                    jobs: int = 1) -> list[Row]:
    """Every model under ``root`` in every host; rows in model then host order."""
    models = find_models(root)
    out_root = Path(out_root)
    jobs_list = [(m, h) for m in models for h in hosts]
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        return list(pool.map(lambda mh: run_model(mh[0], mh[1], out_root, timeout), jobs_list))


def verdict_table(rows: Sequence[Row]) -> str:
    """The verdict table (markdown)."""
    hosts = list(dict.fromkeys(r.host for r in rows))
    lines = ["| exporter | model | " + " | ".join(hosts) + " | reason (first host that did not pass) |",
             "|---|---|" + "---|" * len(hosts) + "---|"]
    by_model: dict[Path, list[Row]] = {}
    for r in rows:
        by_model.setdefault(r.model.folder, []).append(r)
    for folder, rs in by_model.items():
        m = rs[0].model
        cells = {r.host: r.verdict for r in rs}
        bad = next((r for r in rs if r.verdict != "passed"), None)
        reason = (f"{bad.host}: {bad.reason}" if bad else rs[0].reason)
        reason = reason if len(reason) <= 160 else reason[:157] + "..."
        lines.append(f"| {m.info['tool']} {m.info['tool_version']} | {m.name} | "
                     + " | ".join(cells.get(h, "") for h in hosts) + f" | {reason.replace('|', '/')} |")
    counts = {h: {v: sum(1 for r in rows if r.host == h and r.verdict == v) for v in VERDICTS} for h in hosts}
    lines.append("")
    lines += [f"{h}: " + ", ".join(f"{n} {v}" for v, n in counts[h].items()) for h in hosts]
    return "\n".join(lines)


__all__ = ["HOSTS", "Model", "Row", "find_models", "run_cross_check", "run_model", "verdict_table"]
