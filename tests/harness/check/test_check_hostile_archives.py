"""Issue 45 items 2 and 4 (the kit's parts): one FMU's broken modelDescription.xml is that FMU's finding and the
batch goes on with its JUnit file; an archive with two members of the same name is an error finding; an
archive whose members declare more than the kit's limit is refused in one line before anything is unpacked.
Every hostile archive is made here, in the test's tmp folder.
"""
from __future__ import annotations

import shutil
import struct
import sys
import time
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "broken_fmus"))
import chk_build  # noqa: E402

from harness.check.archive import MAX_UNPACKED_BYTES, ArchiveError, extract, open_checked, scan  # noqa: E402
from harness.cli.check import main  # noqa: E402

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler (gcc) to build ChkC")
ENTITY = '<!DOCTYPE fmiModelDescription [<!ENTITY % p "<!ENTITY x \'y\'>"> %p;]>\n'


def _copy(src: Path, dest: Path, edit=None, extra: list[tuple[str, bytes]] = ()) -> Path:
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dest, "w", zipfile.ZIP_DEFLATED) as zout:
        for info in zin.infolist():
            data = zin.read(info.filename)
            if info.filename == "modelDescription.xml" and edit is not None:
                data = edit(data.decode("utf-8")).encode("utf-8")
            zout.writestr(info, data)
        for name, data in extra:
            zout.writestr(name, data)
    return dest


def _with_parameter_entity(text: str) -> str:
    i = text.index("<fmiModelDescription")
    return text[:i] + ENTITY + text[i:]


@needs_gcc
def test_a_parameter_entity_is_that_fmus_finding_and_the_batch_goes_on(tmp_path, capsys):
    good = chk_build.chkc_fmu("ChkC")
    bad = _copy(good, tmp_path / "Entity.fmu", _with_parameter_entity)
    junit = tmp_path / "batch.xml"
    code = main([str(bad), str(good), "--select", "static,load", "--isolated", "--junit", str(junit)])
    out = capsys.readouterr().out
    assert code == 1 and "Traceback" not in out
    line = next(ln for ln in out.splitlines() if f"{bad}  load.libraries" in ln)
    assert line.startswith("ERROR") and "modelDescription.xml cannot be read: XMLSyntaxError" in line
    assert f"PASS   {good}  load.libraries" in out            # the other FMU of the batch is checked
    suites = {s.get("name"): s for s in ET.parse(junit).getroot().findall("testsuite")}
    assert set(suites) == {str(bad), str(good)}                  # and the JUnit file has both
    assert suites[str(good)].get("failures") == "0"


def test_two_members_of_the_same_name_are_an_error_finding(tmp_path, capsys):
    base = tmp_path / "Base.fmu"
    with zipfile.ZipFile(base, "w") as z:
        z.writestr("modelDescription.xml", '<fmiModelDescription fmiVersion="2.0" modelName="M" guid="{1}">'
                                           '<CoSimulation modelIdentifier="M"/><ModelVariables/><ModelStructure/>'
                                           '</fmiModelDescription>')
    twice = tmp_path / "Twice.fmu"
    with pytest.warns(UserWarning, match="Duplicate name"):
        _copy(base, twice, extra=[("modelDescription.xml", b"<fmiModelDescription fmiVersion='2.0'/>")])
    with pytest.raises(ArchiveError, match="two members named 'modelDescription.xml'"):
        open_checked(twice)
    assert main([str(twice), "--static-only", "--isolated"]) == 1
    out = capsys.readouterr().out
    assert f"ERROR  {twice}  static.archive  [FMI 2.0 2.3] two members named 'modelDescription.xml'" in out
    assert main([str(base), "--static-only", "--isolated", "--select", "static.archive"]) == 0


def _declaring(path: Path, member: str, size: int) -> Path:
    """``path`` with ``member``'s uncompressed size in the central directory set to ``size`` (what a zip
    of that much data declares) while the archive stays a few hundred bytes."""
    data = bytearray(path.read_bytes())
    name = member.encode()
    i = data.find(b"PK\x01\x02")
    while i >= 0:
        n = struct.unpack_from("<H", data, i + 28)[0]
        if data[i + 46:i + 46 + n] == name:
            struct.pack_into("<I", data, i + 24, size)
            path.write_bytes(bytes(data))
            return path
        i = data.find(b"PK\x01\x02", i + 4)
    raise AssertionError(f"{member} not in {path}")


def test_an_archive_declaring_900_mb_is_refused_before_unpacking(tmp_path, capsys):
    fmu = tmp_path / "Huge.fmu"
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("modelDescription.xml", '<fmiModelDescription fmiVersion="2.0" modelName="M" guid="{1}">'
                                           '<CoSimulation modelIdentifier="M"/><ModelVariables/><ModelStructure/>'
                                           '</fmiModelDescription>')
        z.writestr("resources/data.bin", b"\0" * 1024)
    _declaring(fmu, "resources/data.bin", 900 * 1024 ** 2)
    assert fmu.stat().st_size < 2000 and 900 * 1024 ** 2 > MAX_UNPACKED_BYTES
    for unpack in (scan, lambda p: extract(p, tmp_path / "out")):
        with pytest.raises(ArchiveError, match=r"declare \d+ bytes, more than 268435456 bytes unpacked .*before"):
            unpack(fmu)
    assert not (tmp_path / "out" / "resources" / "data.bin").exists()
    t0 = time.perf_counter()
    assert main([str(fmu), "--isolated"]) == 1
    elapsed = time.perf_counter() - t0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("ERROR")]
    assert len(lines) == 1 and "static.archive" in lines[0] and "refused before unpacking" in lines[0]
    assert elapsed < 30, elapsed   # no rule runs: it is the archive's one finding (no unpacking at all)


def test_an_archive_understating_its_size_is_still_caught_while_reading(tmp_path):
    fmu = tmp_path / "Liar.fmu"
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("modelDescription.xml", "<fmiModelDescription/>")
        z.writestr("resources/zeros.bin", b"\0" * (3 * 1024 ** 2))
    _declaring(fmu, "resources/zeros.bin", 10)     # declares 10 bytes, holds 3 MiB
    with pytest.raises(ArchiveError):
        scan(fmu, max_bytes=1024 ** 2)
