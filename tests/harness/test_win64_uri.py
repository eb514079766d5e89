"""The win64 loader under wine (issue 44 item 5): the resource URI of a folder named with 'ü' resolves
whether the host writes its path in UTF-8 or in the ANSI code page (Windows-1252 here: 'ü' is the byte
0xFC, which is not UTF-8), percent-encoded or not (fmu_src/native/fmi/platform.h: plat_path_utf8).
The host (tests/c_host/fmi2_any_host.c) reads its arguments as UTF-16, so the ANSI forms reach the
FMU percent-encoded; the not-encoded UTF-8 form as the character itself.

A host whose standard streams are regular files starts the FMU's Python, and what that Python reads
and writes on them is the host's files (fmu_src/native/fmi/win_stdio.h: under wine such handles are
ones CPython's io.FileIO refuses)."""
from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from tests.harness.test_win64 import MINGW,  CASES, ODD, _args, _outputs, _run, hosts, unpacked, wine  # noqa: F401

FORMS = {   # how the host writes C:/<ODD>/<name>/resources
    "UTF-8, percent-encoded": lambda p: p.encode("utf-8"),
    "UTF-8, as it is": None,
    "ANSI (Windows-1252), percent-encoded": lambda p: p.encode("cp1252"),
}


def _uri(name: str, form: str) -> str:
    path = f"{ODD}/{name}/resources"
    enc = FORMS[form]
    if enc is None:
        return "file:///C:/" + path
    return "file:///C:/" + "".join(chr(b) if b < 128 and (chr(b).isalnum() or chr(b) in "/-_.") else f"%{b:02X}"
                                   for b in enc(path))


@pytest.mark.parametrize("form", list(FORMS))
def test_the_resource_uri_resolves_in_either_encoding(form, wine, hosts, unpacked):
    env, _ = wine
    exe, _ = hosts
    name = "SpurDifferential"
    folder = unpacked[name]
    guid, timing, outs, sets = _args(folder, name)
    binary = "C:\\" + ODD + "\\" + name + "\\binaries\\win64\\" + name + ".dll"
    r = _run(["wine", str(exe), binary, *guid, _uri(name, form), *timing, "1", *sets, "get", str(outs[0])],
             env=env)
    assert r.returncode == 0, r.stdout[-3000:]
    assert len(_outputs(r.stdout)) == 1
    assert "does not exist" not in r.stdout


def test_a_host_whose_stdout_and_stderr_are_regular_files_starts_the_python(wine, hosts, unpacked, tmp_path):
    """The host's standard streams are files (a CI job's log, a service): the FMU's Python starts."""
    env, _ = wine
    exe, _ = hosts
    name = "SpurDifferential"
    guid, timing, outs, sets = _args(unpacked[name], name)
    binary = "C:\\" + ODD + "\\" + name + "\\binaries\\win64\\" + name + ".dll"
    out, err = tmp_path / "out.txt", tmp_path / "err.txt"
    with open(out, "w") as fo, open(err, "w") as fe:
        r = subprocess.run(["wine", str(exe), binary, *guid, _uri(name, "UTF-8, percent-encoded"), *timing, "1",
                            *sets, "get", str(outs[0])], stdin=subprocess.DEVNULL, stdout=fo, stderr=fe, env=env,
                           timeout=600)
    text = out.read_text(errors="replace") + err.read_text(errors="replace")
    assert r.returncode == 0, text[-3000:]
    assert len(_outputs(out.read_text(errors="replace"))) == 1, text[-3000:]


def test_what_the_fmu_python_reads_and_writes_is_the_host_files(wine, unpacked, tmp_path):
    """The streams are the host's files, not NUL: a probe (tests/c_host/win_streams_probe.c) with stdin,
    stdout and stderr regular files instantiates the FMU, then runs code in the FMU's Python that reads
    a line from sys.stdin and writes to sys.stdout and sys.stderr."""
    from harness.build.fmu import _fmi2_headers

    env, _ = wine
    env = {**env, "SPURDIFF_FMU_START": "python"}   # the probe runs code in the FMU's Python
    exe = tmp_path / "win_streams_probe.exe"
    subprocess.run([MINGW, "-O2", "-Wall", "-municode", "-static", f"-I{_fmi2_headers()}", "-o", str(exe),
                    str(Path(__file__).resolve().parents[1] / "c_host" / "win_streams_probe.c")], check=True)
    name = "SpurDifferential"
    guid, _, _, _ = _args(unpacked[name], name)
    binary = "C:\\" + ODD + "\\" + name + "\\binaries\\win64\\" + name + ".dll"
    code = ("import sys; line = sys.stdin.readline().strip(); print('python read:', line); sys.stdout.flush(); "
            "sys.stderr.write('python to stderr\\n'); sys.stderr.flush()")
    src, out, err = tmp_path / "in.txt", tmp_path / "out.txt", tmp_path / "err.txt"
    src.write_text("a line from the host's stdin\n")
    with open(src) as fi, open(out, "w") as fo, open(err, "w") as fe:
        r = subprocess.run(["wine", str(exe), binary, *guid, _uri(name, "UTF-8, percent-encoded"), code],
                           stdin=fi, stdout=fo, stderr=fe, env=env, timeout=600)
    said, complained = out.read_text(errors="replace"), err.read_text(errors="replace")
    assert r.returncode == 0, (said + complained)[-3000:]
    assert "python read: a line from the host's stdin" in said.splitlines(), said
    assert "python to stderr" in complained.splitlines(), complained
