"""The FMI 2.0 / 3.0 pair in a build folder agrees (harness/build/fmu3.py): an FMI 3.0 FMU is current
only while the FMI 2.0 FMU it was made from is there unchanged. The FMI 2.0 build draws a new GUID
each time, so a rebuilt FMI 2.0 FMU (``--fmi-version 2``, ``--force``, a build with other
``--platforms`` or stopped before its FMI 3.0 step, tests and runs that build the FMI 2.0 FMUs only)
must make its FMI 3.0 twin stale, whatever the sources. One real FMI 2.0 build (the session's,
copied), the FMI 3.0 builds real (about 2 s each); what an FMI 2.0 rebuild leaves (a new GUID, the
stamp build_one writes) is made by :func:`_rebuilt`."""
from __future__ import annotations

import re
import shutil
import uuid
import zipfile

import pytest

from harness.build import fmu as build2, fmu3, fmu_checksum

NAME = "WheelLoad"


def _guid(fmu) -> str:
    md = zipfile.ZipFile(fmu).read("modelDescription.xml").decode()
    return re.search(r'\b(?:guid|instantiationToken)="([^"]+)"', md).group(1)


@pytest.fixture
def dest(fmu_files, tmp_path):
    """A private build folder holding a current copy of the session's FMI 2.0 FMU."""
    fmu = fmu_files[NAME]
    for f in (fmu, fmu_checksum.checksum_path(fmu), fmu_checksum.stamp_path(fmu)):
        shutil.copy2(f, tmp_path / f.name)
    assert build2.is_current(NAME, tmp_path)
    return tmp_path


def _rebuilt(fmu2, replace_at=None) -> str:
    """What an FMI 2.0 rebuild leaves at ``fmu2``: the same FMU with a new GUID (its description and
    its runtimes' descriptions), renamed into place, and its stamp; returns the new GUID."""
    old, new = _guid(fmu2), str(uuid.uuid1())
    part = fmu2.with_name(".rebuilt.fmu")
    with zipfile.ZipFile(fmu2) as zin, zipfile.ZipFile(part, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename.endswith((".xml", ".cfg")):
                data = data.replace(old.encode(), new.encode())
            zout.writestr(item, data)
    shutil.move(part, fmu2)       # a rename: a reader holding the old file keeps it
    fmu_checksum.write(fmu2, build2.source_digest(NAME))
    return new


def test_a_rebuilt_fmi2_fmu_makes_its_fmi3_twin_stale_and_the_build_remakes_it(dest, monkeypatch):
    monkeypatch.delenv(build2.PLATFORMS_ENV, raising=False)
    fmu2 = build2.fmu_path(NAME, dest)
    (fmi3,) = fmu3.build([NAME], dest, quiet=True)
    assert fmu3.is_current(NAME, dest) and _guid(fmi3) == _guid(fmu2)
    guid = _rebuilt(fmu2)              # e.g. spurdiff build --fmi-version 2 --force
    assert build2.is_current(NAME, dest)
    assert not fmu3.is_current(NAME, dest), "an FMI 3.0 FMU made from the previous FMI 2.0 FMU counts as current"
    (fmi3,) = fmu3.build([NAME], dest, quiet=True)
    assert _guid(fmi3) == guid == _guid(fmu2)
    assert fmu3.is_current(NAME, dest)


def test_the_platforms_in_either_order_make_both_fmus_stale(dest, monkeypatch):
    """default, then --platforms linux64 (stopped after the FMI 2.0 step), then default: the case
    reported (the FMI 3.0 FMU was called up to date with the GUID of two builds before)."""
    monkeypatch.delenv(build2.PLATFORMS_ENV, raising=False)
    fmu2 = build2.fmu_path(NAME, dest)
    fmu3.build([NAME], dest, quiet=True)
    monkeypatch.setenv(build2.PLATFORMS_ENV, "linux64")
    assert not build2.is_current(NAME, dest) and not fmu3.is_current(NAME, dest)
    _rebuilt(fmu2)                     # the linux64 FMI 2.0 build (its GUID is what matters here)
    monkeypatch.delenv(build2.PLATFORMS_ENV)
    assert not build2.is_current(NAME, dest) and not fmu3.is_current(NAME, dest)
    guid = _rebuilt(fmu2)              # the default build's FMI 2.0 step
    assert build2.is_current(NAME, dest) and not fmu3.is_current(NAME, dest)
    (fmi3,) = fmu3.build([NAME], dest, quiet=True)
    assert _guid(fmi3) == guid


def test_an_fmi3_fmu_is_made_from_the_fmi2_file_it_was_stamped_with(dest, monkeypatch):
    """Another build renaming a new FMI 2.0 FMU into place while the FMI 3.0 one is made: the FMI 3.0
    FMU is the old one's twin throughout (not half of each), and is not current afterwards."""
    monkeypatch.delenv(build2.PLATFORMS_ENV, raising=False)
    fmu2 = build2.fmu_path(NAME, dest)
    old = _guid(fmu2)
    base_archive = build2._base_archive

    def meanwhile(*args):
        _rebuilt(fmu2)
        return base_archive(*args)
    monkeypatch.setattr(build2, "_base_archive", meanwhile)
    fmi3 = fmu3.build_one(NAME, dest, quiet=True)
    cfg = zipfile.ZipFile(fmi3).read(f"resources/{build2.RUNTIME_CFG}").decode()
    assert _guid(fmi3) == old and f"guid={old}" in cfg
    assert _guid(fmu2) != old and not fmu3.is_current(NAME, dest)


def test_an_fmi3_build_refuses_to_drop_the_windows_side_of_its_fmi2_fmu(dest, monkeypatch):
    """An FMI 2.0 FMU with win64 binaries and a build making linux64 only (another build's FMU, or
    win64 not makeable here now): a one-line error, not an FMI 3.0 twin without them."""
    if f"binaries/win64/{NAME}.dll" not in zipfile.ZipFile(build2.fmu_path(NAME, dest)).namelist():
        pytest.skip("the session's FMUs carry no win64 binaries (no mingw-w64 here)")
    monkeypatch.setenv(build2.PLATFORMS_ENV, "linux64")
    with pytest.raises(build2.BuildError, match=f"{NAME}.fmu carries win64 binaries, which this build does not "
                                                r"make \(platforms linux64\)"):
        fmu3.build_one(NAME, dest, quiet=True)
    assert not fmu3.fmu_path(NAME, dest).exists()


def test_sources_changed_during_an_fmi2_build_leave_the_fmu_stale(monkeypatch, tmp_path):
    """The stamp names the sources as they were when the build started (one real FMI 2.0 build,
    about 8 s): a source edited while the build runs is not taken as built."""
    sources = {"now": "sources-before"}
    monkeypatch.setattr(build2, "source_digest", lambda name: f"{sources['now']}:{name}")
    native_start = build2._native_start

    def edited_meanwhile(*args):
        sources["now"] = "sources-after"
        return native_start(*args)
    monkeypatch.setattr(build2, "_native_start", edited_meanwhile)
    fmu = build2.build_one(NAME, tmp_path, quiet=True)
    assert sources["now"] == "sources-after"
    assert fmu_checksum.stamp_path(fmu).read_text().strip() == f"sources-before:{NAME}"
    assert not build2.is_current(NAME, tmp_path)
