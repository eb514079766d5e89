"""The FMUs travel: they run where no Python is, as another user, from an odd path.

Each host runs in a mount namespace (``unshare -m``) where every Python installation and virtual
environment of this machine is hidden under an empty tmpfs (the pyenv tree, Debian's and
/usr/local's python3 folders and libpython, this test's own venv), as the unprivileged user
``nobody``, with a bare environment, from a folder whose path has spaces and non-ASCII
characters. Hosts: the FMU Compliance Checker, the Reference FMUs' fmusim, the ecos command line
(copied beside the FMUs: its wheel's folder is hidden too) and our own C host. Every run must
exit 0 and give the in-harness (fmpy, this process) numbers to 1e-9. Skipped with the reason
where namespaces are not permitted (CI runs as root, so it runs them).
"""
from __future__ import annotations

import glob
import os
import re
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

HERE = Path(__file__).resolve().parents[1]   # tests/
HOSTS = HERE.parent.parent / "shared" / "hosts"
RUNS = 20


def _hidden_paths() -> tuple[list[str], list[str]]:
    """Folders and files that make up a Python installation or a venv on this machine."""
    dirs = set()
    for pattern in ("/root/.pyenv", "/usr/lib/python3*", "/usr/local/lib/python3*", "/opt/python*",
                    "/usr/share/python3*", "/usr/lib/python2*"):
        dirs.update(p for p in glob.glob(pattern) if os.path.isdir(p))
    for p in (sys.prefix, sys.base_prefix, os.path.realpath(sys.prefix), os.path.realpath(sys.base_prefix)):
        if os.path.isdir(p) and p not in ("/usr", "/usr/local", "/"):
            dirs.add(p)
    files = set()
    for pattern in ("/usr/bin/python*", "/usr/local/bin/python*", "/usr/lib/x86_64-linux-gnu/libpython3*",
                    "/usr/local/lib/libpython3*", "/usr/lib/libpython3*"):
        files.update(os.path.realpath(p) for p in glob.glob(pattern) if os.path.isfile(p))   # links: their targets
    # a path inside a hidden folder is hidden with it (and could not be mounted over once it is)
    dirs = {d for d in dirs if not any(d.startswith(o + "/") for o in dirs)}
    return sorted(dirs), sorted(f for f in files if not any(f.startswith(d + "/") for d in dirs))


def _namespaces_work() -> str | None:
    if os.geteuid() != 0:
        return "needs root to make a mount namespace (CI runs as root)"
    if not shutil.which("unshare") or not shutil.which("setpriv"):
        return "unshare/setpriv (util-linux) not installed"
    r = subprocess.run(["unshare", "-m", "--propagation", "private", "true"], capture_output=True, text=True)
    return None if r.returncode == 0 else f"mount namespaces not permitted here: {r.stderr.strip()}"


WHY_NOT = _namespaces_work()
pytestmark = pytest.mark.skipif(WHY_NOT is not None, reason=str(WHY_NOT))


def hidden_run(script: str, cwd: Path, timeout: float = 900) -> subprocess.CompletedProcess:
    """Run the shell `script` as nobody, bare environment, in a mount namespace with every Python
    hidden; it starts with a check that no python3 runs there."""
    return hidden_start(script, cwd).wait_done(timeout)


class _Started(subprocess.Popen):
    def wait_done(self, timeout: float) -> subprocess.CompletedProcess:
        out, err = self.communicate(timeout=timeout)
        return subprocess.CompletedProcess(self.args, self.returncode, out, err)


def hidden_start(script: str, cwd: Path) -> _Started:
    """:func:`hidden_run` started, not waited for (the FMUs' loops run side by side on the cores)."""
    dirs, files = _hidden_paths()
    mounts = [f"mount -t tmpfs -o size=1m,mode=755 none {shlex.quote(d)}" for d in dirs]
    mounts += [f"mount --bind /dev/null {shlex.quote(f)}" for f in files]
    inner = ("set -u\n"
             "if command -v python3 >/dev/null 2>&1 && python3 -c pass 2>/dev/null; then echo 'PYTHON VISIBLE'; exit 97; fi\n"
             + script)
    outer = "set -e\n" + "\n".join(mounts) + "\n" + (
        f"cd {shlex.quote(str(cwd))}\n"
        f"exec setpriv --reuid=65534 --regid=65534 --clear-groups env -i PATH=/usr/bin:/bin HOME={shlex.quote(str(cwd))} "
        f"sh -c {shlex.quote(inner)}\n")
    return _Started(["unshare", "-m", "--propagation", "private", "sh", "-c", outer], stdout=subprocess.PIPE,
                    stderr=subprocess.PIPE, text=True)


@pytest.fixture(scope="module")
def odd_dir(fmu_files):
    """A folder nobody can use, with spaces and non-ASCII characters in its path, holding the FMUs."""
    root = Path(tempfile.mkdtemp(prefix="spurdiff travel ü ", dir="/tmp"))
    os.chmod(root, 0o777)
    for name, path in fmu_files.items():
        shutil.copy(path, root / f"{name}.fmu")
        os.chmod(root / f"{name}.fmu", 0o644)
    yield root
    shutil.rmtree(root, ignore_errors=True)


@pytest.fixture(scope="module")
def reference(fmu_files):
    out = {}
    for name, inputs in CASES.items():
        res = simulate_fmu(str(fmu_files[name]), stop_time=STOP, output_interval=STEP, start_values=inputs)
        out[name] = {n: np.asarray(res[n], dtype=float) for n in res.dtype.names}
    return out


def _loop(cmd: str, runs: int = RUNS) -> str:
    """`runs` runs of cmd; prints 'RUN i rc' after each."""
    return f"i=1; while [ $i -le {runs} ]; do {cmd}; echo RUN $i $?; i=$((i+1)); done\n"


def _exit_codes(out: str) -> list[int]:
    return [int(line.split()[2]) for line in out.splitlines() if line.startswith("RUN ")]


def test_no_python_is_visible_in_the_namespace(odd_dir):
    r = hidden_run("ls /root/.pyenv 2>/dev/null | wc -l; id -u; pwd\n", odd_dir)
    assert r.returncode == 0, r.stdout + r.stderr
    lines = r.stdout.split()
    assert lines[0] == "0" and lines[1] == "65534", r.stdout


def _side_by_side(scripts: dict[str, str], cwd: Path) -> dict[str, subprocess.CompletedProcess]:
    """One namespace run per FMU, at once (each loop is mostly the host unpacking the FMU)."""
    started = {name: hidden_start(script, cwd) for name, script in scripts.items()}
    return {name: p.wait_done(900) for name, p in started.items()}


@pytest.mark.skipif(not (HOSTS / "fmusim").is_file(), reason=f"{HOSTS}/fmusim is absent")
def test_fmusim_runs_each_fmu_where_no_python_is(odd_dir, reference):
    scripts = {}
    for name in CASES:
        starts = " ".join(f"--start-value {k} {v}" for k, v in CASES[name].items())
        cmd = (f"{shlex.quote(str(HOSTS / 'fmusim'))} --interface-type cs --output-interval {STEP} "
               f"--stop-time {STOP} {starts} --output-file out-fmusim-{name}.csv {name}.fmu >/dev/null "
               f"2>>err-fmusim-{name}.txt")
        scripts[name] = _loop(cmd)
    for name, r in _side_by_side(scripts, odd_dir).items():
        err = odd_dir / f"err-fmusim-{name}.txt"
        err = err.read_text(errors="replace") if err.exists() else ""
        codes = _exit_codes(r.stdout)
        assert codes == [0] * RUNS, f"{name}: exit codes {codes}\n{r.stdout[-2000:]}{r.stderr[-2000:]}{err[-3000:]}"
        compare(read_csv(odd_dir / f"out-fmusim-{name}.csv"), reference[name], f"fmusim {name}")


@pytest.mark.skipif(not (HOSTS / "fmuCheck.linux64").is_file(), reason=f"{HOSTS}/fmuCheck.linux64 is absent")
def test_fmucheck_runs_each_fmu_where_no_python_is(odd_dir, reference):
    scripts = {}
    for name in CASES:
        names = list(CASES[name])
        inputs = odd_dir / f"in-{name}.csv"
        with open(inputs, "w") as f:
            f.write("time," + ",".join(names) + "\n")
            for t in (0.0, STOP):
                f.write(f"{t}," + ",".join(str(CASES[name][n]) for n in names) + "\n")
        os.chmod(inputs, 0o644)
        cmd = (f"{shlex.quote(str(HOSTS / 'fmuCheck.linux64'))} -k cs -h {STEP} -s {STOP} -i in-{name}.csv "
               f"-o out-fmucheck-{name}.csv {name}.fmu >log-fmucheck-{name}.txt 2>&1; "
               f"grep -q '0 Error(s)' log-fmucheck-{name}.txt")
        scripts[name] = _loop(cmd)
    for name, r in _side_by_side(scripts, odd_dir).items():
        log = (odd_dir / f"log-fmucheck-{name}.txt").read_text(errors="replace")
        codes = _exit_codes(r.stdout)
        assert codes == [0] * RUNS, f"{name}: exit codes {codes}\n{r.stderr[-2000:]}{log[-3000:]}"
        compare(read_csv(odd_dir / f"out-fmucheck-{name}.csv"), reference[name], f"fmuCheck {name}")


@pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler")
def test_our_c_host_runs_the_differential_where_no_python_is(odd_dir, differential_fmu):
    exe = odd_dir / "fmi2_any_host"
    build_c_host("fmi2_any_host", exe)
    os.chmod(exe, 0o755)
    unpacked = odd_dir / "unpacked differential ü"
    with zipfile.ZipFile(differential_fmu) as z:
        z.extractall(unpacked)
    subprocess.run(["chmod", "-R", "a+rX", str(unpacked)], check=True)
    md = read_model_description(str(differential_fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    so = unpacked / "binaries" / "linux64" / "SpurDifferential.so"
    # the paper's straight-line case, 10 steps of 1 ms: locked, the carrier torque 2100 N m
    args = [str(exe), str(so), md.guid, (unpacked / "resources").as_uri(), "10", "1e-3", "1",
            f"{vr['carrier.w_ref']}=1.389", f"{vr['left.tau']}=-1050", f"{vr['right.tau']}=-1050",
            "get", str(vr["carrier.tauDrive"])]
    cmd = " ".join(shlex.quote(a) for a in args) + " >>out-chost.txt 2>&1"
    r = hidden_run(_loop(cmd), odd_dir)
    codes = _exit_codes(r.stdout)
    text = (odd_dir / "out-chost.txt").read_text(errors="replace")
    assert codes == [0] * RUNS, f"exit codes {codes}\n{text[-3000:]}"
    drive = re.findall(rf"^run 0 status 0 {vr['carrier.tauDrive']}=(\S+)$", text, re.M)
    assert len(drive) == RUNS and all(abs(float(x) - 2100.0) < 1e-6 for x in drive), text[-3000:]


ECOS = ecos_binary()


@pytest.mark.skipif(ECOS is None, reason="the ecos command line (pip install ecospy; apt-get install libtbb12) "
                                         "does not run here")
def test_ecos_runs_each_fmu_where_no_python_is(odd_dir, fmu_files):
    """ecos has no start-value option for a lone FMU: it runs the FMU's defaults, compared with fmpy's
    run of the same defaults."""
    exe = odd_dir / "ecos"
    shutil.copy(ECOS, exe)
    os.chmod(exe, 0o755)
    scripts = {}
    for name in CASES:
        work = odd_dir / f"ecos {name}"
        work.mkdir(exist_ok=True)
        os.chmod(work, 0o777)
        cmd = (f"cd {shlex.quote(str(work))} && ../ecos simulate --path ../{name}.fmu --stopTime {STOP} "
               f"--stepSize {STEP} {ECOS_LOG} >>log.txt 2>&1; rc=$?; cd ..; (exit $rc)")
        scripts[name] = _loop(cmd)
    for name, r in _side_by_side(scripts, odd_dir).items():
        work = odd_dir / f"ecos {name}"
        log = (work / "log.txt").read_text(errors="replace") if (work / "log.txt").exists() else ""
        codes = _exit_codes(r.stdout)
        assert codes == [0] * RUNS, f"{name}: exit codes {codes}\n{r.stderr[-2000:]}{log[-3000:]}"
        res = simulate_fmu(str(fmu_files[name]), stop_time=STOP, output_interval=STEP)
        ref = {n: np.asarray(res[n], dtype=float) for n in res.dtype.names}
        got = read_ecos_csv(work / f"{name}.csv", log, f"ecos {name}")
        # ecos writes six decimals (or seven significant digits for large values): half a unit of either
        compare(got, ref, f"ecos {name}", tol=5e-7)
