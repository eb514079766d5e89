"""One interpreter holds one copy of a package: an FMU loaded by a Python host that already imported
another ``spurdiff`` must not silently run that copy (the bridge compares the files it carries with
the loaded ones before importing its module; fmu_src/native/fmi2_pybridge.c, identity_check)."""
from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                                reason="no C compiler: the FMUs run on pythonfmu's wrapper, not our bridge")


def _changed_copy(fmu: Path, out: Path, member: str = "resources/spurdiff/tyre.py") -> Path:
    """The FMU with one module of its spurdiff copy changed (a comment line appended)."""
    with zipfile.ZipFile(fmu) as zin, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item)
            if item.filename == member:
                data += b"\n# another version of this module\n"
            zout.writestr(item, data)
    return out


def test_a_host_that_imported_another_copy_is_refused_with_the_reason(fmu_files, tmp_path):
    changed = _changed_copy(fmu_files["WheelLoad"], tmp_path / "WheelLoad.fmu")
    code = (
        "import sys, spurdiff\n"
        "from fmpy import simulate_fmu\n"
        "msgs = []\n"
        "def logger(*a): msgs.append(a[-1].decode())\n"
        "try:\n"
        "    simulate_fmu(sys.argv[1], stop_time=0.01, output_interval=1e-3, logger=logger)\n"
        "    print('RAN')\n"
        "except Exception as e:\n"
        "    print('REFUSED', e)\n"
        "print('\\n'.join(msgs))\n")
    r = subprocess.run([sys.executable, "-c", code, str(changed)], capture_output=True, text=True, timeout=120)
    assert "REFUSED" in r.stdout, r.stdout + r.stderr
    assert "already imported the Python package 'spurdiff'" in r.stdout, r.stdout
    assert "tyre.py differs" in r.stdout, r.stdout


def test_the_same_fmu_runs_in_a_process_that_imported_nothing(fmu_files, tmp_path):
    changed = _changed_copy(fmu_files["WheelLoad"], tmp_path / "WheelLoad.fmu")
    code = ("import sys\nfrom fmpy import simulate_fmu\n"
            "r = simulate_fmu(sys.argv[1], stop_time=0.01, output_interval=1e-3)\n"
            "import spurdiff, os\n"
            "print('RAN', len(r), os.path.basename(os.path.dirname(os.path.dirname(spurdiff.__file__))))\n")
    r = subprocess.run([sys.executable, "-c", code, str(changed)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and "RAN 11 resources" in r.stdout, r.stdout + r.stderr


def test_an_identical_copy_runs_beside_the_imported_package(fmu_files, tmp_path):
    copy = shutil.copy(fmu_files["WheelLoad"], tmp_path / "WheelLoad.fmu")
    code = ("import sys, spurdiff\nfrom fmpy import simulate_fmu\n"
            "r = simulate_fmu(sys.argv[1], stop_time=0.01, output_interval=1e-3)\nprint('RAN', len(r))\n")
    r = subprocess.run([sys.executable, "-c", code, str(copy)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and "RAN 11" in r.stdout, r.stdout + r.stderr
