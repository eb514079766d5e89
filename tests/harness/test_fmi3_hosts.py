"""The FMI 3.0 FMUs (``NAME-fmi3.fmu``) in hosts nobody on this project wrote, and in ours.

Each host runs each FMU with a bare environment (``env -i PATH=/usr/bin:/bin``) from a folder whose
path has spaces and non-ASCII characters, ``RUNS`` times; every run must exit 0 and give fmpy's
in-process numbers of the FMI 2.0 twin (host_cases.CASES; to 1e-12, ecos to its six decimals):
the Reference FMUs' fmusim, fmpy (this venv's Python, isolated), the ecos command line, and our
C host (tests/c_host/fmi3_host.c, on the FMI 3.0 standard headers). ``SPURDIFF_HOST_RUNS`` sets
RUNS (default 2 to keep the suite short: fmusim and ecos unpack 78 MB per run; the
interoperability table was made with 20). fmpy and the C host run the FMU unpacked once.
Also: every scene gives the FMI 2.0 results with the FMI 3.0 FMUs (shortened), and the SSP
export names the FMI 3.0 FMUs when asked to.
"""
from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from host_cases import CASES, ECOS_LOG, STEP, STOP, build_c_host, compare, ecos_binary, read_csv, read_ecos_csv

from harness.fmi.instance import fmu_cache

HERE = Path(__file__).resolve().parents[1]   # tests/
HOSTS = HERE.parent.parent / "shared" / "hosts"
RUNS = int(os.environ.get("SPURDIFF_HOST_RUNS", "2"))
BARE = ["env", "-i", "PATH=/usr/bin:/bin"]


@pytest.fixture(scope="module")
def fmu3_files(fmu_files):
    from harness.build.fmu3 import build

    return dict(zip(fmu_files, build(list(fmu_files), quiet=True)))


@pytest.fixture(scope="module")
def odd_dir(fmu3_files):
    root = Path(tempfile.mkdtemp(prefix="spurdiff fmi3 ü "))
    for name, path in fmu3_files.items():
        shutil.copy(path, root / f"{name}.fmu")
    yield root
    shutil.rmtree(root, ignore_errors=True)


@pytest.fixture(scope="module")
def unpacked(odd_dir):
    """Each FMI 3.0 FMU unpacked once under the odd path (fmpy and the C host run it from there)."""
    out = {}
    for name in CASES:
        out[name] = odd_dir / f"unpacked {name} ü"
        with zipfile.ZipFile(odd_dir / f"{name}.fmu") as z:
            z.extractall(out[name])
        for p in (out[name] / "binaries" / "x86_64-linux").iterdir():
            p.chmod(0o755)
    return out


@pytest.fixture(scope="module")
def reference(fmu_files):
    """fmpy in this process on the FMI 2.0 FMUs."""
    out = {}
    for name, inputs in CASES.items():
        res = simulate_fmu(fmu_cache().get(fmu_files[name])[0], stop_time=STOP, output_interval=STEP,
                           start_values=inputs)
        out[name] = {n: np.asarray(res[n], dtype=float) for n in res.dtype.names}
    return out


def _loop(cmd: str, runs: int = RUNS) -> str:
    return f"i=1; while [ $i -le {runs} ]; do {cmd}; echo RUN $i $?; i=$((i+1)); done\n"


def _side_by_side(scripts: dict[str, str], cwd: Path) -> dict[str, list[int]]:
    """One bare shell per FMU, at once; the exit code of every run."""
    started = {n: subprocess.Popen([*BARE, "sh", "-c", s], cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                   text=True) for n, s in scripts.items()}
    codes = {}
    for name, p in started.items():
        out, err = p.communicate(timeout=600)
        codes[name] = [int(line.split()[2]) for line in out.splitlines() if line.startswith("RUN ")]
    return codes


@pytest.mark.skipif(not (HOSTS / "fmusim").is_file(), reason=f"{HOSTS}/fmusim is absent")
def test_fmusim_runs_each_fmi3_fmu_bare(odd_dir, reference):
    scripts = {}
    for name in CASES:
        starts = " ".join(f"--start-value {k} {v}" for k, v in CASES[name].items())
        scripts[name] = _loop(f"{shlex.quote(str(HOSTS / 'fmusim'))} --interface-type cs --output-interval {STEP} "
                              f"--stop-time {STOP} {starts} --output-file out-fmusim-{name}.csv {name}.fmu "
                              f">/dev/null 2>>err-fmusim-{name}.txt")
    for name, codes in _side_by_side(scripts, odd_dir).items():
        err = odd_dir / f"err-fmusim-{name}.txt"
        assert codes == [0] * RUNS, f"{name}: exit codes {codes}\n{err.read_text(errors='replace')[-3000:] if err.exists() else ''}"
        compare(read_csv(odd_dir / f"out-fmusim-{name}.csv"), reference[name], f"fmusim {name}", tol=1e-12)


FMPY_SCRIPT = """
import sys
from fmpy import simulate_fmu
from fmpy.util import write_csv
name, stop, step = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
starts = dict(zip(sys.argv[4:-1:2], map(float, sys.argv[5:-1:2])))
r = simulate_fmu(sys.argv[-1], stop_time=stop, output_interval=step, start_values=starts)
write_csv('out-fmpy-' + name + '.csv', r)
"""


def test_fmpy_runs_each_fmi3_fmu_bare(odd_dir, unpacked, reference):
    (odd_dir / "run_fmpy.py").write_text(FMPY_SCRIPT)
    scripts = {}
    for name in CASES:
        starts = " ".join(f"{shlex.quote(k)} {v}" for k, v in CASES[name].items())
        scripts[name] = _loop(f"{shlex.quote(sys.executable)} -I run_fmpy.py {name} {STOP} {STEP} {starts} "
                              f"{shlex.quote(str(unpacked[name]))} >>log-fmpy-{name}.txt 2>&1")
    for name, codes in _side_by_side(scripts, odd_dir).items():
        log = odd_dir / f"log-fmpy-{name}.txt"
        assert codes == [0] * RUNS, f"{name}: exit codes {codes}\n{log.read_text(errors='replace')[-3000:] if log.exists() else ''}"
        compare(read_csv(odd_dir / f"out-fmpy-{name}.csv"), reference[name], f"fmpy {name}", tol=1e-12)


@pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler")
def test_our_c_host_runs_each_fmi3_fmu_bare(odd_dir, unpacked, reference):
    exe = build_c_host("fmi3_host", odd_dir / "fmi3_host")
    scripts, gets = {}, {}
    for name in CASES:
        md = read_model_description(str(unpacked[name]))
        vr = {v.name: v.valueReference for v in md.modelVariables}
        outs = [n for n in reference[name] if n in vr and n != "time"][:6]
        gets[name] = outs
        args = [str(exe), str(unpacked[name] / "binaries" / "x86_64-linux" / f"{name}.so"), md.guid,
                str(unpacked[name] / "resources"), str(STOP), str(STEP),
                *(f"set:{vr[k]}={v!r}" for k, v in CASES[name].items()), *(f"get:{vr[n]}" for n in outs)]
        scripts[name] = _loop(" ".join(shlex.quote(a) for a in args) + f" >out-chost-{name}.txt 2>&1")
    for name, codes in _side_by_side(scripts, odd_dir).items():
        text = (odd_dir / f"out-chost-{name}.txt").read_text(errors="replace")
        assert codes == [0] * RUNS, f"{name}: exit codes {codes}\n{text[-3000:]}"
        assert "freed" in text and "status 0" in text, text
        got = {int(line.split()[1]): float(line.split()[2]) for line in text.splitlines() if line.startswith("get ")}
        md = read_model_description(str(unpacked[name]))
        vr = {v.name: v.valueReference for v in md.modelVariables}
        for n in gets[name]:
            assert got[vr[n]] == pytest.approx(reference[name][n][-1], rel=1e-12, abs=1e-12), n
    # the model in its own process (SPURDIFF_FMU_PROCESS=out: the server behind the FMI 3.0 calls)
    name = "SpurDifferential"
    md = read_model_description(str(unpacked[name]))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    r = subprocess.run([*BARE, "SPURDIFF_FMU_PROCESS=out", str(exe),
                        str(unpacked[name] / "binaries" / "x86_64-linux" / f"{name}.so"), md.guid,
                        str(unpacked[name] / "resources"), str(STOP), str(STEP),
                        *(f"set:{vr[k]}={v!r}" for k, v in CASES[name].items()), f"get:{vr['left.w']}"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and "freed" in r.stdout, r.stdout + r.stderr
    got = float(next(line.split()[2] for line in r.stdout.splitlines() if line.startswith("get ")))
    assert got == pytest.approx(reference[name]["left.w"][-1], rel=1e-12, abs=1e-12)


ECOS = ecos_binary()


@pytest.mark.skipif(ECOS is None, reason="the ecos command line (pip install ecospy; apt-get install libtbb12) "
                                         "does not run here")
def test_ecos_runs_each_fmi3_fmu_bare(odd_dir, fmu_files):
    """ecos runs a lone FMU's defaults: compared with fmpy's run of the FMI 2.0 twin's defaults. Once,
    SpurDifferential only, unless SPURDIFF_HOST_RUNS is set (then RUNS runs of each FMU: ecos
    unpacks the FMU per run, the slowest host)."""
    full = "SPURDIFF_HOST_RUNS" in os.environ
    runs = RUNS if full else 1
    exe = odd_dir / "ecos"
    shutil.copy(ECOS, exe)
    exe.chmod(0o755)
    scripts = {}
    for name in (CASES if full else ["SpurDifferential"]):
        work = odd_dir / f"ecos {name}"
        work.mkdir(exist_ok=True)
        scripts[name] = _loop(f"cd {shlex.quote(str(work))} && ../ecos simulate --path ../{name}.fmu --stopTime {STOP} "
                              f"--stepSize {STEP} {ECOS_LOG} >>log.txt 2>&1; rc=$?; cd ..; (exit $rc)", runs)
    for name, codes in _side_by_side(scripts, odd_dir).items():
        work = odd_dir / f"ecos {name}"
        log = (work / "log.txt").read_text(errors="replace") if (work / "log.txt").exists() else ""
        assert codes == [0] * runs, f"{name}: exit codes {codes}\n{log[-3000:]}"
        res = simulate_fmu(fmu_cache().get(fmu_files[name])[0], stop_time=STOP, output_interval=STEP)
        ref = {n: np.asarray(res[n], dtype=float) for n in res.dtype.names}
        got = read_ecos_csv(work / f"{name}.csv", log, f"ecos {name}")
        compare(got, ref, f"ecos {name}", tol=5e-7)


@pytest.mark.parametrize("scene", ["vehicle-cornering", "tip-in-tip-out", "wheel-lift"])
def test_a_scene_gives_the_fmi2_results_with_the_fmi3_fmus(scene, fmu3_files):
    """Shortened (0.1 s); every scene at full length: python -m harness.cli.tools.fmi_versions."""
    from harness.measure.fmi_versions import compare

    c = compare(scene, duration=0.1)
    assert c.failure2 is None and c.failure3 is None, (c.failure2, c.failure3)
    assert c.samples > 10 and c.max_rel <= 1e-12, c


def test_ssp_export_names_the_fmi3_fmus(tmp_path, fmu3_files):
    from harness.run.runner import fmu_files_for, prepare_scene
    from harness.interop.ssp import export_ssp

    scene = prepare_scene("paper-cornering")
    out = export_ssp(scene, fmu_files_for(scene, fmi_version=3), tmp_path / "pc3.ssp")
    with zipfile.ZipFile(out) as z:
        names = z.namelist()
        ssd = z.read("SystemStructure.ssd").decode()
    assert any(n.endswith("-fmi3.fmu") for n in names), names
    assert not any(n.endswith(".fmu") and not n.endswith("-fmi3.fmu") for n in names), names
    assert "-fmi3.fmu" in ssd
    for n in (n for n in names if n.endswith(".fmu")):
        with zipfile.ZipFile(out) as z, z.open(n) as f, zipfile.ZipFile(f) as fmu:
            assert b'fmiVersion="3.0"' in fmu.read("modelDescription.xml")


def test_fmusim_runs_each_fmi3_fmu_where_no_python_is(odd_dir, reference):
    """As test_travel.py does for the FMI 2.0 FMUs: every Python of the machine hidden (mount
    namespace), as nobody, bare environment, odd path; once per FMU."""
    from test_travel import WHY_NOT, hidden_run

    if WHY_NOT is not None:
        pytest.skip(WHY_NOT)
    if not (HOSTS / "fmusim").is_file():
        pytest.skip(f"{HOSTS}/fmusim is absent")
    os.chmod(odd_dir, 0o777)
    for name in CASES:
        os.chmod(odd_dir / f"{name}.fmu", 0o644)
    script = ""
    for name in CASES:
        starts = " ".join(f"--start-value {k} {v}" for k, v in CASES[name].items())
        script += (f"{shlex.quote(str(HOSTS / 'fmusim'))} --interface-type cs --output-interval {STEP} "
                   f"--stop-time {STOP} {starts} --output-file hidden-{name}.csv {name}.fmu >/dev/null 2>&1; "
                   f"echo RUN {name} $?\n")
    r = hidden_run(script, odd_dir, timeout=600)
    codes = {line.split()[1]: int(line.split()[2]) for line in r.stdout.splitlines() if line.startswith("RUN ")}
    assert codes == {name: 0 for name in CASES}, r.stdout + r.stderr
    for name in CASES:
        compare(read_csv(odd_dir / f"hidden-{name}.csv"), reference[name], f"fmusim hidden {name}", tol=1e-12)
