"""Results of a run: statistics, the scene's checks, the results table and the CSV file."""
from __future__ import annotations

import csv
import errno
import math
import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from harness.run.result import Result
from harness.scene.spec import SceneError
from harness.scene import theory
from harness.scene.expressions import compile_expression, is_expression


def window_mask(t: np.ndarray, window) -> np.ndarray:
    if not window:
        return np.ones_like(t, dtype=bool)
    lo, hi = float(window[0]), float(window[1])
    return (t >= lo - 1e-12) & (t <= hi + 1e-12)


def series(result: Result, quantity: str) -> np.ndarray:
    """A recorded variable, or an expression over recorded variables in braces
    (checked and evaluated by :mod:`harness.scene.expressions`, never ``eval``)."""
    if not is_expression(quantity):
        return theory.series(result, quantity) if quantity.startswith(theory.PREFIX) else result[quantity]
    expr = compile_expression(quantity, f"scene {result.scene.name}: quantity")

    def get(name: str):     # a recorded variable, or a theory value from the run's parameters
        return theory.series(result, name) if name.startswith(theory.PREFIX) else result[name]
    return np.broadcast_to(np.asarray(expr(get), dtype=float), result.time.shape)


def stat(result: Result, name: str, kind: str, window=None) -> float:
    """mean | max | min | final | absmax | span of a recorded quantity over a time window.

    The mean is the time average (trapezoidal rule), so it does not depend on the sampling."""
    t = result.time
    y = series(result, name)
    m = window_mask(t, window)
    t, y = t[m], y[m]
    if len(y) == 0:
        return float("nan")
    if kind == "mean":
        return float(np.trapezoid(y, t) / (t[-1] - t[0])) if len(y) > 1 and t[-1] > t[0] else float(y[0])
    if kind == "max":
        return float(np.max(y))
    if kind == "min":
        return float(np.min(y))
    if kind == "final":
        return float(y[-1])
    if kind == "absmax":
        return float(np.max(np.abs(y)))
    if kind == "span":
        return float(np.max(y) - np.min(y))
    raise ValueError(kind)


@dataclass
class CheckOutcome:
    name: str
    passed: bool
    value: float
    expectation: str


def evaluate_checks(result: Result) -> list[CheckOutcome]:
    out = []
    level = str(result.scene.effects.get("meshModel", "rigid"))
    for c in result.scene.checks:
        if "fidelity" in c and level not in c["fidelity"]:   # the check states where it holds
            out.append(CheckOutcome(c.get("name", c["var"]), True, float("nan"),
                                    f"not checked at meshModel = {level} (holds at {', '.join(c['fidelity'])})"))
            continue
        w, end = c.get("window"), result.scene.duration
        if w and float(w[0]) > end * (1 + 1e-9):   # a run shortened by --duration ends before the window
            out.append(CheckOutcome(c.get("name", c["var"]), True, float("nan"),
                                    f"not checked: window [{float(w[0]):g}, {float(w[1]):g}] s starts after "
                                    f"this run's end ({end:g} s)"))
            continue
        v = stat(result, c["var"], c["stat"], c.get("window"))
        ok = np.isfinite(v)
        parts = []
        if "expect" in c or "expect_var" in c:
            target = float(c["expect"]) if "expect" in c else stat(result, c["expect_var"], c["stat"], c.get("window"))
            tol = float(c.get("atol", 0.0)) + float(c.get("rtol", 0.0)) * abs(target)
            ok = ok and abs(v - target) <= tol
            parts.append(f"{target:.6g} +- {tol:.3g}")
        if "below" in c:
            ok = ok and v < float(c["below"])
            parts.append(f"< {c['below']}")
        if "above" in c:
            ok = ok and v > float(c["above"])
            parts.append(f"> {c['above']}")
        if w and float(w[1]) > end * (1 + 1e-9):
            parts.append(f"over [{float(w[0]):g}, {end:g}] s: the run ends inside the window")
        out.append(CheckOutcome(c.get("name", c["var"]), bool(ok), v, ", ".join(parts)))
    return out


def _pct(ours: float, ref: float) -> str:
    if ref == 0 or not np.isfinite(ours):
        return "-"
    return f"{100.0 * (ours - ref) / abs(ref):+.2f} %"


def format_table(result: Result) -> str:
    """The scene's results table: our mean/max/min beside the paper (ADAMS) and the theory."""
    rows = result.scene.table
    if not rows:
        return ""
    head = ["quantity", "unit", "ours mean", "ours max", "ours min", "ADAMS mean", "theory",
            "ours vs theory", "ADAMS vs theory"]
    lines = []
    for r in rows:
        s = float(r.get("scale", 1.0))
        w = r.get("window")
        mean = stat(result, r["var"], "mean", w) * s
        mx = stat(result, r["var"], "max", w) * s
        mn = stat(result, r["var"], "min", w) * s
        paper = r.get("paper")
        theory = r.get("theory")
        if isinstance(theory, str):
            theory = stat(result, theory, "mean", w) * s
        lines.append([r["label"], r.get("unit", ""), num(mean), num(mx), num(mn),
                      num(paper) if paper is not None else "-",
                      num(theory) if theory is not None else "-",
                      _pct(mean, theory) if theory is not None else "-",
                      _pct(paper, theory) if (paper is not None and theory is not None) else "-"])
    # columns that are empty on every row (no ADAMS data in the vehicle scenes) are left out
    keep = [i for i in range(len(head)) if i < 5 or any(line[i] != "-" for line in lines)]
    return render([head[i] for i in keep], [[line[i] for i in keep] for line in lines])


def num(x: float) -> str:
    """Thousands separators for large values, four significant digits for small ones."""
    return f"{x:,.0f}" if abs(x) >= 1000 else f"{x:.4g}"


def render(head: list[str], lines: list[list[str]]) -> str:
    widths = [max(len(str(x)) for x in col) for col in zip(head, *lines)]
    def fmt(row):
        return "  ".join(str(x).rjust(w) if i > 1 else str(x).ljust(w) for i, (x, w) in enumerate(zip(row, widths)))
    sep = "  ".join("-" * w for w in widths)
    return "\n".join([fmt(head), sep] + [fmt(r) for r in lines])


def format_checks(outcomes: list[CheckOutcome]) -> str:
    return "\n".join(f"N/A   {o.name}: {o.expectation}" if o.expectation.startswith("not checked") else
                     f"{'PASS' if o.passed else 'FAIL'}  {o.name}: {o.value:.6g} (expected {o.expectation})"
                     for o in outcomes)


RESIDUAL_WARN = 0.01   # coupling energy residual, relative to the work transferred


def _residual(e: dict[str, float]) -> tuple[float, float]:
    """Energy residual of a coupling (work given minus received) and the work it is relative to."""
    wf, wt = e["work_from"], e["work_to"]
    return wf - wt, max(abs(wf), abs(wt), 1e-12)


def coupling_warnings(result: Result, limit: float = RESIDUAL_WARN) -> list[str]:
    """Couplings whose energy residual exceeds ``limit`` of the work they transferred: the
    communication step is too coarse for the coupling's stiffness (or the run diverged)."""
    out = []
    for name, e in result.coupling_energy.items():
        res, ref = _residual(e)
        rel = abs(res) / ref if math.isfinite(res) else math.inf
        if rel > limit:
            out.append(f"WARNING coupling {name}: energy residual {100 * rel:.3g} % of the work transferred "
                       f"(limit {100 * limit:g} %) at step {result.scene.step:g} s ({result.scene.algorithm}): the "
                       "communication step is too coarse for this coupling; reduce it"
                       + (" or use gauss-seidel" if result.scene.algorithm == "jacobi" else ""))
    return out


def format_couplings(result: Result) -> str:
    lines = []
    for name, e in result.coupling_energy.items():
        res, ref = _residual(e)
        lines.append(f"coupling {name}: work given {e['work_from']:.6g} J, received {e['work_to']:.6g} J, "
                     f"residual {res:+.3g} J ({100 * res / ref:+.3f} %)")
    return "\n".join(lines + coupling_warnings(result))


def writable_dir(path: Path, label: str) -> Path:
    """Make sure results can be written into folder ``path`` (created if missing) before a run
    starts; else a one-line SceneError naming ``label``."""
    path = Path(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(dir=path, prefix=".spurdiff-write-test-")
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        code = f" [errno {e.errno} {errno.errorcode.get(e.errno, '?')}]" if e.errno else ""
        raise SceneError(f"{label} = {str(path)!r}: cannot write there ({e.strerror or e}){code}; "
                         "allowed: a folder you can write") from None
    return path


class CsvStream:
    """Recorded rows to a CSV file as they come (the same format as :func:`write_csv`), flushed at
    least every ``flush_every`` s of wall time and on close: an interrupted or killed run keeps what
    it recorded. The file is created at the first row (:class:`harness.common.outputs.StreamFile`: never
    through a link planted there), so a run refused before it starts leaves an earlier file in
    place. A write error raises :class:`harness.common.outputs.OutputError` (place, errno, rows kept)."""

    def __init__(self, path: Path, header: list[str], flush_every: float = 0.5):
        self.path, self.header, self.flush_every = Path(path), list(header), flush_every
        self.fh = None
        self.rows = 0
        self._last = 0.0

    def write(self, row) -> None:
        from harness.common.outputs import StreamFile

        if self.fh is None:
            self.fh = StreamFile(self.path)
            self._w = csv.writer(self.fh)
            self._w.writerow(self.header)
        self._w.writerow([repr(float(x)) for x in row])
        self.rows += 1
        now = time.monotonic()
        if now - self._last >= self.flush_every:
            self.fh.flush()
            self._last = now

    def close(self) -> None:
        if self.fh is not None:
            fh, self.fh = self.fh, None
            fh.close()

    def __enter__(self) -> "CsvStream":
        return self

    def __exit__(self, *exc) -> None:
        if exc[0] is None:
            self.close()
        else:   # the first error stands; a second one while closing would hide it
            try:
                self.close()
            except Exception:
                pass


def write_csv(result: Result, path: Path) -> Path:
    from harness.common.outputs import atomic_file

    with atomic_file(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time"] + result.names)
        for row in result.data:
            w.writerow([repr(float(x)) for x in row])
    return path
