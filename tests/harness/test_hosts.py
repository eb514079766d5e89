"""Our FMUs in FMI hosts nobody here wrote, and in our own C host, with a bare environment.

The hosts: the FMU Compliance Checker (``fmuCheck.linux64``) and the Reference FMUs' ``fmusim``
from ``../shared/hosts`` (skipped with that reason where the folder is absent), and
``tests/c_host/fmi2_host.c`` (compiled here). Each is started as a user would start it, with
``env -i PATH=/usr/bin:/bin`` (no LD_PRELOAD, PYTHONHOME or PYTHONPATH) from an unrelated working
directory, several times per FMU: every run must exit 0 (Python is never finalized in the host,
so no crash at exit) and give fmpy's numbers for the same case to 1e-9.
"""
from __future__ import annotations

import csv
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

HERE = Path(__file__).resolve().parents[1]   # tests/
HOSTS = HERE.parent.parent / "shared" / "hosts"
BARE_ENV = {"PATH": "/usr/bin:/bin"}
RUNS = 10
STOP, STEP = 0.05, 1e-3

# one case per FMU: constant inputs given as start values (fmusim) or an input file (fmuCheck)
CASES = {
    "SpurDifferential": {"carrier.w_ref": 1.389, "left.tau": -1050.0, "right.tau": -1040.0},
    "WheelLoad": {"flange.w": 30.0, "Fz": 4000.0, "mu": 0.9, "vx": 10.0},
    "Vehicle": {"rearLeft.Fx": 500.0, "rearRight.Fx": 480.0, "speedTarget": 10.0, "pathRadius": 20.0},
}

needs_hosts = pytest.mark.skipif(not HOSTS.is_dir(), reason=f"{HOSTS} is absent (third-party FMI hosts)")


def _read_csv(path: Path) -> dict[str, np.ndarray]:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    names = [n.strip().strip('"') for n in rows[0]]
    out = {}
    for i, n in enumerate(names):   # numeric columns only (ecos also writes String variables)
        try:
            out[n] = np.array([float(r[i]) for r in rows[1:] if r], dtype=float)
        except ValueError:
            continue
    return out


@pytest.fixture(scope="module")
def reference(fmu_files):
    """fmpy's run of each case (the same FMU, the same inputs, the same step)."""
    out = {}
    for name, inputs in CASES.items():
        res = simulate_fmu(str(fmu_files[name]), stop_time=STOP, output_interval=STEP, start_values=inputs)
        out[name] = {n: np.asarray(res[n], dtype=float) for n in res.dtype.names}
    return out


def _compare(name: str, got: dict[str, np.ndarray], ref: dict[str, np.ndarray], where: str,
             rtol: float = 1e-9, atol: float = 1e-9) -> None:
    t_ref = ref["time"]
    common = [n for n in got if n in ref and n != "time"]
    assert len(common) >= 5, f"{where}: too few common outputs {common}"
    # the hosts may also write t = 0; compare at the times both have
    idx = np.searchsorted(got["time"], t_ref - 1e-12)
    ok = (idx < len(got["time"])) & (np.abs(got["time"][np.minimum(idx, len(got["time"]) - 1)] - t_ref) < 1e-9)
    assert ok.sum() >= int(STOP / STEP), f"{where}: the host wrote {len(got['time'])} rows"
    for n in common:
        g, r = got[n][idx[ok]], ref[n][ok]
        assert np.allclose(g, r, rtol=rtol, atol=atol), (
            f"{where}: {n} differs from fmpy by {np.max(np.abs(g - r)):.3g}")


def _run(cmd: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, cwd=cwd, env=BARE_ENV, capture_output=True, text=True, timeout=120)


@needs_hosts
@pytest.mark.parametrize("name", list(CASES))
def test_fmusim_runs_our_fmu_with_a_bare_environment(name, fmu_files, reference, tmp_path):
    args = []
    for k, v in CASES[name].items():
        args += ["--start-value", k, repr(v)]
    for i in range(RUNS):
        out = tmp_path / f"out{i}.csv"
        r = _run([str(HOSTS / "fmusim"), "--interface-type", "cs", "--output-interval", str(STEP),
                  "--stop-time", str(STOP), *args, "--output-file", str(out), str(fmu_files[name])], tmp_path)
        assert r.returncode == 0, f"run {i + 1}/{RUNS}: exit {r.returncode}\n{r.stdout[-2000:]}{r.stderr[-2000:]}"
        _compare(name, _read_csv(out), reference[name], f"fmusim run {i + 1}")


@needs_hosts
@pytest.mark.parametrize("name", list(CASES))
def test_fmucheck_runs_our_fmu_with_a_bare_environment(name, fmu_files, reference, tmp_path):
    inputs = tmp_path / "inputs.csv"
    names = list(CASES[name])
    with open(inputs, "w") as f:
        f.write(",".join(["time", *names]) + "\n")
        for t in (0.0, STOP):
            f.write(",".join([repr(t), *(repr(CASES[name][n]) for n in names)]) + "\n")
    for i in range(RUNS):
        out = tmp_path / f"out{i}.csv"
        r = _run([str(HOSTS / "fmuCheck.linux64"), "-k", "cs", "-h", str(STEP), "-s", str(STOP),
                  "-i", str(inputs), "-o", str(out), str(fmu_files[name])], tmp_path)
        assert r.returncode == 0, f"run {i + 1}/{RUNS}: exit {r.returncode}\n{r.stdout[-3000:]}{r.stderr[-3000:]}"
        assert "0 Error(s)" in r.stdout + r.stderr, (r.stdout + r.stderr)[-3000:]
        _compare(name, _read_csv(out), reference[name], f"fmuCheck run {i + 1}")


@pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler")
def test_our_c_host_runs_the_fmu_with_a_bare_environment(differential_fmu, tmp_path):
    exe = tmp_path / "fmi2_host"
    subprocess.run(["gcc", "-o", str(exe), str(HERE / "c_host" / "fmi2_host.c"), "-ldl"], check=True)
    with zipfile.ZipFile(differential_fmu) as z:
        z.extractall(tmp_path / "fmu")
    md = read_model_description(str(differential_fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    so = tmp_path / "fmu" / "binaries" / "linux64" / "SpurDifferential.so"
    needed = subprocess.run(["readelf", "-d", str(so)], capture_output=True, text=True).stdout
    assert "libpython" not in needed, "the loader must not depend on libpython (any host can dlopen it)"
    args = [str(exe), str(so), md.guid, (tmp_path / "fmu" / "resources").as_uri(),
            str(vr["carrier.w_ref"]), str(vr["left.tau"]), str(vr["right.tau"]), str(vr["carrier.tauDrive"])]
    for i in range(3):
        r = _run(args, tmp_path)
        assert "status 0 tauDrive 2100.000000" in r.stdout, r.stdout + r.stderr
        assert "freed" in r.stdout
        assert r.returncode == 0, f"run {i + 1}: exit {r.returncode}\n{r.stdout}{r.stderr}"


@needs_hosts
def test_a_missing_package_is_named_and_instantiate_returns_null(differential_fmu, tmp_path):
    """The host's Python lacks scipy: fmi2Instantiate logs which package and which interpreter,
    and returns NULL (the host reports it; no crash)."""
    fmu = tmp_path / "NoScipy.fmu"
    with zipfile.ZipFile(differential_fmu) as zin, zipfile.ZipFile(fmu, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "resources/python_runtime.cfg":
                data = data.replace(b"require=scipy", b"require=scipy_not_installed_here")
            zout.writestr(item, data)
    r = _run([str(HOSTS / "fmuCheck.linux64"), "-k", "cs", "-s", "0.01", str(fmu)], tmp_path)
    text = r.stdout + r.stderr
    assert "scipy_not_installed_here" in text and "cannot import" in text, text[-3000:]
    assert "Could not instantiate" in text
    assert r.returncode == 1, f"fmuCheck: exit {r.returncode}, docs/interoperability.md says 1"
    r = _run([str(HOSTS / "fmusim"), "--interface-type", "cs", "--stop-time", "0.01",
              "--output-file", str(tmp_path / "o.csv"), str(fmu)], tmp_path)
    assert "scipy_not_installed_here" in r.stdout + r.stderr
    assert r.returncode == 3, f"fmusim: exit {r.returncode}, docs/interoperability.md says 3"


@needs_hosts
def test_a_missing_python_is_named_and_instantiate_returns_null(differential_fmu, tmp_path):
    fmu = tmp_path / "NoPython.fmu"
    with zipfile.ZipFile(differential_fmu) as zin, zipfile.ZipFile(fmu, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "resources/python_runtime.cfg":
                data = b"\n".join(b"libpython=/nonexistent/libpython3.11.so.1.0" if line.startswith(b"libpython=")
                                  else line for line in data.split(b"\n"))
            zout.writestr(item, data)
    r = _run([str(HOSTS / "fmusim"), "--interface-type", "cs", "--stop-time", "0.01",
              "--output-file", str(tmp_path / "o.csv"), str(fmu)], tmp_path)
    text = r.stdout + r.stderr
    assert "/nonexistent/libpython3.11.so.1.0" in text, text[-3000:]
    assert r.returncode == 3, f"fmusim: exit {r.returncode}, docs/interoperability.md says 3 (a failed instantiation)"
    r = _run([str(HOSTS / "fmuCheck.linux64"), "-k", "cs", "-s", "0.01", str(fmu)], tmp_path)
    assert "/nonexistent/libpython3.11.so.1.0" in r.stdout + r.stderr
    assert r.returncode == 1, f"fmuCheck: exit {r.returncode}, docs/interoperability.md says 1"


def _ecos() -> str | None:
    """The ecos command line from the ecospy wheel, if it runs here (it needs Debian's libtbb12)."""
    try:
        import ecospy
    except (ImportError, OSError):   # OSError: its library is there but libtbb.so.12 is not
        return None
    exe = Path(ecospy.__file__).parent / "binaries" / "ecos"
    if not exe.is_file():
        return None
    exe.chmod(exe.stat().st_mode | 0o111)
    r = subprocess.run([str(exe), "--version"], capture_output=True, text=True, env=BARE_ENV)
    return str(exe) if r.returncode == 0 else None


ECOS = _ecos()


@pytest.mark.skipif(ECOS is None, reason="the ecos command line (pip install ecospy; apt-get install libtbb12) "
                                         "does not run here")
@pytest.mark.parametrize("name", list(CASES))
def test_ecos_command_line_runs_our_fmu_with_a_bare_environment(name, fmu_files, tmp_path):
    """ecos has no start-value option for a lone FMU: it runs the FMU's defaults, compared with
    fmpy's run of the same defaults."""
    res = simulate_fmu(str(fmu_files[name]), stop_time=STOP, output_interval=STEP)
    ref = {n: np.asarray(res[n], dtype=float) for n in res.dtype.names}
    for i in range(RUNS):
        r = _run([ECOS, "simulate", "--path", str(fmu_files[name]), "--stopTime", str(STOP),
                  "--stepSize", str(STEP)], tmp_path)
        assert r.returncode == 0, f"run {i + 1}/{RUNS}: exit {r.returncode}\n{r.stdout[-2000:]}{r.stderr[-2000:]}"
        got = _read_csv(tmp_path / f"{name}.csv")
        # ecos names columns "instance::carrier.w[REAL]"
        got = {k.split("::", 1)[-1].split("[", 1)[0]: v for k, v in got.items()}
        # ecos writes six decimals ("%f": 0.034141 for 0.03414129): rounding moves a value by at
        # most 5e-7 (fmusim and fmuCheck write 16 or more significant digits)
        _compare(name, got, ref, f"ecos run {i + 1}", rtol=1e-9, atol=5e-7)
