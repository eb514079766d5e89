"""fmu_src/native/fmi/runtime_unpack.h: the runtime's archives unpacked once per user and runtime
(issue 44 item 1). The header's functions, compiled here into a test library (ctypes), against
Python's zlib and hashlib; the folder's rules (private, atomic, verified, nothing left on a refusal)
through ru_runtime_root with SPURDIFF_FMU_RUNTIME_DIR (and the user cache's fallback) set in this
process. The built FMUs' own use of it: tests/harness/test_hosts.py (damaged archives) and every
host test that starts the FMU's Python."""
from __future__ import annotations

import ctypes
import hashlib
import io
import multiprocessing
import os
import shutil
import stat
import subprocess
import time
import zipfile
import zlib
from pathlib import Path

import pytest

from harness.common.paths import fmu_sources

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler (gcc) for the test library")

SOURCE = r"""
#define _GNU_SOURCE
#include "runtime_cfg.h"
int t_inflate(const uint8_t *in, size_t n, uint8_t *out, size_t m) { return ru_inflate(in, n, out, m); }
int t_unlzma(const uint8_t *in, size_t n, uint8_t *out, size_t m) { return ru_unlzma(in, n, out, m); }
void t_sha(const uint8_t *in, size_t n, char *hex) { RuSha s; ru_sha_init(&s); ru_sha_add(&s, in, n); ru_sha_hex(&s, hex); }
unsigned t_crc(const uint8_t *in, size_t n) { return ru_crc32(in, n); }
int t_root(const char *res, int n, char **rel, char **hex, char *out, size_t size, char *err, size_t es)
{ return ru_runtime_root(res, n, rel, hex, out, size, err, es); }
"""
ENV = "SPURDIFF_FMU_RUNTIME_DIR"


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    folder = tmp_path_factory.mktemp("unpack lib")
    (folder / "t.c").write_text(SOURCE)
    fmi = fmu_sources() / "native" / "fmi"
    r = subprocess.run(["gcc", "-O2", "-Wall", "-Werror", "-shared", "-fPIC", f"-I{fmi}", str(folder / "t.c"),
                        "-o", str(folder / "t.so")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    so = ctypes.CDLL(str(folder / "t.so"))
    so.t_inflate.argtypes = [ctypes.c_char_p, ctypes.c_size_t, ctypes.c_char_p, ctypes.c_size_t]
    so.t_unlzma.argtypes = [ctypes.c_char_p, ctypes.c_size_t, ctypes.c_char_p, ctypes.c_size_t]
    so.t_sha.argtypes = [ctypes.c_char_p, ctypes.c_size_t, ctypes.c_char_p]
    so.t_crc.argtypes = [ctypes.c_char_p, ctypes.c_size_t]
    so.t_crc.restype = ctypes.c_uint
    return so


def _inflate(lib, raw: bytes, n: int) -> tuple[int, bytes]:
    out = ctypes.create_string_buffer(max(n, 1))
    return lib.t_inflate(raw, len(raw), out, n), out.raw[:n]


def _samples() -> list[bytes]:
    rnd = __import__("random").Random(7)
    text = (fmu_sources() / "native" / "fmi" / "runtime_unpack.h").read_bytes()
    return [b"", b"x", bytes(rnd.getrandbits(8) for _ in range(70000)), b"abc" * 40000, text,
            bytes(rnd.choice(b"ab") for _ in range(200000)), Path(zlib.__file__ or "/bin/sh").read_bytes()
            if zlib.__file__ else text * 3]


def test_inflate_gives_zlibs_input_back_for_every_level_and_strategy(lib):
    for data in _samples():
        for level in (0, 1, 6, 9):
            for strategy in (zlib.Z_DEFAULT_STRATEGY, zlib.Z_FIXED, zlib.Z_HUFFMAN_ONLY, zlib.Z_RLE, zlib.Z_FILTERED):
                c = zlib.compressobj(level, zlib.DEFLATED, -15, 9, strategy)
                raw = c.compress(data) + c.flush()
                rc, out = _inflate(lib, raw, len(data))
                assert rc == 0 and out == data, (len(data), level, strategy)


def test_inflate_refuses_short_long_and_garbled_streams(lib):
    data = _samples()[4]
    raw = zlib.compress(data, 9)[2:-4]
    assert _inflate(lib, raw, len(data) - 1)[0] != 0          # more output than room
    assert _inflate(lib, raw, len(data) + 1)[0] != 0          # less output than announced
    assert _inflate(lib, raw[:-3], len(data))[0] != 0         # the stream cut short
    rnd = __import__("random").Random(3)
    for _ in range(300):                                      # garbled: refused or wrong, never a crash
        bad = bytearray(raw)
        for _ in range(4):
            bad[rnd.randrange(len(bad))] = rnd.getrandbits(8)
        rc, out = _inflate(lib, bytes(bad), len(data))
        assert rc != 0 or len(out) == len(data)
    assert _inflate(lib, b"\x07", 10)[0] != 0                # block type 3 does not exist


def _lzma_member(data: bytes, filters: dict | None = None) -> bytes:
    """``data`` as the LZMA data of a zip member of method 14: version, the properties' size and the
    properties, then the raw LZMA1 stream with its end marker (as zipfile writes it)."""
    import lzma
    f = {"id": lzma.FILTER_LZMA1, **(filters or {})}
    props = lzma._encode_filter_properties(f)
    return bytes([9, 4, len(props), 0]) + props + lzma.compress(data, format=lzma.FORMAT_RAW, filters=[f])


def _unlzma(lib, member: bytes, n: int) -> tuple[int, bytes]:
    out = ctypes.create_string_buffer(max(n, 1))
    return lib.t_unlzma(member, len(member), out, n), out.raw[:n]


def test_unlzma_gives_lzmas_input_back_for_presets_and_properties(lib):
    import lzma
    for data in _samples():
        for f in ({"preset": 0}, {"preset": 6}, {"preset": 9 | lzma.PRESET_EXTREME}, {"lc": 0, "lp": 2, "pb": 0},
                  {"lc": 4, "lp": 0, "pb": 4}, {"lc": 0, "lp": 4, "pb": 1, "dict_size": 4096}, {"mode": lzma.MODE_FAST}):
            rc, out = _unlzma(lib, _lzma_member(data, f), len(data))
            assert rc == 0 and out == data, (len(data), f)
    # what the packer writes: zipfile's LZMA members (the end marker flagged)
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_LZMA) as z:
        z.writestr("a", _samples()[4])
    with zipfile.ZipFile(buf) as z:
        info = z.infolist()[0]
        assert info.compress_type == zipfile.ZIP_LZMA and info.flag_bits & 2
        raw = buf.getvalue()[info.header_offset + 30 + len(info.filename) + len(info.extra):][:info.compress_size]
    rc, out = _unlzma(lib, raw, info.file_size)
    assert rc == 0 and out == _samples()[4]


def test_unlzma_refuses_short_long_and_garbled_streams(lib):
    data = _samples()[4]
    member = _lzma_member(data)
    assert _unlzma(lib, member, len(data) - 1)[0] != 0          # more output than room
    assert _unlzma(lib, member, len(data) + 1)[0] != 0          # less output than announced
    assert _unlzma(lib, member[:-3], len(data))[0] != 0         # the stream cut short
    assert _unlzma(lib, member[:40], len(data))[0] != 0
    assert _unlzma(lib, b"\x09\x04\x05\x00\xff" + member[5:], len(data))[0] != 0   # lc/lp/pb out of range
    assert _unlzma(lib, b"\x09\x04\x06\x00" + member[4:], len(data))[0] != 0    # properties of another size
    assert _unlzma(lib, b"", 0)[0] != 0
    rnd = __import__("random").Random(5)
    for _ in range(300):                                        # garbled: refused or wrong, never a crash
        bad = bytearray(member)
        for _ in range(4):
            bad[rnd.randrange(9, len(bad))] = rnd.getrandbits(8)
        rc, out = _unlzma(lib, bytes(bad), len(data))
        assert rc != 0 or len(out) == len(data)
    for _ in range(200):                                        # random bytes after a valid header
        junk = member[:9] + bytes([0]) + bytes(rnd.getrandbits(8) for _ in range(rnd.randrange(4, 400)))
        _unlzma(lib, junk, rnd.randrange(0, 5000))


def test_sha256_and_crc32_agree_with_hashlib_and_zlib(lib):
    for data in _samples() + [b"a" * n for n in range(0, 130, 7)]:
        hexd = ctypes.create_string_buffer(65)
        lib.t_sha(data, len(data), hexd)
        assert hexd.value.decode() == hashlib.sha256(data).hexdigest()
        assert lib.t_crc(data, len(data)) == zlib.crc32(data)


# ------------------------------------------------------------------------------------------ the folder
def _archive(members: dict[str, bytes], modes: dict[str, int] | None = None) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in members.items():
            info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_STORED if name.endswith("/") or name.endswith(".st") else zipfile.ZIP_DEFLATED
            info.external_attr = ((modes or {}).get(name, 0o644) | (0o40000 if name.endswith("/") else 0o100000)) << 16
            z.writestr(info, data)
    return buf.getvalue()


RUNTIME = {"python/": b"", "python/lib/libpython.so": os.urandom(5000) + b"\0" * 20000,
           "python/lib/stored.st": b"stored as is", "python/lib/x/y/deep.txt": b"deep" * 1000}


def _resources(tmp_path: Path, archives: dict[str, bytes]) -> tuple[Path, list[str], list[str]]:
    res = tmp_path / "resources ü"
    (res / "runtime").mkdir(parents=True)
    rels, hexes = [], []
    for name, data in archives.items():
        (res / "runtime" / name).write_bytes(data)
        rels.append(f"runtime/{name}")
        hexes.append(hashlib.sha256(data).hexdigest())
    return res, rels, hexes


def _root(lib, res: Path, rels: list[str], hexes: list[str]) -> tuple[int, str, str]:
    out = ctypes.create_string_buffer(8192)
    err = ctypes.create_string_buffer(8192)
    arr = ctypes.c_char_p * len(rels)
    rc = lib.t_root(str(res).encode(), len(rels), arr(*(r.encode() for r in rels)), arr(*(h.encode() for h in hexes)),
                    out, 8192, err, 8192)
    return rc, out.value.decode(), err.value.decode()


@pytest.fixture
def base(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv(ENV, str(folder))
    return folder


def test_unpacks_once_privately_and_verified(lib, tmp_path, base):
    res, rels, hexes = _resources(tmp_path, {"common.zip": _archive({"python/lib/std.zip": b"std" * 999}),
                                             "linux64.zip": _archive(RUNTIME, {"python/lib/libpython.so": 0o755})})
    rc, out, err = _root(lib, res, rels, hexes)
    assert rc == 0, err
    root = Path(out)
    key = hashlib.sha256("".join(h + "\n" for h in hexes).encode()).hexdigest()
    assert root == base / f"python-{key[:16]}"
    assert (root / ".spurdiff-runtime").read_text() == key + "\n"
    assert (root / "python/lib/std.zip").read_bytes() == b"std" * 999
    for name, data in RUNTIME.items():
        if not name.endswith("/"):
            assert (root / name).read_bytes() == data
    for p in [root, *root.rglob("*")]:
        mode = stat.S_IMODE(p.lstat().st_mode)
        assert mode & 0o077 == 0, (p, oct(mode))                 # nothing for group or others
    assert stat.S_IMODE((root / "python/lib/libpython.so").stat().st_mode) == 0o700
    assert stat.S_IMODE(base.stat().st_mode) == 0o700
    assert [p.name for p in base.iterdir()] == [root.name]       # no temporary folder left
    # the second start finds it: nothing written again, its marker touched (used now)
    lib_inode = (root / "python/lib/libpython.so").stat().st_ino
    os.utime(root / ".spurdiff-runtime", (1e9, 1e9))
    (res / rels[1]).write_bytes(b"not read again")               # (a used folder is not re-verified)
    rc, again, err = _root(lib, res, rels, hexes)
    assert rc == 0 and again == out and (root / "python/lib/libpython.so").stat().st_ino == lib_inode, err
    assert (root / ".spurdiff-runtime").stat().st_mtime > 1e9 + 1


def test_a_damaged_or_foreign_archive_is_refused_and_nothing_is_left(lib, tmp_path, base):
    good = _archive(RUNTIME)
    cases = {
        "a digest of other bytes": ({"linux64.zip": good}, lambda h: ["0" * 64], "has SHA-256"),
        "a flipped byte": ({"linux64.zip": good[:200] + bytes([good[200] ^ 0xFF]) + good[201:]}, None,
                           "does not unpack to its size and CRC-32"),
        "a name out of the folder": ({"linux64.zip": _archive({"python/../../escape": b"x"})}, None,
                                     "is not a relative name inside the folder"),
        "an absolute name": ({"linux64.zip": _archive({"/tmp/escape": b"x"})}, None, "is not a relative name"),
        "a backslash": ({"linux64.zip": _archive({"python\\..\\escape": b"x"})}, None, "is not a relative name"),
        "not a zip": ({"linux64.zip": b"PK\x03\x04 but nothing else"}, None, "is not a zip archive"),
    }
    for case, (archives, hexes_of, said) in cases.items():
        sub = tmp_path / case
        sub.mkdir()
        res, rels, hexes = _resources(sub, archives)
        rc, _, err = _root(lib, res, rels, hexes_of(hexes) if hexes_of else hexes)
        assert rc != 0 and said in err, (case, err)
        assert not base.exists() or list(base.iterdir()) == [], (case, list(base.iterdir()))
    assert not (tmp_path / "escape").exists() and not Path("/tmp/escape").exists()


def test_a_folder_not_to_be_trusted_is_refused_never_deleted(lib, tmp_path, base):
    res, rels, hexes = _resources(tmp_path, {"linux64.zip": _archive(RUNTIME)})
    rc, out, err = _root(lib, res, rels, hexes)
    assert rc == 0, err
    root = Path(out)
    (root / ".spurdiff-runtime").write_text("0" * 64 + "\n")       # another runtime's marker
    rc, _, err = _root(lib, res, rels, hexes)
    assert rc != 0 and "does not name this runtime" in err and root.is_dir()
    (root / ".spurdiff-runtime").write_text(hashlib.sha256("".join(h + "\n" for h in hexes).encode()).hexdigest() + "\n")
    root.chmod(0o755)                                             # open to others
    rc, _, err = _root(lib, res, rels, hexes)
    assert rc != 0 and "mode 755" in err and root.is_dir()
    root.chmod(0o700)
    aside = root.with_name("elsewhere")
    root.rename(aside)
    root.symlink_to(aside)                                        # a link in its place
    rc, _, err = _root(lib, res, rels, hexes)
    assert rc != 0 and "not a folder" in err and root.is_symlink()
    root.unlink()
    base.chmod(0o755)                                             # the base folder open to others
    rc, _, err = _root(lib, res, rels, hexes)
    assert rc != 0 and "mode 755" in err and str(base) in err
    base.chmod(0o700)


def test_the_folder_variable_must_be_absolute(lib, tmp_path, monkeypatch):
    res, rels, hexes = _resources(tmp_path, {"linux64.zip": _archive(RUNTIME)})
    monkeypatch.setenv(ENV, "relative/cache")
    rc, _, err = _root(lib, res, rels, hexes)
    assert rc != 0 and f"{ENV}=relative/cache is not an absolute path" in err


def test_without_a_usable_user_cache_the_private_temporary_folder(lib, tmp_path, monkeypatch):
    """XDG_CACHE_HOME below a file (no folder can be made there): $TMPDIR/spurdiff-<uid>, made private."""
    res, rels, hexes = _resources(tmp_path, {"linux64.zip": _archive(RUNTIME)})
    (tmp_path / "a file").write_text("")
    monkeypatch.delenv(ENV, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "a file" / "cache"))
    monkeypatch.setenv("TMPDIR", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    rc, out, err = _root(lib, res, rels, hexes)
    assert rc == 0, err
    fallback = tmp_path / "tmp" / f"spurdiff-{os.geteuid()}"
    assert Path(out).parent == fallback and stat.S_IMODE(fallback.stat().st_mode) == 0o700
    fallback.chmod(0o777)                                         # not private any more: refused, naming both
    rc, _, err = _root(lib, res, rels, hexes)
    assert rc != 0 and "cannot be made" in err and "mode 777" in err


def _unpack_in_child(args) -> tuple[int, str, str]:
    so_path, res, rels, hexes = args
    lib = ctypes.CDLL(so_path)
    return _root(lib, Path(res), rels, hexes)


def test_processes_unpacking_at_once_share_one_folder(lib, tmp_path, base):
    big = {f"python/lib/m{i}.bin": os.urandom(20000) * 20 for i in range(12)}
    res, rels, hexes = _resources(tmp_path, {"linux64.zip": _archive(big)})
    ctx = multiprocessing.get_context("fork")
    with ctx.Pool(4) as pool:
        results = pool.map(_unpack_in_child, [(lib._name, str(res), rels, hexes)] * 8)
    outs = {out for rc, out, err in results}
    assert all(rc == 0 for rc, _, _ in results), results
    assert len(outs) == 1 and [p.name for p in base.iterdir()] == [Path(outs.pop()).name]   # one folder, no leftovers


def test_a_folder_under_one_others_can_write_is_refused(lib, tmp_path, monkeypatch):
    """Another user could move the cache away from under it and put theirs in its place: a folder above
    that others may write (not sticky) refuses the place; sticky (as /tmp) is allowed."""
    res, rels, hexes = _resources(tmp_path, {"linux64.zip": _archive(RUNTIME)})
    shared = tmp_path / "shared"
    shared.mkdir()
    monkeypatch.setenv(ENV, str(shared / "mine" / "cache"))
    shared.chmod(0o777)
    try:
        rc, _, err = _root(lib, res, rels, hexes)
        assert rc != 0 and f"the folder above it, {shared}, is writable by others (mode 777, not sticky)" in err, err
        shared.chmod(0o1777)
        rc, out, err = _root(lib, res, rels, hexes)
        assert rc == 0 and Path(out).parent == shared / "mine" / "cache", err
    finally:
        shared.chmod(0o700)


def test_a_killed_unpacks_leftovers_and_long_unused_runtimes_are_swept_and_nothing_else(lib, tmp_path, base):
    """A temporary folder of a process that died ten minutes ago, and another runtime's folder (or an earlier
    build's numpy folder) no start used for 30 days, are removed at the next unpack; one of a living process,
    a fresh one, a runtime or numpy used 10 days ago, one without its marker and anything not named like ours stay."""
    res, rels, hexes = _resources(tmp_path, {"linux64.zip": _archive(RUNTIME)})
    base.mkdir(mode=0o700)
    dead = _a_dead_pid()
    old = 1e9   # 2001
    made = {}
    for label, pid, when in (("dead", dead, old), ("alive", os.getpid(), old), ("young", dead, None)):
        d = base / f".python-{'a' * 16}.{pid}.{len(made) + 1}"
        (d / "python" / "lib").mkdir(parents=True)
        (d / "python" / "lib" / "f").write_bytes(b"x")
        if when:
            os.utime(d, (when, when))
        made[label] = d
    other = base / "not-ours"
    other.mkdir()
    runtimes = {}
    # other runtimes' folders, and the numpy folders of earlier builds
    for kind, marker in (("python", ".spurdiff-runtime"), ("numpy", ".spurdiff-numpy")):
        for days in (40, 10):
            d = base / f"{kind}-{days:016x}"
            (d / kind).mkdir(parents=True)
            (d / marker).write_text(f"{days:064x}\n")
            os.utime(d / marker, (time.time() - days * 86400,) * 2)
            runtimes[f"{kind} unused {days} days"] = d
    unmarked = base / f"numpy-{'b' * 16}"           # no marker: not one of ours, stays
    unmarked.mkdir()
    os.utime(unmarked, (old, old))
    rc, out, err = _root(lib, res, rels, hexes)
    assert rc == 0, err
    assert not made["dead"].exists() and made["alive"].is_dir() and made["young"].is_dir() and other.is_dir()
    for kind in ("python", "numpy"):
        assert not runtimes[f"{kind} unused 40 days"].exists() and runtimes[f"{kind} unused 10 days"].is_dir()
    assert unmarked.is_dir()


def _a_dead_pid() -> int:
    p = subprocess.Popen(["true"])
    p.wait()
    return p.pid
