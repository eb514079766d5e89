"""One case per FMU for the host tests (constant inputs as start values; fmpy gives the reference), and
what those tests share: where the ecos command line is and reading its results (never a run whose FMU
failed), building our C hosts (tests/c_host/), reading a host's CSV and comparing it with fmpy's."""
from __future__ import annotations

import csv
import re
import subprocess
from pathlib import Path

import numpy as np

C_HOSTS = Path(__file__).resolve().parents[1] / "c_host"
MINGW = "x86_64-w64-mingw32-gcc"

STOP, STEP = 0.05, 1e-3
CASES = {
    "SpurDifferential": {"carrier.w_ref": 1.389, "left.tau": -1050.0, "right.tau": -1040.0},
    "WheelLoad": {"flange.w": 30.0, "Fz": 4000.0, "mu": 0.9, "vx": 10.0},
    "Vehicle": {"rearLeft.Fx": 500.0, "rearRight.Fx": 480.0, "speedTarget": 10.0, "pathRadius": 20.0},
}


def build_c_host(name: str, exe: Path, windows: bool = False) -> Path:
    """Our C host tests/c_host/``name``.c (fmi2_any_host or fmi3_host) built into ``exe`` against the FMI
    headers fmpy ships: with gcc for this machine, or with mingw-w64 for 64-bit Windows (``windows``: a
    static .exe that reads its arguments as UTF-16)."""
    import fmpy
    include, src = Path(fmpy.__file__).parent / "c-code", C_HOSTS / f"{name}.c"
    if windows:
        cmd = [MINGW, "-O2", "-Wall", "-municode", "-D__USE_MINGW_ANSI_STDIO=1", "-static", f"-I{include}", "-o", str(exe),
               str(src)]
    else:
        cmd = ["gcc", "-O2", "-Wall", f"-I{include}", "-o", str(exe), str(src), "-ldl", "-lm"]
    subprocess.run(cmd, check=True)
    return exe


def ecos_binary() -> Path | None:
    """The ecos command line of the ecospy wheel, None where it is missing or its libraries are (ldd)."""
    try:
        import ecospy
    except (ImportError, OSError):
        return None
    exe = Path(ecospy.__file__).parent / "binaries" / "ecos"
    if not exe.is_file():
        return None
    r = subprocess.run(["ldd", str(exe)], capture_output=True, text=True)
    return exe if "not found" not in r.stdout else None


# ecos logs its FMUs' messages (where a failed fmi2Instantiate says why) at debug level only
ECOS_LOG = "-l debug"
# what the container runtime of fmu-manipulation-toolbox 2.0 logs with status fmi2Error on every run,
# a good one too (ecos: "fmi2Error Solver configure...."): not a failure
CONTAINER_NOISE = "Solver configure...."


def ecos_failure(log: str) -> str | None:
    """The first line of an ecos log that says an FMU failed: a message an FMU logged with status Error
    or Fatal (at ``ECOS_LOG`` only; FMI 2.0 ``fmi2Error fmi2Instantiate: <reason>``, FMI 3.0
    ``[instance] Error fmi3InstantiateCoSimulation: <reason>``) or an error of ecos's own; None if none."""
    for line in log.splitlines():
        failed = re.search(r"\bfmi2(Error|Fatal) |\] (Error|Fatal) |\[(error|critical)\]", line)
        if failed and CONTAINER_NOISE not in line:
            return line.strip()
    return None


def read_ecos_csv(path: Path, log: str, what: str) -> dict[str, np.ndarray]:
    """ecos's CSV result, its columns named as the FMU's variables (``instance::x[REAL]`` -> ``x``), after
    checking the run: ecos exits 0 and writes a CSV of zeros when an FMU's instantiation failed (it goes on
    calling the FMU with a NULL instance). Fails naming the log line that says an FMU failed
    (:func:`ecos_failure`: run ecos with ``ECOS_LOG``), or, where the log says nothing, when every value
    ecos wrote is zero (nothing came from the FMU)."""
    failed = ecos_failure(log)
    assert failed is None, f"{what}: ecos exited 0, but its log says an FMU failed: {failed}"
    got = {k.split("::", 1)[-1].split("[", 1)[0]: v for k, v in read_csv(path).items()}
    values = [v for n, v in got.items() if n not in ("time", "iterations")]
    assert any(np.any(v != 0.0) for v in values), \
        f"{what}: ecos exited 0, but every value it wrote ({len(values)} columns) is 0: nothing came from the FMU"
    return got


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """A host's CSV result: its numeric columns by name (quotes and blanks stripped from the names)."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    names = [n.strip().strip('"') for n in rows[0]]
    out = {}
    for i, n in enumerate(names):
        try:
            out[n] = np.array([float(r[i]) for r in rows[1:] if r], dtype=float)
        except ValueError:
            continue
    return out


def compare(got: dict, ref: dict, what: str, tol: float = 1e-9):
    """The host's columns against fmpy's at the times both wrote (a host may also write t = 0), to ``tol``
    (relative and absolute)."""
    t_ref = ref["time"]
    common = [n for n in got if n in ref and n != "time"]
    assert len(common) >= 3, f"{what}: too few common columns ({common})"
    idx = np.searchsorted(got["time"], t_ref - 1e-12)
    ok = (idx < len(got["time"])) & (np.abs(got["time"][np.minimum(idx, len(got["time"]) - 1)] - t_ref) < 1e-9)
    assert ok.sum() >= int(STOP / STEP), f"{what}: the host wrote {len(got['time'])} rows"
    for n in common:
        g, r = got[n][idx[ok]], ref[n][ok]
        assert np.allclose(g, r, rtol=tol, atol=tol), f"{what}: {n} differs from fmpy by {np.max(np.abs(g - r)):.3g}"
