"""The FMI cross-check suite's rule for judging a result against a reference result (the band).

The suite (modelica/fmi-cross-check, FMI-CROSS-CHECK-RULES.md 9.1.4 and 9.2; the validation of submitted
results that fmpy ships for it, ``fmpy.cross_check.validate_result``) passes a result when

1. it has at least two samples;
2. it starts at or before ``StartTime`` and ends at or after ``StopTime`` of ``_ref.opt`` (the options,
   not the reference's own last time, which an exporter may have rounded: TorsionBar's reference ends at
   12.5664 s for a StopTime of 12.5663706143592 s);
3. every column of the reference is in the result (Booleans as 0/1, Integers as numbers);
4. for every column, at most 10 % of the result's samples lie outside the band: the reference resampled
   linearly onto 1000 points from StartTime to StopTime (at a time the reference repeats, an event, its
   first row, the value before the event), widened sideways to the lowest and highest value among 21
   neighbouring points (10 points, 1 % of the span, on either side: an event one sample early or late
   stays inside) and up and down by 10 % of the resampled reference's range (of its magnitude when it is
   constant; 0.5 when it is constantly 0). Only result samples from StartTime to StopTime can be
   outside; the share is of all the result's samples.

Where this module goes further than the suite, it says so in the reason: a NaN in the result is outside
the band (the suite's comparisons let it through), and StopTime counts as reached within 1e-9 of the
span (a result's last time summed from steps may miss it by a rounding error).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

BAND_POINTS = 1000      # points of the resampled reference
BAND_WINDOW = 21        # neighbouring points the band is widened over (10 on either side)
BAND_HEIGHT = 0.1       # of the reference's range
ZERO_HEIGHT = 0.5       # band half-height around a reference that is constantly 0
MAX_SHARE = 0.1         # of the result's samples a column may have outside the band
TIME_EPS = 1e-9         # of the span: StartTime / StopTime reached


@dataclass(frozen=True)
class ColumnVerdict:
    """One reference column: passed, why, and the share of the result's samples outside the band."""

    name: str
    passed: bool
    reason: str
    share_outside: float = math.nan


@dataclass(frozen=True)
class Verdict:
    """The whole result: passed, the first reason it failed (or a summary) and every column's verdict."""

    passed: bool
    reason: str
    columns: tuple[ColumnVerdict, ...] = ()


def _band(t_ref, y_ref, t_start: float, t_stop: float):
    """(band times, lower, upper) of one reference column (see the module docstring)."""
    import numpy as np
    from numpy.lib.stride_tricks import sliding_window_view
    t_ref = np.asarray(t_ref, dtype=float)
    y_ref = np.asarray(y_ref, dtype=float)
    first = np.r_[True, np.diff(t_ref) > 0]          # at a repeated time: the row before the event
    t_band = np.linspace(t_start, t_stop, BAND_POINTS)
    y_band = np.interp(t_band, t_ref[first], y_ref[first])
    lo, hi = float(np.min(y_band)), float(np.max(y_band))
    if lo == hi:
        w = ZERO_HEIGHT if lo == 0 else abs(lo) * BAND_HEIGHT
    else:
        w = (hi - lo) * BAND_HEIGHT
    half = BAND_WINDOW // 2
    padded = np.pad(y_band, half, mode="symmetric")
    windows = sliding_window_view(padded, BAND_WINDOW)
    return t_band, windows.min(axis=1) - w, windows.max(axis=1) + w


def judge_column(name: str, t, y, t_ref, y_ref, t_start: float, t_stop: float) -> ColumnVerdict:
    """One column of the result (``t``, ``y``) against the reference's (``t_ref``, ``y_ref``)."""
    import numpy as np
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    finite_ref = np.isfinite(np.asarray(y_ref, dtype=float))
    if not finite_ref.all():
        return ColumnVerdict(name, False, "the reference column has NaN or infinite values: it cannot be judged")
    t_band, y_min, y_max = _band(t_ref, y_ref, t_start, t_stop)
    lower = np.interp(t, t_band, y_min)
    upper = np.interp(t, t_band, y_max)
    inside_time = (t >= t_start) & (t <= t_stop)
    with np.errstate(invalid="ignore"):
        outside = ((y < lower) | (y > upper) | np.isnan(y)) & inside_time
    n_out = int(outside.sum())
    share = n_out / float(len(t))
    if n_out:
        i = int(np.argmax(outside))
        where = f"first at t = {t[i]:.6g} s: {float(y[i])!r} outside [{lower[i]:.6g}, {upper[i]:.6g}]"
    else:
        where = "every sample inside the band"
    verdict = share <= MAX_SHARE
    return ColumnVerdict(name, verdict, f"{n_out} of {len(t)} samples ({100 * share:.1f} %) outside the band"
                                        f"{' (more than 10 %)' if not verdict else ''}; {where}", share)


def judge(names: Sequence[str], rows: Sequence[Sequence[float]], ref_names: Sequence[str],
          ref_rows: Sequence[Sequence[float]], t_start: float | None = None, t_stop: float | None = None,
          stop_rounding: float = 0.0) -> Verdict:
    """The suite's verdict on a result (``names`` with "time" first, ``rows``) against a reference.

    ``t_start`` / ``t_stop``: StartTime / StopTime of ``_ref.opt``; when None, the reference's first /
    last time, its last time taken as reached ``stop_rounding`` early (half a unit of its last printed
    digit: see :func:`printed_rounding`)."""
    import numpy as np
    R = np.asarray(rows, dtype=float).reshape(len(rows), len(names))
    F = np.asarray(ref_rows, dtype=float).reshape(len(ref_rows), len(ref_names))
    t, t_ref = R[:, 0], F[:, 0]
    if t_start is None:
        t_start = float(t_ref[0])
    slack = 0.0
    if t_stop is None:
        t_stop, slack = float(t_ref[-1]), abs(stop_rounding)
    if len(t) < 2:
        return Verdict(False, f"the result has {len(t)} sample(s); at least 2 are needed")
    eps = TIME_EPS * max(abs(t_stop - t_start), 1e-300)
    if t[0] > t_start + eps:
        return Verdict(False, f"the result starts at t = {t[0]:.9g} s, after the start time {t_start:.9g} s")
    if t[-1] < t_stop - eps - slack:
        return Verdict(False, f"the result ends at t = {t[-1]:.9g} s, before the stop time {t_stop:.9g} s")
    missing = [n for n in ref_names[1:] if n not in names]
    if missing:
        return Verdict(False, f"reference column(s) missing from the result: {', '.join(missing[:8])}"
                              + (" ..." if len(missing) > 8 else ""))
    if t_stop - slack < t_start:
        return Verdict(False, f"the stop time {t_stop:.9g} s is before the start time {t_start:.9g} s")
    band_stop = min(t_stop, float(t[-1])) if slack else t_stop
    cols = tuple(judge_column(n, t, R[:, names.index(n)], t_ref, F[:, k], t_start, band_stop)
                 for k, n in enumerate(ref_names) if k > 0)
    failed = [c for c in cols if not c.passed]
    if failed:
        return Verdict(False, f"column {failed[0].name}: {failed[0].reason}", cols)
    worst = max(cols, key=lambda c: c.share_outside, default=None)
    summary = (f"{len(cols)} column(s), t = {t_start:.9g} .. {t_stop:.9g} s reached; "
               + (f"most outside: {worst.name} ({100 * worst.share_outside:.1f} %)" if worst else "no column to compare"))
    return Verdict(True, summary, cols)


def printed_rounding(literal: str) -> float:
    """Half a unit of the last digit of a number as printed (``"12.5664"`` -> 5e-05; ``"20"`` -> 0.5;
    ``"1.5E+01"`` -> 0.05 x 10): how far a rounded time may lie from the time it stands for."""
    s = literal.strip().lower()
    mant, _, exp = s.partition("e")
    try:
        e = int(exp) if exp else 0
    except ValueError:
        return 0.0
    decimals = len(mant.split(".", 1)[1]) if "." in mant else 0
    return 0.5 * 10.0 ** (e - decimals)
