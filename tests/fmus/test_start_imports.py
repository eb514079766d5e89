"""What SpurDifferential's default configuration imports at its start (issue 44: the start's cost is
the package's import): instantiated and initialized as the bridge does it (its package copy loaded under
a private alias, the class constructed, setup, initialization), in a fresh Python, none of the modules
that only other configurations, a fallback or a later call use is loaded; the ones the start needs are.
As tests/physics/test_numpy_free.py does for numpy, with the names, not a count."""
from __future__ import annotations

import subprocess
import sys
import zipfile

# loaded only by another configuration or a later call, never by the default start (the lazy imports)
NOT_AT_START_STDLIB = (
    "tomllib",     # the data files come parsed (spurdiff/data/parsed_toml.json, datafile.parse_bundled)
    "hashlib",     # a checkout's kernel digest (native_library.source_digest)
    "logging",     # a kernel's fallback logged (native_library._Logger)
    "numpy",       # no module of the package imports it (tests/physics/test_numpy_free.py); the FMU carries none
    "xml",         # pythonfmu's to_xml, never called in an FMU (harness/build/fmu_package.py: DEFERRED)
)
NOT_AT_START_PACKAGE = (
    "differential.shafts", "differential.shaft_kernel", "differential.shaft_solver",  # shaftCoupling = wheel
    "native_step", "differential.rigid_native",       # the native step: asked for by the bridge while stepping
    "differential.derivatives", "differential.mesh.rates", "differential.mesh.layout",  # FMI 3.0 derivatives
    "differential.mesh.laws", "differential.mesh.model",                               # the mesh levels
)
# what the start does need (the check sees the package's modules at all)
AT_START_PACKAGE = ("fmi.differential_fmu", "fmi.adapter", "differential.rigid", "differential.watches",
                    "gears.capacity.rating", "datafile")

START = r"""
import importlib, importlib.util, os, sys
res = sys.argv[1]
alias = '_spurdiff_fmu_start_test'
import zipimport                         # as the bridge loads the FMU's package archive
archive = os.path.join(res, 'spurdiff.zip')
inner = os.path.join(archive, 'spurdiff')
top = zipimport.zipimporter(archive)
spec = importlib.util.spec_from_loader(alias, top, origin=os.path.join(inner, '__init__.py'), is_package=True)
spec.submodule_search_locations = [inner]
spec.has_location = True
mod = importlib.util.module_from_spec(spec)
sys.modules[alias] = mod
exec(top.get_code('spurdiff'), mod.__dict__)
cls = getattr(importlib.import_module(alias + '._fmu_entry'), 'SpurDifferential')
s = cls(instance_name='start', resources=res, visible=False, logging_on=False)
status = (s.fmi2_setup_experiment(False, 0.0, 0.0, False, 0.0), s.fmi2_enter_initialization_mode(),
          s.fmi2_exit_initialization_mode())
print('STATUS', *status)
for name in sorted(sys.modules):
    print('MODULE', name.replace(alias, 'PKG'))
"""


def _start_modules(fmu, tmp_path) -> set[str]:
    with zipfile.ZipFile(fmu) as z:
        z.extractall(tmp_path)
    r = subprocess.run([sys.executable, "-I", "-S", "-c", START, str(tmp_path / "resources")],
                       capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "STATUS 0 0 0" in r.stdout, r.stdout[-2000:]
    return {ln.split()[1] for ln in r.stdout.splitlines() if ln.startswith("MODULE ")}


def test_the_default_start_imports_none_of_the_lazy_modules(differential_fmu, tmp_path):
    mods = _start_modules(differential_fmu, tmp_path)
    assert {f"PKG.{m}" for m in AT_START_PACKAGE} <= mods
    loaded = sorted(m for m in NOT_AT_START_STDLIB if m in mods or any(x.startswith(m + ".") for x in mods))
    loaded += sorted(m for m in NOT_AT_START_PACKAGE if f"PKG.{m}" in mods)
    assert loaded == [], f"the default start imports {loaded} again"



HOST_START = r"""
import sys
from fmpy import simulate_fmu
before = set(sys.modules)
print('BEFORE', 'hashlib' in before or '_hashlib' in before)
simulate_fmu(sys.argv[1], stop_time=0.003, step_size=1e-3, output_interval=1e-3)
print('PYTHON', any(n.startswith('_spurdiff_fmu_') and n.endswith('._fmu_entry') for n in sys.modules))
print('ADDED', *sorted(set(sys.modules) - before))
"""


def test_the_bridge_loads_no_openssl_into_a_python_host(differential_fmu, tmp_path):
    """The bridge names the package's alias by a SHA-256 from the interpreter's own module, not
    hashlib, whose import loads OpenSSL's libcrypto into the host (about 10 ms of a Python start in an
    fmpy host: startup_bench 15 against the build before): a Python start in an fmpy 3.11 process adds
    neither hashlib nor _hashlib."""
    import os
    env = {**os.environ, "SPURDIFF_FMU_START": "python", "SPURDIFF_FMU_PROCESS": "in"}
    r = subprocess.run([sys.executable, "-c", HOST_START, str(differential_fmu)], capture_output=True, text=True,
                       timeout=180, env=env, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "BEFORE False" in r.stdout, r.stdout[-2000:]    # fmpy itself has not loaded it: the check can fail
    assert "PYTHON True" in r.stdout, r.stdout[-2000:]     # the Python start ran in this process
    added = next(ln for ln in r.stdout.splitlines() if ln.startswith("ADDED")).split()[1:]
    assert "hashlib" not in added and "_hashlib" not in added, added
