"""A damaged or hostile FMU runtime is refused with the cause, never a crash, in a C host.

The FMUs' normal runs in the hosts nobody here wrote (fmusim, fmuCheck, ecos) and in our own C
host are tests/harness/test_travel.py (with every Python hidden). Here each case changes one thing
in a copy of SpurDifferential.fmu: the runtime description (tests of runtime_cfg.h's strict
reading: long lines, a special file, duplicate or unknown keys, absolute or escaping paths, a
missing key, another format), the runtime itself (a missing libpython, a libpython of another
version than described), or the host's environment (PYTHONHOME, PYTHONPATH and a
planted ``numpy.py`` that must not run). fmusim (bare environment, from ../shared/hosts; skipped
with that reason where absent) must exit with its failure code (not a signal), print the cause
our loader logged, and leave the planted file unexecuted.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parents[1]   # tests/
HOSTS = HERE.parent.parent / "shared" / "hosts"
BARE_ENV = {"PATH": "/usr/bin:/bin"}
CFG = "resources/python_runtime.cfg"

# fmusim's tests skip where it is absent (../shared/hosts no longer carries it); their cases run in
# our own C host in test_damaged_runtime_own_host.py; the FIFO test needs no external host
NEED_FMUSIM = pytest.mark.skipif(not (HOSTS / "fmusim").is_file(), reason=f"{HOSTS}/fmusim is absent")


def _copy(fmu: Path, out: Path, change) -> Path:
    """The FMU with `change(name, data) -> data | None` applied to each member (None drops it); stored,
    not compressed (no time spent on compression)."""
    with zipfile.ZipFile(fmu) as zin, zipfile.ZipFile(out, "w", zipfile.ZIP_STORED) as zout:
        for item in zin.infolist():
            data = change(item.filename, zin.read(item))
            if data is not None:
                item.compress_type = zipfile.ZIP_STORED
                zout.writestr(item, data)
    return out


def _cfg(change):
    def f(name, data):
        return change(data) if name == CFG else data
    return f


def _fmusim(fmu: Path, cwd: Path, env=None) -> subprocess.CompletedProcess:
    return subprocess.run([str(HOSTS / "fmusim"), "--interface-type", "cs", "--stop-time", "0.01",
                           "--output-file", str(cwd / "o.csv"), str(fmu)], cwd=cwd, env=env or BARE_ENV,
                          capture_output=True, text=True, timeout=120)


def _other_digest(data: bytes) -> bytes:
    """The description with the first archive's SHA-256 changed in its first digit."""
    at = data.index(b"archive=") + len(b"archive=")
    return data[:at] + (b"1" if data[at:at + 1] == b"0" else b"0") + data[at + 1:]


def _damaged_archive(member: str = "resources/runtime/linux64.zip"):
    """A change flipping one byte in the middle of ``member`` (a stored archive before the description
    in the FMU) and naming the damaged bytes' SHA-256 in the runtime description."""
    said = {}

    def f(name, data):
        if name == member:
            damaged = bytearray(data)
            damaged[len(damaged) // 2] ^= 0xFF
            said["new"] = hashlib.sha256(bytes(damaged)).hexdigest()
            return bytes(damaged)
        if name == CFG:
            tail = b" " + member.split("resources/", 1)[1].encode()
            return b"\n".join(b"archive=" + said["new"].encode() + tail if ln.endswith(tail) else ln
                               for ln in data.split(b"\n"))
        return data
    return f


def _line(key: str, value: str):
    return lambda data: b"\n".join(f"{key}={value}".encode() if ln.startswith(f"{key}=".encode()) else ln
                                   for ln in data.split(b"\n"))


CASES = {
    "a line over 4095 bytes": (_cfg(lambda d: d + b"# " + b"x" * 5000 + b"\nguid=hidden\n"), "longer than 4095 bytes"),
    "a duplicate key": (_cfg(lambda d: d + b"class=Other\n"), "'class' given twice"),
    "an unknown key": (_cfg(lambda d: d + b"executable=/usr/bin/python3\n"), "unknown key 'executable'"),
    "an absolute path": (_cfg(_line("libpython", "/usr/lib/libpython3.11.so.1.0")), "'libpython' must be a relative"),
    "a path out of the FMU": (_cfg(lambda d: d + b"path=python/../../../../tmp\n"), "'path' must be a relative"),
    "a missing key": (_cfg(lambda d: b"\n".join(ln for ln in d.split(b"\n") if not ln.startswith(b"package="))),
                      "lacks one of"),
    "another format": (_cfg(_line("format", "1")), "has format 1 where this loader reads format 2"),
    "a line that is not key=value": (_cfg(lambda d: d + b"just some text\n"), "is not key=value"),
    # the runtime's archives (fmu_src/native/fmi/runtime_unpack.h): a digest that names other bytes (so a
    # folder of its own, unpacked afresh and refused before a byte is written), and damaged bytes whose
    # digest the description names (unpacked afresh too; the damaged member is refused)
    "a runtime archive of another digest": (_cfg(_other_digest), "has SHA-256"),
    "an archive line without its digest": (_cfg(lambda d: d + b"archive=runtime/other.zip\n"),
                                           "'archive' must be a SHA-256"),
    "an archive out of the FMU": (_cfg(lambda d: d + b"archive=" + b"0" * 64 + b" ../../../etc/x.zip\n"),
                                  "'archive' must be a SHA-256 (64 hex digits), a space and a relative path"),
    "a damaged runtime archive": (_damaged_archive(), "does not unpack to its size and CRC-32"),
    "libpython of another version than described": (_cfg(_line("version", "3.10")), "the FMU's runtime description says 3.10"),
}


@NEED_FMUSIM
@pytest.mark.parametrize("case", list(CASES))
def test_a_damaged_runtime_is_refused_with_the_cause(case, differential_fmu, tmp_path):
    change, cause = CASES[case]
    fmu = _copy(differential_fmu, tmp_path / "SpurDifferential.fmu", change)
    r = _fmusim(fmu, tmp_path)
    text = r.stdout + r.stderr
    # fmusim's code for an FMU it cannot instantiate (a signal would be negative)
    assert r.returncode == 3, f"{case}: expected fmusim's clean failure (3), got exit {r.returncode}\n{text[-3000:]}"
    assert cause in text, f"{case}: the cause is not named\n{text[-3000:]}"


def test_the_description_as_a_special_file_is_refused_at_once(differential_fmu, tmp_path):
    """A FIFO in the description's place (which would block a reader) and /dev/zero (endless)."""
    for special in ("fifo", "/dev/zero"):
        unpacked = tmp_path / special.strip("/").replace("/", "_")
        with zipfile.ZipFile(differential_fmu) as z:
            z.extractall(unpacked)
        cfg = unpacked / CFG
        cfg.unlink()
        if special == "fifo":
            os.mkfifo(cfg)
        else:
            cfg.symlink_to(special)
        # fmusim unpacks archives, which cannot hold a FIFO: drive our loader through fmpy's C calls
        code = ("import sys\nfrom fmpy import read_model_description\nfrom fmpy.fmi2 import FMU2Slave\n"
                "md = read_model_description(sys.argv[1])\n"
                "f = FMU2Slave(guid=md.guid, unzipDirectory=sys.argv[1], modelIdentifier='SpurDifferential')\n"
                "try:\n    f.instantiate()\n    print('INSTANTIATED')\n"
                "except Exception as e:\n    print('REFUSED', e)\n")   # fmpy prints the FMU's log to stdout
        r = subprocess.run([sys.executable, "-c", code, str(unpacked)], capture_output=True, text=True, timeout=30)
        assert "REFUSED" in r.stdout and "is not a regular file" in r.stdout, r.stdout + r.stderr
        shutil.rmtree(unpacked)


def planted_env(where: Path) -> tuple[dict, Path]:
    """A bare environment whose PYTHONHOME, PYTHONPATH, PYTHONSTARTUP and PYTHONUSERBASE name a folder
    with a planted numpy.py, sitecustomize.py, ... (the same files in ``where``, the working folder);
    and the file any of them creates when it runs."""
    evil = where / "evil"
    evil.mkdir()
    marker = where / "RAN"
    payload = f"open({str(marker)!r}, 'w').write('planted code ran')\n"
    for name in ("numpy.py", "sitecustomize.py", "usercustomize.py", "encodings.py", "startup.py"):
        (evil / name).write_text(payload)
        (where / name).write_text(payload)
    env = {**BARE_ENV, "PYTHONPATH": str(evil), "PYTHONHOME": str(evil), "PYTHONSTARTUP": str(evil / "startup.py"),
           "PYTHONUSERBASE": str(evil)}
    return env, marker


@NEED_FMUSIM
def test_the_hosts_python_variables_and_planted_files_do_not_reach_the_fmu(differential_fmu, tmp_path):
    """PYTHONHOME, PYTHONPATH, PYTHONSTARTUP pointing at a folder with a planted numpy.py and
    sitecustomize.py, and the same files in the working folder: none runs, the FMU runs."""
    env, marker = planted_env(tmp_path)
    r = _fmusim(differential_fmu, tmp_path, env=env)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    assert not marker.exists(), "a planted file ran inside the FMU"


@pytest.mark.skipif(not (HOSTS / "fmuCheck.linux64").is_file(), reason=f"{HOSTS}/fmuCheck.linux64 is absent")
def test_fmucheck_exits_1_naming_the_cause(differential_fmu, tmp_path):
    fmu = _copy(differential_fmu, tmp_path / "SpurDifferential.fmu", CASES["a damaged runtime archive"][0])
    r = subprocess.run([str(HOSTS / "fmuCheck.linux64"), "-k", "cs", "-s", "0.01", str(fmu)], cwd=tmp_path,
                       env=BARE_ENV, capture_output=True, text=True, timeout=120)
    text = r.stdout + r.stderr
    assert r.returncode == 1 and CASES["a damaged runtime archive"][1] in text, text[-3000:]
