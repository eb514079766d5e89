"""The package as a user gets it: `python -m build` gives an sdist and a wheel; the wheel,
installed into a fresh venv, runs the documented commands from an empty folder, writes results
under that folder and FMUs to the per-user cache, and writes nothing inside site-packages."""
from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _files(folder: Path) -> dict[str, float]:
    return {str(p): p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file()}


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("pkg")
    r = subprocess.run([sys.executable, "-m", "build", "--outdir", str(tmp / "dist"), str(ROOT)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    # setuptools warned that spurdiff_fmus.native "would be ignored" before it was listed (issue 31)
    assert "WARNING" not in r.stdout + r.stderr, (r.stdout + r.stderr)[-3000:]
    wheels = list((tmp / "dist").glob("*.whl"))
    sdists = list((tmp / "dist").glob("*.tar.gz"))
    assert len(wheels) == 1 and len(sdists) == 1
    venv = tmp / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=120)
    r = subprocess.run([str(venv / "bin" / "pip"), "install", "-q", str(wheels[0])],
                       capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    site = Path(subprocess.run([str(venv / "bin" / "python"), "-c",
                                "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               capture_output=True, text=True, check=True).stdout.strip())
    return tmp, wheels[0], venv, site


def test_the_wheel_holds_what_the_commands_need(installed):
    _, wheel, _, _ = installed
    names = set(zipfile.ZipFile(wheel).namelist())
    for needed in ("spurdiff/fmi/wheel_fmu.py", "spurdiff/fmi/vehicle_fmu.py", "spurdiff/data/differential.toml",
                   "spurdiff_fmus/native/fmi/fmi2_loader.c", "spurdiff_fmus/native/fmi/fmi2_pybridge.c",
                   "spurdiff_fmus/native/fmi/runtime_cfg.h", "spurdiff/fmi/differential_fmu.py",
                   "spurdiff/data/passenger_car.toml", "harness/scenes/vehicle-cornering.toml",
                   "harness/sweeps/split-mu-locking.toml", "harness/measure/accuracy/accuracy_grid.toml",
                   "harness/measure/accuracy/accuracy_data.csv", "harness/measure/accuracy/accuracy_facts.json", "harness/interop/recipes/fmi2_host.c",
                   "harness/interop/recipes/fmpy_differential.py", "harness/interop/recipes/libcosim_ssp.py"):
        assert needed in names, needed
    # every harness subpackage made it (a new one must be listed in pyproject.toml)
    for pkg in (ROOT / "harness").rglob("__init__.py"):
        rel = pkg.relative_to(ROOT).as_posix()
        assert rel in names, f"{rel} is not in the wheel: add its package to pyproject.toml"


def test_the_installed_package_runs_from_an_empty_folder_and_writes_only_there(installed):
    tmp, _, venv, site = installed
    work = tmp / "work"
    work.mkdir()
    cache = tmp / "cache"
    env = {**os.environ, "XDG_CACHE_HOME": str(cache), "PYTHONDONTWRITEBYTECODE": "1",
           "MPLBACKEND": "Agg"}
    env.pop("SPURDIFF_FMU_DIR", None)
    before = _files(site)
    exe = str(venv / "bin" / "spurdiff")

    def run(*args):
        r = subprocess.run([exe, *args], cwd=work, env=env, capture_output=True, text=True, timeout=600)
        return r.returncode, r.stdout + r.stderr

    code, out = run("--version")
    assert code == 0 and out.strip().startswith("spurdiff ")
    code, out = run("run", "vehicle-cornering")           # the main job, as the README runs it
    assert code == 0, out[-3000:]
    assert (work / "results" / "vehicle-cornering" / "vehicle-cornering.csv").is_file()
    assert list((work / "results" / "vehicle-cornering").glob("*.png"))
    code, out = run("fmu", "SpurDifferential")
    fmu = Path(out.strip().splitlines()[-1])
    assert code == 0 and fmu.is_file() and cache in fmu.parents, out
    code, out = run("scenes")
    assert code == 0 and "paper-straight" in out
    code, out = run("info")
    assert code == 0 and "pinFriction" in out
    # a scene file from anywhere, extending a packaged scene by name
    (work / "mine.toml").write_text('extends = "paper-straight"\nname = "mine"\n')
    code, out = run("run", "mine.toml", "--no-plots")
    assert code == 0, out[-3000:]
    assert (work / "results" / "mine" / "mine.csv").is_file()
    code, out = run("build", "--out", str(tmp / "fmus"))
    assert code == 0 and str(tmp / "fmus") in out
    assert _files(site) == before, "something was written inside site-packages"
    written = {Path(p).relative_to(work).parts[0] for p in _files(work)}
    assert written <= {"results", "mine.toml"}, written
