"""The bundled data files parsed beforehand (spurdiff/data/parsed_toml.json, spurdiff.datafile.parse_bundled;
issue 44: an FMU starts without tomllib): current with the TOML files, what tomllib makes of each, a
file edited since read as it is."""
from __future__ import annotations

import json
import subprocess
import sys
import tomllib

from spurdiff import datafile

REGENERATE = 'python -c "from spurdiff.datafile import write_parsed; write_parsed()"'


def _canonical(x) -> str:
    return json.dumps(x)     # (NaN of passenger_car.toml compares as text)


def test_the_parsed_copy_is_current():
    committed = json.loads(datafile.PARSED_FILE.read_text(encoding="utf-8"))["files"]
    now = datafile.parsed_entries()
    assert sorted(committed) == sorted(now) == sorted(p.name for p in datafile.DATA_FOLDER.glob("*.toml"))
    stale = [n for n in now if _canonical(committed[n]) != _canonical(now[n])]
    assert not stale, f"data files changed since the parsed copy was written: {stale}; run {REGENERATE}"


def test_each_bundled_file_parses_as_tomllib_parses_it_into_a_new_dict():
    for path in sorted(datafile.DATA_FOLDER.glob("*.toml")):
        text = path.read_text(encoding="utf-8")
        a, b = datafile.parse_bundled(path.name), datafile.parse_bundled(path.name, text)
        assert _canonical(a) == _canonical(b) == _canonical(tomllib.loads(text)), path.name
        assert list(a) == list(tomllib.loads(text))       # the keys in the file's order
        a["changed"] = 1
        assert "changed" not in datafile.parse_bundled(path.name)


def test_an_edited_file_is_parsed_as_it_is():
    text = (datafile.DATA_FOLDER / "parts.toml").read_text(encoding="utf-8")
    edited = "extra = 2\n" + text
    assert datafile.parse_bundled("parts.toml", edited)["extra"] == 2
    # the same size and another text: the CRC-32 tells them apart
    swapped = text.replace("bore = 0.027", "bore = 0.028", 1)
    assert len(swapped) == len(text) and swapped != text
    got = datafile.parse_bundled("parts.toml", swapped)
    assert _canonical(got) == _canonical(tomllib.loads(swapped)) != _canonical(tomllib.loads(text))
    # a file the copy does not hold
    assert datafile.parse_bundled("nofile.toml", "a = 1\n") == {"a": 1}


def test_reading_every_bundled_file_imports_no_tomllib():
    code = ("import sys\nfrom spurdiff import datafile\n"
            "for p in sorted(datafile.DATA_FOLDER.glob('*.toml')):\n    datafile.parse_bundled(p.name)\n"
            "print(sorted(m for m in sys.modules if m.startswith('tomllib')))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]", f"{r.stdout} (a stale parsed copy? run {REGENERATE})"
