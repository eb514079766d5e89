"""The start cache (fmu_src/native/fmi/native_start.c: take_sets, cache_build, seen_before; fmi2_loader.c:
keep_start; spurdiff/fmi/native_start.py: snapshot with the values set): a host that sets parameters to
other values than the FMU's defaults starts the model's Python at the build; the first time, the loader
marks those values as seen; the second time, when the instance is freed, it keeps the model's own native
start of exactly those values in the user's cache; from the third instance that sets the same values on,
the build comes from it without Python (no model process either), and the host sees exactly what the
Python-started instance sees: every status, every value of every variable, every message. A file that is
damaged, of another user's folder, or of other values is never used."""
from __future__ import annotations

import os
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from tests.fmus.test_native_start import START, _run

# a start value changed, a String, an Integer and a Boolean parameter changed (each a build of its own)
CHANGES = {
    "real": [("set", "differential.w_start", 5.0)],
    "kinds": [("set", "lockingLaw", "paper"), ("set", "maxInternalSteps", 7), ("set", "pinFriction", False),
              ("set", "differential.w_start", 2.0)],
}


def _program(changes) -> list:
    """Sets in the Instantiated phase, a read of everything in Initialization Mode (the build), its end,
    steps with input changes, everything again."""
    return (START[:1] + changes + START[1:] + [("steps", 30, 1e-3), ("set", "left.tau", -300.0),
                                              ("steps", 20, 2e-3), ("all",), ("terminate",)])


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    """This test's start cache: <tmp>/cache/spurdiff/starts (XDG_CACHE_HOME), for this process's
    instances and the hosts it starts."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.delenv("SPURDIFF_FMU_START_CACHE", raising=False)
    monkeypatch.delenv("SPURDIFF_FMU_START_CACHE_DIR", raising=False)   # (tests/conftest.py sets one)
    return tmp_path / "cache" / "spurdiff" / "starts"


def _files(cache: Path, kind: str = "bin") -> list[Path]:
    return sorted(cache.glob(f"*.{kind}")) if cache.is_dir() else []


@pytest.mark.parametrize("then", [[], [("state",), ("steps", 10, 1e-3), ("all",)]], ids=["", "then-a-state"])
@pytest.mark.parametrize("which", list(CHANGES))
def test_a_second_start_with_the_same_values_equals_the_python_start(differential_fmu, monkeypatch, cache, which,
                                                                     then):
    """... and an FMU state after a start from the cache starts the Python, which replays the calls (the
    sets among them) and goes on."""
    program = _program(CHANGES[which])
    program = program[:-1] + then + program[-1:]
    first = _run(differential_fmu, "auto", program, monkeypatch)        # the Python starts at the build
    assert (len(_files(cache, "seen")), len(_files(cache))) == (1, 0)   # seen once
    second = _run(differential_fmu, "auto", program, monkeypatch)       # again: the snapshot at its end
    assert len(_files(cache)) == 1
    third = _run(differential_fmu, "auto", program, monkeypatch)        # from the cache file
    monkeypatch.setenv("SPURDIFF_FMU_START_CACHE", "off")
    python = _run(differential_fmu, "python", program, monkeypatch)
    assert first == second == python
    assert third == python
    assert any(m[1] for m in third[-1][1]), "the build logs its messages: the comparison would prove little"
    assert len(_files(cache)) == 1


def test_the_cache_folder_and_file_are_private(differential_fmu, monkeypatch, cache):
    for _ in range(2):
        _run(differential_fmu, "auto", _program(CHANGES["real"]), monkeypatch)
    (f,) = _files(cache)
    assert stat.S_IMODE(cache.stat().st_mode) == 0o700
    assert stat.S_IMODE(f.stat().st_mode) == 0o600
    assert not [p for p in cache.iterdir() if p.name.startswith(".new-")]   # no temporary file left


HOST = textwrap.dedent("""
    import os, sys
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    d = str(extract(sys.argv[1], sys.argv[2]))
    md = read_model_description(d)
    s = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier, instanceName='c')
    s.instantiate()
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s.setReal([vr['differential.w_start']], [float(sys.argv[3])])
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    for i in range(20):
        s.doStep(i * 1e-3, 1e-3)
    out = s.getReal([v.valueReference for v in md.modelVariables if v.causality == 'output' and v.type == 'Real'])
    kids = []
    for t in os.listdir('/proc/self/task'):
        kids += open(f'/proc/self/task/{t}/children').read().split()
    mine = [m for m, x in list(sys.modules.items()) if str(getattr(x, '__file__', '')).startswith(d)]
    s.terminate()
    s.freeInstance()
    print('RESULT', len(mine), len(kids), repr(out))
""")


def _host(fmu, where: Path, value: float, env: dict) -> tuple[int, int, str]:
    """A fresh fmpy host that sets differential.w_start and runs 20 steps: (the FMU package's modules it
    loaded, its model processes, the outputs)."""
    r = subprocess.run([sys.executable, "-c", HOST, str(fmu), str(where), repr(value)], capture_output=True,
                       text=True, env={**os.environ, **env}, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    line = next(ln for ln in r.stdout.splitlines() if ln.startswith("RESULT "))
    _, mods, kids, out = line.split(" ", 3)
    return int(mods), int(kids), out


@pytest.mark.parametrize("process", ["in", "out"])
def test_a_hit_starts_no_python_and_no_model_process(differential_fmu, tmp_path, cache, process):
    env = {"SPURDIFF_FMU_PROCESS": process}
    first = [_host(differential_fmu, tmp_path / f"a{i}", 4.0, env) for i in range(2)]   # seen, then kept
    third = _host(differential_fmu, tmp_path / "b", 4.0, env)
    other = [_host(differential_fmu, tmp_path / f"c{i}", 3.0, env) for i in range(2)]   # other values
    python = _host(differential_fmu, tmp_path / "d", 4.0, {**env, "SPURDIFF_FMU_START": "python"})
    # the Python started: in this process its modules, in its own a model process
    started = (True, 0) if process == "in" else (False, 1)
    assert [(x[0] > 20, x[1]) for x in first + other] == [started] * 4
    assert third[:2] == (0, 0)
    assert first[0][2] == first[1][2] == third[2] == python[2] != other[0][2]
    assert len(_files(cache)) == 2


@pytest.mark.parametrize("damage", ["one byte", "other values", "folder open to others", "a link"])
def test_a_file_not_to_be_trusted_is_never_used(differential_fmu, cache, tmp_path, damage):
    """A file with one byte changed (its digest), one made for other values under these values' name, one
    in a folder others may enter, or a symbolic link: the model's process starts (the Python builds) and
    the results are the Python's."""
    env = {"SPURDIFF_FMU_PROCESS": "out"}
    first = [_host(differential_fmu, tmp_path / f"a{i}", 4.0, env) for i in range(2)][0]
    (f,) = _files(cache)
    if damage == "one byte":
        data = bytearray(f.read_bytes())
        data[len(data) // 2] ^= 0x01
        f.write_bytes(bytes(data))
    elif damage == "other values":
        for i in range(2):
            _host(differential_fmu, tmp_path / f"b{i}", 3.0, env)
        (g,) = [p for p in _files(cache) if p != f]
        os.replace(g, f)
    elif damage == "folder open to others":
        cache.chmod(0o755)
    else:
        target = tmp_path / "elsewhere.bin"
        os.replace(f, target)
        f.symlink_to(target)
    again = _host(differential_fmu, tmp_path / "c", 4.0, env)
    assert again[1] == 1, "the file was used"
    assert again[2] == first[2]


def test_off_neither_reads_nor_writes(differential_fmu, monkeypatch, cache):
    monkeypatch.setenv("SPURDIFF_FMU_START_CACHE", "off")
    for _ in range(2):
        _run(differential_fmu, "auto", _program(CHANGES["real"]), monkeypatch)
    assert not cache.exists()


def test_the_folder_keeps_the_most_recently_used_512_files(differential_fmu, monkeypatch, cache):
    """Pruned at each write, least recently used first (a file used is touched); only files named as ours."""
    cache.mkdir(parents=True, mode=0o700)
    old = [cache / f"{i:016x}.seen" for i in range(520)]
    for i, p in enumerate(old):
        p.write_bytes(b"")
        os.utime(p, (1000 + i, 1000 + i))
    (cache / "notes.txt").write_text("not ours")
    _run(differential_fmu, "auto", _program(CHANGES["real"]), monkeypatch)   # one more .seen: 521, 9 go
    left = {p.name for p in cache.iterdir()}
    assert len(left) == 513 and "notes.txt" in left
    assert not any(p.name in left for p in old[:9]) and all(p.name in left for p in old[9:])


def test_an_own_folder_is_used_and_a_relative_one_is_no_cache(differential_fmu, monkeypatch, cache, tmp_path):
    monkeypatch.setenv("SPURDIFF_FMU_START_CACHE_DIR", str(tmp_path / "mine" / "starts"))
    for _ in range(2):
        _run(differential_fmu, "auto", _program(CHANGES["real"]), monkeypatch)
    assert len(_files(tmp_path / "mine" / "starts")) == 1 and _files(cache) == []
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("SPURDIFF_FMU_START_CACHE_DIR", "relative")
    _run(differential_fmu, "auto", _program(CHANGES["real"]), monkeypatch)
    assert not (tmp_path / "relative").exists() and _files(cache) == []


def test_the_values_set_decode_and_refuse_a_cut_record():
    import struct

    from spurdiff.fmi.native_start import decode_sets

    data = struct.pack("=IId", 0, 7, 2.5) + struct.pack("=III", 3, 9, 2) + b"ok" + struct.pack("=IId", 2, 4, 1.0)
    assert decode_sets(data) == [("Real", 7, 2.5), ("String", 9, "ok"), ("Boolean", 4, True)]
    with pytest.raises(ValueError, match="end inside a number"):
        decode_sets(data[:-3])
