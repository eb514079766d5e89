"""Where numpy is needed at run time (issue 44 item 1): the car and the wheel never import it, nor the
differential at rigid with the FMU's default gear set (its undercut gears' form radii computed at
build time by the same function, spurdiff.gears.generating, harness/build/fmu.py: form_radius_table);
the mesh levels and other gear sets do. Each case in a fresh Python with numpy made unimportable."""
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
print('from', differential_fmu.__file__)
for mod, extra in ((differential_fmu, {}), (differential_fmu, {'carrierDrive': 'torque', 'lockingLaw': 'paper'}),
                   (vehicle_fmu, {}), (wheel_fmu, {})):
    values = {v.name: v.start for v in mod.VARIABLES}
    values.update(extra)
    m = mod.build_model(values)
    for i in range(20):
        m.do_step(0.005 * i, 0.005)
    print('ran', mod.__name__)
from spurdiff.gears import generating
print('table', len(generating._TABLE or {}))
try:
    differential_fmu.build_model({**{v.name: v.start for v in differential_fmu.VARIABLES}, 'meshModel': 'contact'})
except ImportError as e:
    print('contact needs numpy:', e)
"""


def test_the_default_configurations_run_without_numpy(differential_fmu, tmp_path):
    with zipfile.ZipFile(differential_fmu) as z:
        z.extractall(tmp_path)
    r = subprocess.run([sys.executable, "-c", CASE, str(tmp_path / "resources")], capture_output=True, text=True,
                       timeout=120, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    assert r.stdout.count("ran ") == 4, r.stdout
    assert f"from {tmp_path / 'resources' / 'spurdiff.zip'}" in r.stdout, r.stdout     # the FMU's copy
    # the default gear set (the designed one) has no undercut gear: its form radii need no generation,
    # the build's table (harness/build/fmu_contents.form_radius_table) may be empty; the four runs above
    # are the check that the default configurations need no numpy
    assert "contact needs numpy" in r.stdout, r.stdout


def test_the_mesh_parameters_name_the_integrators_methods():
    """mesh/params.py names the methods without importing the integrator (numpy)."""
    assert params.METHODS == tuple(integrator.METHODS)
