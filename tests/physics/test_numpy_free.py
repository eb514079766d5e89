"""numpy is not needed at run time (issue 44 item 1): every model an FMU runs, the mesh levels and
their Python reference included, and a gear set whose undercut form radius must be simulated, run
from the FMU's own package archive in a fresh Python where any import of numpy fails. (The FMUs
carry no numpy: tests/harness/test_fmu_package.py; the harness and the tests use it.)"""
from __future__ import annotations

import subprocess
import sys
import zipfile

from spurdiff.differential.mesh import integrator, params

CASE = r"""
import sys
sys.modules['numpy'] = None      # any import of numpy fails
sys.path.insert(0, sys.argv[1] + '/spurdiff.zip')      # the FMU's package archive (zipimport)
from spurdiff.fmi import differential_fmu, vehicle_fmu, wheel_fmu
from spurdiff.gears import generating
print('from', differential_fmu.__file__)
MESH = {'meshModel': 'contact', 'backlash': True, 'flankFriction': True,
        'meshStiffnessVariation': True}
CASES = [
    (differential_fmu, {}), (differential_fmu, {'carrierDrive': 'torque', 'lockingLaw': 'paper'}),
    (vehicle_fmu, {}), (wheel_fmu, {}),
    (differential_fmu, {'meshModel': 'compliant'}),
    (differential_fmu, {**MESH, 'solver.kernel': 'python', 'solver.method': 'ros34pw2'}),   # the Python reference
    (differential_fmu, {**MESH, 'solver.kernel': 'python', 'solver.method': 'rodas5p', 'carrierDrive': 'torque'}),
    (differential_fmu, {**MESH, 'solver.kernel': 'compiled'}),
    (differential_fmu, {'planet1.x': 0.1}),            # an undercut planet: its form radius simulated
]
racks = []                                             # the tool racks the generation made
Rack = generating._Rack
generating._Rack = lambda *a: racks.append(a) or Rack(*a)
for mod, extra in CASES:
    values = {v.name: v.start for v in mod.VARIABLES}
    missing = set(extra) - set(values)
    assert not missing, missing
    values.update(extra)
    generating._TABLE = {}                             # no build-time form radii: any undercut gear is generated
    generating.form_radius.cache_clear()
    m = mod.build_model(values)
    for i in range(20):
        m.do_step(0.005 * i, 0.005)
    print("ran", mod.__name__, sorted(extra.items()), f"racks={len(racks)}", getattr(m, "kernel_in_use", ""))
    racks.clear()
print('numpy loaded:', [k for k, v in sys.modules.items() if k.startswith('numpy') and v is not None])
"""


def test_every_configuration_runs_without_numpy(differential_fmu, tmp_path):
    with zipfile.ZipFile(differential_fmu) as z:
        z.extractall(tmp_path)
    r = subprocess.run([sys.executable, "-c", CASE, str(tmp_path / "resources")], capture_output=True, text=True,
                       timeout=300, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    assert r.stdout.count("ran ") == 9, r.stdout
    assert f"from {tmp_path / 'resources' / 'spurdiff.zip'}" in r.stdout, r.stdout     # the FMU's copy
    assert "numpy loaded: []" in r.stdout, r.stdout
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith("ran ")]
    assert "python" in lines[5] and "python" in lines[6] and lines[7].endswith("compiled"), lines
    # the default gear set has no undercut gear (nothing generated); the last case's planet is undercut
    assert all(" racks=0 " in ln for ln in lines[:8]) and " racks=0 " not in lines[8], lines


def test_the_mesh_parameters_name_the_integrators_methods():
    """mesh/params.py names the methods without importing the integrator (a rigid run loads no mesh module)."""
    assert params.METHODS == tuple(integrator.METHODS)
