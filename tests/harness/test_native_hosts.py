"""The native step in a C host (fmusim from ../shared/hosts, bare environment: the FMU's own Python):
Vehicle and WheelLoad, FMI 2.0 and 3.0, with inputs changing over the run from a file, give the
same results with solver.nativeStep true (the whole step in C, no Python while the host only steps
and sets and gets) as with false, to the last digit fmusim writes; in FMI 3.0 also with early return
allowed (every step through the bridge's Python path then)."""
from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parents[1]   # tests/
HOSTS = HERE.parent.parent / "shared" / "hosts"
BARE_ENV = {"PATH": "/usr/bin:/bin"}

pytestmark = pytest.mark.skipif(not (HOSTS / "fmusim").is_file(), reason=f"{HOSTS}/fmusim is absent")

INPUTS = {   # a CSV input file per FMU: the inputs change at every row
    "Vehicle": ("rearLeft.Fx", "rearRight.Fx", "speedTarget"),
    "WheelLoad": ("flange.w", "Fz", "vx"),
}


def _input_file(fmu: str, out: Path) -> Path:
    rows = ["time," + ",".join(INPUTS[fmu])]
    for i in range(101):
        t = 0.01 * i
        if fmu == "Vehicle":
            rows.append(f"{t:.2f},{500.0 + 3.0 * i},{480.0 - 2.0 * i},{10.0 + 0.02 * i}")
        else:
            rows.append(f"{t:.2f},{30.0 + 0.1 * i},{4000.0 + 5.0 * i},{10.0 + 0.01 * i}")
    out.write_text("\n".join(rows) + "\n")
    return out


def _run(fmu_path: Path, fmu: str, cwd: Path, native: bool, fmi3: bool, early: bool = False) -> str:
    out = cwd / f"o-{native}-{fmi3}-{early}.csv"
    cmd = [str(HOSTS / "fmusim"), "--interface-type", "cs", "--stop-time", "1", "--output-interval", "0.005",
           "--input-file", str(_input_file(fmu, cwd / "in.csv")), "--start-value", "solver.nativeStep",
           "true" if native else "false", "--output-file", str(out)]
    if early:
        cmd.append("--early-return-allowed")
    r = subprocess.run(cmd + [str(fmu_path)], cwd=cwd, env=BARE_ENV, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    text = out.read_text()
    assert len(text.splitlines()) == 202          # the header and 201 rows
    return text


@pytest.mark.parametrize("fmi3", [False, True], ids=["fmi2", "fmi3"])
@pytest.mark.parametrize("fmu", list(INPUTS))
def test_native_step_in_a_c_host_gives_the_python_steps_results(fmu, fmi3, fmu_files, tmp_path):
    path = fmu_files[fmu]
    if fmi3:
        path = path.with_name(f"{fmu}-fmi3.fmu")
        assert path.is_file(), path
    native = _run(path, fmu, tmp_path, True, fmi3)
    assert native == _run(path, fmu, tmp_path, False, fmi3)
    if fmi3:
        assert native == _run(path, fmu, tmp_path, True, fmi3, early=True)
