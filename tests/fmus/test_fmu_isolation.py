"""Every FMU runs its own copy of the physics package, whatever else the process holds.

The bridge imports ``resources/spurdiff`` under a private name per extraction folder and GUID
(fmu_src/native/fmi/fmi2_pybridge.c, BOOT_SOURCE), never ``spurdiff`` from sys.path: our FMUs one
after another with their folders removed in between, side by side, two builds whose packages
differ, and an FMU beside a host that imported ``spurdiff`` itself each run their own code. Each
case runs in a fresh Python process (the test process has imported FMUs of its own).
"""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from harness.build import fmu_contents


pytestmark = [pytest.mark.usefixtures("children_scratch_in_tmp_path"),   # hosts that may never remove theirs
              pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                                 reason="no C compiler: the FMUs cannot be built with our loader")]

# a loaded differential whose suns slip: the locking torque is the pin friction's (proportional to mu_pin)
CASE = {"carrier.w_ref": 1.389, "left.tau": -1500.0, "right.tau": -500.0}


def _other_build(fmu: Path, out: Path, mu_pin: float = 0.13) -> Path:
    """The FMU as another build would make it: its package's default pin friction changed and a
    new GUID (in modelDescription.xml and the runtime description)."""
    with zipfile.ZipFile(fmu) as z:
        md = z.read("modelDescription.xml").decode()
    old = md.split('guid="', 1)[1].split('"', 1)[0]
    new = "{0badc0de-0000-4000-8000-" + old[-13:-1] + "}"
    def edit(name: str, data: bytes) -> bytes:      # a member of the package's archive
        if name != "spurdiff/data/differential.toml":
            return data
        return "\n".join(f"mu_pin = {mu_pin}" if ln.startswith("mu_pin =") else ln
                         for ln in data.decode().split("\n")).encode() + \
            b"\n# another build: a line that moves every later member of the package archive\n"

    def rest(name: str, data: bytes) -> bytes:
        return data.replace(old.encode(), new.encode()) if name in ("modelDescription.xml",
                                                                    "resources/python_runtime.cfg") else data
    return fmu_contents.edit_package(fmu, out, edit, rest)


def _run(code: str, *args, env=None) -> dict:
    r = subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True,
                       timeout=300, env=env)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


LOCKING = """
import json, sys
from fmpy import simulate_fmu
CASE = %r
def locking(path):
    r = simulate_fmu(path, stop_time=0.02, output_interval=1e-3, start_values=CASE)
    return float(r['lockingTorque'][-1])
""" % (CASE,)


def test_two_builds_one_after_another_and_again_each_run_their_own_package(differential_fmu, tmp_path):
    other = _other_build(differential_fmu, tmp_path / "SpurDifferential.fmu")
    out = _run(LOCKING + "print(json.dumps([locking(p) for p in sys.argv[1:]]))",
               differential_fmu, other, differential_fmu, other)
    alone = [_run(LOCKING + "print(json.dumps([locking(sys.argv[1])]))", p)[0] for p in (differential_fmu, other)]
    assert out == alone * 2, f"one process {out}, each alone {alone}"
    assert out[1] < 0.6 * out[0], out   # half the pin friction: the other build's package ran


def test_another_build_extracted_into_the_same_folder_runs_its_own_package(differential_fmu, tmp_path):
    """A host that extracts another build where the first one was, in one process: the package
    archive at that path is read afresh (zipimport keeps an archive's directory by its path: a stale
    one would read the other build's members at the first one's offsets), so each build runs its own;
    and the first build extracted there again imports what it had not imported yet (the contact
    level) from its own archive, not through the other build's directory."""
    other = _other_build(differential_fmu, tmp_path / "SpurDifferential.fmu")
    folder = tmp_path / "the same folder"
    code = LOCKING + (
        "import shutil\n"
        "from fmpy import extract, simulate_fmu\n"
        "def contact(path):\n"
        "    r = simulate_fmu(path, stop_time=0.005, output_interval=1e-3, start_values={**CASE, 'meshModel': 'contact'})\n"
        "    return float(r['lockingTorque'][-1])\n"
        "out = []\n"
        "for path, run in zip(sys.argv[2:], (locking, locking, contact)):\n"
        "    shutil.rmtree(sys.argv[1], ignore_errors=True)\n"
        "    extract(path, unzipdir=sys.argv[1])\n"
        "    out.append(run(sys.argv[1]))\n"
        "print(json.dumps(out))\n")
    out = _run(code, folder, differential_fmu, other, differential_fmu)
    alone = [_run(LOCKING + "print(json.dumps([locking(sys.argv[1])]))", p)[0] for p in (differential_fmu, other)]
    alone.append(_run(code.replace("zip(sys.argv[2:], (locking, locking, contact))", "zip(sys.argv[2:], (contact,))"),
                      tmp_path / "alone", differential_fmu)[0])
    assert out == alone, f"one folder {out}, each alone {alone}"
    assert out[1] < 0.6 * out[0], out


def test_an_fmu_beside_a_host_that_imported_spurdiff_runs_its_own_copy(differential_fmu, tmp_path):
    other = _other_build(differential_fmu, tmp_path / "SpurDifferential.fmu")
    code = LOCKING + (
        "import spurdiff, os\n"
        "before = (spurdiff.__file__, list(sys.path))\n"
        "x = [locking(sys.argv[1]), locking(sys.argv[2])]\n"
        "import spurdiff as again\n"
        "assert (again.__file__, list(sys.path)) == before, 'the host\\'s spurdiff or sys.path changed'\n"
        "import sysconfig\n"
        "stdlib = sysconfig.get_paths()['stdlib'] + os.sep   # (its importlib/resources/ is no FMU's)\n"
        "bad = [m for m, mod in list(sys.modules.items()) if not m.startswith('_spurdiff_fmu_')\n"
        "       and '/resources/' in str(getattr(mod, '__file__', '') or '')\n"
        "       and not str(mod.__file__).startswith(stdlib)]\n"
        "assert not bad, f'modules imported from an FMU under their own names: {bad}'\n"
        "print(json.dumps(x))\n")
    a, b = _run(code, differential_fmu, other)
    assert b < 0.6 * a, (a, b)


def test_side_by_side_two_builds_step_interleaved(differential_fmu, tmp_path):
    other = _other_build(differential_fmu, tmp_path / "SpurDifferential.fmu")
    code = """
import json, sys
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
CASE = %r
fmus = []
for i, path in enumerate(sys.argv[1:]):
    md = read_model_description(path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    f = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier='SpurDifferential', instanceName=f'd{i}')
    f.instantiate(); f.setupExperiment(startTime=0); f.enterInitializationMode()
    f.setReal([vr[k] for k in CASE], list(CASE.values()))
    f.exitInitializationMode()
    fmus.append((f, vr['lockingTorque']))
t = 0.0
for _ in range(20):
    for f, _vr in fmus:
        f.doStep(t, 1e-3)
    t += 1e-3
out = [f.getReal([vr])[0] for f, vr in fmus]
for f, _vr in fmus:
    f.terminate(); f.freeInstance()
print(json.dumps(out))
""" % (CASE,)
    a, b = _run(code, differential_fmu, other)
    assert b < 0.6 * a, (a, b)


def test_our_three_fmus_one_after_another_with_their_folders_removed(fmu_files):
    """fmpy's simulate_fmu extracts each FMU to a temporary folder and removes it afterwards;
    every later FMU (and the first one again) runs, and the packages of removed folders are
    dropped from sys.modules (at most the live ones stay)."""
    code = """
import json, sys
from fmpy import simulate_fmu
rows = []
for path in sys.argv[1:]:
    r = simulate_fmu(path, stop_time=0.01, output_interval=1e-3)
    rows.append(len(r))
aliases = sorted({m.split('.')[0] for m in sys.modules if m.startswith('_spurdiff_fmu_') and not m.startswith('_spurdiff_fmu_boot_')})
print(json.dumps([rows, len(aliases)]))
"""
    paths = [fmu_files["SpurDifferential"], fmu_files["WheelLoad"], fmu_files["Vehicle"],
             fmu_files["SpurDifferential"], fmu_files["WheelLoad"]]
    rows, aliases = _run(code, *paths)
    assert rows == [11] * 5
    assert aliases <= 1, f"{aliases} packages of removed FMU folders are still imported"
