"""harness/build/fmu_package.py: the FMU's copy of spurdiff imports nothing by the global names
``spurdiff``/``pythonfmu`` and runs under a private alias; datafile reads its own folder."""
from __future__ import annotations

import ast
import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

from harness.build import fmu_package, runtime_bundle
from harness.build.fmu_package import (PackageError, leftover_imports, rewrite_source, stage_package,
                                       write_entry)
from harness.common.paths import physics_package


def test_absolute_imports_become_relative_from_any_depth():
    text = ("from spurdiff.geometry import GearSet\n"
            "from spurdiff import datafile\n"
            "import spurdiff.errors as errs\n"
            "from pythonfmu.enums import Fmi2Status\n"
            "from numpy import pi\n")
    assert rewrite_source(text, Path("spurdiff/mesh/model.py")) == (
        "from ..geometry import GearSet\n"
        "from .. import datafile\n"
        "from .. import errors as errs\n"
        "from .._vendor.pythonfmu.enums import Fmi2Status\n"
        "from numpy import pi\n")
    assert rewrite_source(text, Path("spurdiff/wheel.py")).splitlines()[:4] == [
        "from .geometry import GearSet", "from . import datafile", "from . import errors as errs",
        "from ._vendor.pythonfmu.enums import Fmi2Status"]


def test_a_multi_line_import_keeps_its_lines_and_a_nested_one_is_found():
    text = ("from spurdiff.mesh.forces import (\n    a,\n    b,\n)\n"
            "def f():\n    from pythonfmu import Real\n    return Real\n")
    out = rewrite_source(text, Path("spurdiff/mesh/kernel.py"))
    assert out.count("\n") == text.count("\n")
    assert out.startswith("from .forces import (\n    a,\n    b,\n)\n")
    assert "    from .._vendor.pythonfmu import Real\n" in out
    ast.parse(out)


@pytest.mark.parametrize("text, line, what", [
    ("x = 1\nimport spurdiff.geometry\n", 2, "import spurdiff.geometry"),
    ("import spurdiff\n", 1, "import spurdiff"),
    ("import importlib\nm = importlib.import_module('spurdiff.geometry')\n", 2, "import_module"),
    ("from importlib import resources\nt = resources.files('spurdiff.data')\n", 2, "files"),
])
def test_what_cannot_be_made_relative_fails_naming_file_and_line(text, line, what):
    with pytest.raises(PackageError, match=rf"spurdiff/x\.py:{line}: .*{what}"):
        rewrite_source(text, Path("spurdiff/x.py"))


def _absolute_imports_of(root: Path, names=("spurdiff", "pythonfmu")) -> list[str]:
    """Every absolute import of ``names`` in the tree, by a full ast.walk (independent of the
    module's own statement walk)."""
    left = []
    for path in root.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            mods = ([a.name for a in node.names] if isinstance(node, ast.Import)
                    else [node.module] if isinstance(node, ast.ImportFrom) and node.level == 0 else [])
            left += [f"{path}:{node.lineno}:{m}" for m in mods if m and m.split(".")[0] in names]
    return left


@pytest.fixture(scope="module")
def staged(tmp_path_factory):
    root = tmp_path_factory.mktemp("fmu package") / "resources"
    pkg = stage_package(physics_package(), root)
    write_entry(pkg, "WheelLoad", "spurdiff.fmi.wheel_fmu")
    return pkg


def test_the_copy_has_no_global_import_left_and_the_source_keeps_its_own(staged):
    assert _absolute_imports_of(staged) == []
    assert leftover_imports(staged.parent) == []
    assert _absolute_imports_of(physics_package(), ("pythonfmu",)) != []    # the source is untouched
    vendored = staged / "_vendor" / "pythonfmu"
    assert sorted(p.stem for p in vendored.glob("*.py")) == sorted(
        ["__init__", "fmi2slave", "variables", "enums", "logmsg", "default_experiment", "osutil", "_version",
         "_deferred"])


def test_a_copy_may_import_the_standard_library_only(tmp_path):
    """The FMU's runtime carries the standard library and nothing else: an import of numpy, even
    inside a function, is what the copy would import from outside (stage_package refuses it)."""
    (tmp_path / "spurdiff").mkdir()
    (tmp_path / "spurdiff" / "m.py").write_text("import json\n\ndef f():\n    import numpy\n    return numpy\n")
    assert leftover_imports(tmp_path) == ["spurdiff/m.py:4: numpy"]


def test_the_vendored_copy_imports_xml_at_its_first_use_and_still_writes_it(staged, tmp_path):
    """pythonfmu's modules import xml.etree's Element and SubElement at their top; the copy's import them
    when called (an FMU's start never writes a modelDescription.xml), and writing one still works."""
    script = (
        "import importlib.util, sys\n"
        f"spec = importlib.util.spec_from_file_location('_vend', {str(staged / '__init__.py')!r}, "
        f"submodule_search_locations=[{str(staged)!r}])\n"
        "m = importlib.util.module_from_spec(spec); sys.modules['_vend'] = m; spec.loader.exec_module(m)\n"
        "from _vend._vendor.pythonfmu import Fmi2Causality, Real\n"
        "print('BEFORE', any(n.startswith('xml') for n in sys.modules))\n"
        "r = Real('x', causality=Fmi2Causality.output, getter=lambda: 1.5)\n"
        "import xml.etree.ElementTree as ET\n"
        "e = r.to_xml()\n"
        "print('XML', isinstance(e, ET.Element), ET.tostring(e).decode())\n")
    r = subprocess.run([sys.executable, "-I", "-S", "-c", script], capture_output=True, text=True, timeout=60,
                       cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "BEFORE False" in r.stdout, r.stdout
    assert "XML True <ScalarVariable" in r.stdout and 'name="x"' in r.stdout and "<Real" in r.stdout, r.stdout


def test_a_deferred_import_keeps_the_lines_and_leaves_other_imports():
    text = ("import json\nfrom xml.etree.ElementTree import Element, SubElement\n"
            "from xml.etree.ElementTree import tostring\nx = 1\n")
    out = fmu_package.defer_imports(text, Path("m.py"))
    assert out == ("import json\nfrom ._deferred import Element, SubElement\n"
                   "from xml.etree.ElementTree import tostring\nx = 1\n")


def test_the_copy_runs_under_an_alias_without_the_source_tree_or_the_global_names(staged):
    """In ``python -I -S`` whose path is the standard library only, with ``spurdiff`` and
    ``pythonfmu`` refused by name: the copy loads under its alias and runs."""
    path = [str(runtime_bundle.STDLIB), str(runtime_bundle.DYNLOAD)]
    assert not any(Path(p).resolve() == physics_package().parent for p in path)
    out = runtime_bundle._run_probe(runtime_bundle.probe_spec(
        {"WheelLoad": (staged, {"startTime": 0.0, "stepSize": 1e-3})}, path))
    loaded = out["modules"]
    assert not any(n.split(".")[0] in ("spurdiff", "pythonfmu") for n in loaded)
    aliases = {n.split(".")[0] for n in loaded if n.startswith("_spurdiff_fmu_")}
    assert len(aliases) == 1 and f"{aliases.pop()}._fmu_entry" in loaded
    assert len(out["results"]["WheelLoad"]) > 10


def test_a_global_import_in_the_copy_is_refused_by_the_probe(tmp_path, staged):
    """The guard is real: a copy that still imports pythonfmu by name fails to load."""
    import shutil

    copy = tmp_path / "resources" / "spurdiff"
    shutil.copytree(staged, copy)
    entry = copy / "_fmu_entry.py"
    entry.write_text("import pythonfmu\n" + entry.read_text())
    with pytest.raises(runtime_bundle.RuntimeBundleError, match="pythonfmu"):
        runtime_bundle._run_probe(runtime_bundle.probe_spec(
            {"WheelLoad": (copy, {"stepSize": 1e-3})}, [str(runtime_bundle.STDLIB), str(runtime_bundle.DYNLOAD)]))


def test_datafile_reads_the_data_of_its_own_copy_at_import(staged, tmp_path):
    """A copy's datafile module reads the copy's data folder (changed here), not the source's,
    and no longer needs it once imported."""
    import shutil

    copy = tmp_path / "spurdiff"
    shutil.copytree(staged, copy)
    toml = copy / "data" / "passenger_car.toml"
    text = toml.read_text()
    assert "[wheel]" in text
    toml.write_text(text.replace("[wheel]", "[wheel]\nplantedByTheTest = 1.5", 1))
    code = (
        "import importlib.util, shutil, sys\n"
        "folder = sys.argv[1]\n"
        "spec = importlib.util.spec_from_file_location('_alias_x', folder + '/__init__.py', "
        "submodule_search_locations=[folder])\n"
        "m = importlib.util.module_from_spec(spec); sys.modules['_alias_x'] = m; spec.loader.exec_module(m)\n"
        "import importlib; d = importlib.import_module('_alias_x.datafile')\n"
        "shutil.rmtree(folder + '/data')\n"
        "print(d.read_data()['wheel']['plantedByTheTest'], 'spurdiff' in sys.modules)\n")
    r = subprocess.run([sys.executable, "-I", "-c", code, str(copy)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["1.5", "False"]
    from spurdiff.datafile import read_data
    assert "plantedByTheTest" not in read_data()["wheel"]


def test_the_source_package_has_no_global_name_lookup():
    """The rewrite would refuse it: the source names its data by folder, not by package name."""
    spec = importlib.util.find_spec("spurdiff.datafile")
    text = Path(spec.origin).read_text()
    rewrite_source(text, Path("spurdiff/datafile.py"))
    assert "spurdiff.data" not in text.replace("``spurdiff/data", "")


def test_the_package_archive_stores_unchecked_pycs_and_deflates_the_sources(differential_fmu, tmp_path):
    """resources/spurdiff.zip: every pyc hash-based and unchecked (an import never reads the source) and
    stored, every source deflated (a host's unzip writes 0.5 MB less), the data stored; an edited source
    loses its pyc, so the import runs the edit."""
    import io
    import struct
    import zipfile

    from harness.build import fmu_contents

    def package(fmu):
        with zipfile.ZipFile(fmu) as z:
            return zipfile.ZipFile(io.BytesIO(z.read("resources/spurdiff.zip")))

    arch = package(differential_fmu)
    infos = {i.filename: i for i in arch.infolist()}
    pycs = [n for n in infos if n.endswith(".pyc")]
    assert len(pycs) > 50 and all(n[:-1] in infos for n in pycs)
    for n in pycs:
        assert struct.unpack("<I", arch.read(n)[4:8])[0] == 0b01, n      # hash-based, unchecked
        assert infos[n].compress_type == zipfile.ZIP_STORED, n
    assert all(i.compress_type == zipfile.ZIP_DEFLATED for n, i in infos.items() if n.endswith(".py"))
    assert all(i.compress_type == zipfile.ZIP_STORED for n, i in infos.items() if n.endswith((".toml", ".json")))

    def edit(name, data):
        return data + b"\nEDITED = True\n" if name == "spurdiff/gears/__init__.py" else data
    edited = package(fmu_contents.edit_package(differential_fmu, tmp_path / "e.fmu", edit))
    assert "spurdiff/gears/__init__.pyc" not in edited.namelist()
    assert edited.read("spurdiff/gears/__init__.py").endswith(b"EDITED = True\n")
    assert set(edited.namelist()) == set(infos) - {"spurdiff/gears/__init__.pyc"}
