"""Comparing an importer's result with a reference result (cross-check CSV files).

:func:`suite_checks` (``spurdiff check --compare``, the default) judges by the FMI cross-check suite's
rule (:mod:`.band`: the band, 10 % of the samples, every column, StopTime of ``_ref.opt`` reached), the
rule ``--cross-check`` applies. :func:`compare_results` (``--compare --rule tube``, or with ``--rtol``,
``--atol``, ``--tolerance``) is a stricter per-sample tube for a reference of one's own: it judges an importer's result CSV column by column against a reference:
the result is interpolated linearly onto the reference time points, and sample i of column c
passes when ``|y_i - y_ref,i| <= atol_c + rtol_c |y_ref,i|``. ``rtol_c`` defaults to 1e-3;
``atol_c`` defaults to ``rtol_c * max_i |y_ref,i|`` (so a signal crossing zero is not judged
by a vanishing relative band), floored at 1e-12; both can be set for all columns or per column.
At a time that appears twice (an event) the result's left or right limit may match.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

from .band import ColumnVerdict
from .formats import read_cross_check_csv
from ..report import FAIL, PASS, CheckResult

DEFAULT_RTOL = 1e-3
ATOL_FLOOR = 1e-12


@dataclass(frozen=True)
class Tolerance:
    """Per-column tolerance: relative ``rtol`` and absolute ``atol`` (None: rtol x column peak)."""

    rtol: float = DEFAULT_RTOL
    atol: float | None = None


@dataclass(frozen=True)
class ColumnComparison(ColumnVerdict):
    """Outcome for one reference column by the tube: a column verdict (``share_outside``: of the
    reference's samples) with the largest error and the number of samples outside."""

    max_error: float = math.nan
    samples_outside: int = 0


def _limits(t, y):
    """Left- and right-limit copies of a sampled signal with repeated time points (events)."""
    import numpy as np
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    keep_first = np.r_[True, np.diff(t) > 0]
    keep_last = np.r_[np.diff(t) > 0, True]
    return (t[keep_first], y[keep_first]), (t[keep_last], y[keep_last])


def compare_results(result_csv: str | Path, reference_csv: str | Path, rtol: float = DEFAULT_RTOL,
                    atol: float | None = None,
                    per_column: Mapping[str, Tolerance] | None = None) -> list[ColumnComparison]:
    """Compare every non-time column of ``reference_csv`` with the same column of ``result_csv``
    (see the module docstring for the rule). Raises CsvFormatError for unreadable files."""
    import numpy as np
    per_column = dict(per_column or {})
    res_names, res_rows = read_cross_check_csv(result_csv)
    ref_names, ref_rows = read_cross_check_csv(reference_csv)
    R = np.asarray(res_rows, dtype=float)
    F = np.asarray(ref_rows, dtype=float)
    t_ref, t_res = F[:, 0], R[:, 0]
    span = max(abs(t_ref[-1] - t_ref[0]), 1e-300)
    eps = 1e-9 * max(span, 1.0)
    covered = t_res[0] <= t_ref[0] + eps and t_res[-1] >= t_ref[-1] - eps
    out: list[ColumnComparison] = []
    for k, name in enumerate(ref_names[1:], 1):
        tol = per_column.get(name, Tolerance(rtol, atol))
        if name not in res_names:
            out.append(ColumnComparison(name, False, "column missing from the result"))
            continue
        if not covered:
            out.append(ColumnComparison(name, False, f"the result covers t = {t_res[0]:g} .. {t_res[-1]:g} s, "
                                                     f"the reference {t_ref[0]:g} .. {t_ref[-1]:g} s"))
            continue
        y_ref = F[:, k]
        (tl, yl), (tr, yr) = _limits(t_res, R[:, res_names.index(name)])
        y_left = np.interp(t_ref, tl, yl)
        y_right = np.interp(t_ref, tr, yr)
        finite_ref = y_ref[np.isfinite(y_ref)]
        peak = float(np.max(np.abs(finite_ref))) if finite_ref.size else 0.0
        a = tol.atol if tol.atol is not None else max(tol.rtol * peak, ATOL_FLOOR)
        allowed = a + tol.rtol * np.abs(y_ref)
        with np.errstate(invalid="ignore"):
            err = np.fmin(np.abs(y_left - y_ref), np.abs(y_right - y_ref))
            both_nan = np.isnan(y_ref) & (np.isnan(y_left) | np.isnan(y_right))
            err = np.where(both_nan, 0.0, err)
            err = np.where(np.isnan(err), np.inf, err)  # NaN on one side only
            outside = err > allowed
            y_best = np.where(np.abs(y_left - y_ref) <= np.abs(y_right - y_ref), y_left, y_right)
        n_out = int(outside.sum())
        i = int(np.argmax(err - allowed))
        rule = f"|error| <= {a:.3g} + {tol.rtol:.3g} |ref|"
        if n_out:
            reason = (f"{n_out} of {len(t_ref)} samples outside {rule}; worst at t = {t_ref[i]:g} s: "
                      f"result {float(y_best[i])!r} vs reference {float(y_ref[i])!r} (|error| {err[i]:.3g} > {allowed[i]:.3g})")
        else:
            i = int(np.argmax(err))
            reason = f"max |error| {float(err[i]):.3g} at t = {t_ref[i]:g} s; all {len(t_ref)} samples within {rule}"
        out.append(ColumnComparison(name, n_out == 0, reason, n_out / len(t_ref), float(np.max(err)), n_out))
    return out


def compare_checks(result_csv: str | Path, reference_csv: str | Path, rtol: float = DEFAULT_RTOL,
                   atol: float | None = None, per_column: Mapping[str, Tolerance] | None = None,
                   subject: str | None = None) -> list[CheckResult]:
    """:func:`compare_results` as report lines: one ``compare.<column>`` check per column."""
    subject = subject if subject is not None else str(result_csv)
    return [CheckResult(subject, f"compare.{c.name}", PASS if c.passed else FAIL, c.reason)
            for c in compare_results(result_csv, reference_csv, rtol, atol, per_column)]


# ----------------------------------------------------------------------------- the cross-check suite's rule

def opt_beside(reference_csv: str | Path) -> Path | None:
    """``<Model>_ref.opt`` beside ``<Model>_ref.csv`` (the cross-check layout), if there is one."""
    ref = Path(reference_csv)
    if ref.name.endswith("_ref.csv"):
        opt = ref.with_name(ref.name[: -len("_ref.csv")] + "_ref.opt")
        if opt.is_file():
            return opt
    return None


def suite_checks(result_csv: str | Path, reference_csv: str | Path, ref_opt: str | Path | None = None,
                 subject: str | None = None) -> list[CheckResult]:
    """The cross-check suite's verdict (:mod:`.band`) as report lines: ``compare.run`` (two samples, start
    and stop time reached, every reference column present) and one ``compare.<column>`` per column.
    StartTime / StopTime come from ``ref_opt`` (default: the ``_ref.opt`` beside the reference); without
    one, from the reference, its last time taken as reached within the rounding of how it is printed.
    Raises CsvFormatError for unreadable files."""
    from .band import judge, printed_rounding
    from .formats import last_time_text, read_ref_opt
    subject = subject if subject is not None else str(result_csv)
    names, rows = read_cross_check_csv(result_csv)
    ref_names, ref_rows = read_cross_check_csv(reference_csv)
    opt = Path(ref_opt) if ref_opt is not None else opt_beside(reference_csv)
    if opt is not None:
        o = read_ref_opt(opt)
        v = judge(names, rows, ref_names, ref_rows, o["StartTime"], o["StopTime"])
        source = f"StartTime {o['StartTime']:g} s, StopTime {o['StopTime']:.9g} s from {opt.name}"
    else:
        v = judge(names, rows, ref_names, ref_rows, stop_rounding=printed_rounding(last_time_text(reference_csv)))
        source = "start and stop time from the reference (no _ref.opt)"
    if not v.columns:
        return [CheckResult(subject, "compare.run", FAIL, f"{v.reason} ({source})")]
    out = [CheckResult(subject, "compare.run", PASS, f"{len(rows)} samples; {source}")]
    out += [CheckResult(subject, f"compare.{c.name}", PASS if c.passed else FAIL, c.reason) for c in v.columns]
    return out
