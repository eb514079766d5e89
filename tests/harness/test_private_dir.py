"""Issue 45 item 1: every cache or scratch place is private to the user, and nothing another local
user plants there is used or run (harness/common/private_dir.py and each place that uses it: the kit's
bare C host, the sweep's FMU snapshots, the FMU runtime cache, the win64 downloads and runtimes, the
per-user cache root and its temporary-folder fallback).

The plants: a folder owned by another user (``nobody``, made with ``os.chown``: needs root, else
skipped), a folder of ours others may write to, a symbolic link to a folder of ours, a file where
the folder should be, a parent folder others may write to (not sticky), and, inside a private
folder, a file of the right size (or a planted program) whose digest is not the one recorded.
"""
from __future__ import annotations

import os
import pwd
import stat
import subprocess
import tempfile
from pathlib import Path

import pytest

from harness.common import private_dir as pd
from harness.common.private_dir import PrivatePlaceError

as_root = pytest.mark.skipif(os.geteuid() != 0, reason="planting as another user needs root (os.chown)")


def _nobody() -> int:
    try:
        return pwd.getpwnam("nobody").pw_uid
    except KeyError:
        return 65534


def _plant(place: Path, how: str) -> None:
    """``place`` made the way ``how`` names (another user's, open to others, a link, a file)."""
    place.parent.mkdir(parents=True, exist_ok=True)
    if how == "other-user":
        place.mkdir(mode=0o755)
        os.chown(place, _nobody(), _nobody())
    elif how == "group-writable":
        place.mkdir()
        os.chmod(place, 0o775)
    elif how == "world-writable":
        place.mkdir()
        os.chmod(place, 0o777)
    elif how == "symlink":
        target = place.parent / f"elsewhere-{place.name}"
        target.mkdir(mode=0o700)
        place.symlink_to(target)
    elif how == "file":
        place.write_bytes(b"#!/bin/sh\n")
    elif how == "open-parent":
        os.chmod(place.parent, 0o777)
        place.mkdir(mode=0o700)
    else:
        raise AssertionError(how)


PLANTS = ["group-writable", "world-writable", "symlink", "file", "open-parent",
          pytest.param("other-user", marks=as_root)]


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    """SPURDIFF_CACHE pointed at a fresh folder under the test's own folder."""
    root = tmp_path / "home" / "cache"
    root.parent.mkdir(mode=0o700)
    monkeypatch.setenv("SPURDIFF_CACHE", str(root))
    return root


# ----------------------------------------------------------------------------- the module itself

def test_a_new_folder_is_0700_with_its_missing_parents(tmp_path):
    p = pd.private_dir(tmp_path / "a" / "b" / "c")
    for d in (tmp_path / "a", tmp_path / "a" / "b", p):
        assert stat.S_IMODE(os.lstat(d).st_mode) == 0o700
    assert pd.private_dir(p) == p    # a second use accepts it


def test_a_folder_of_ours_only_readable_by_others_is_tightened(tmp_path):
    d = tmp_path / "ours"
    d.mkdir(mode=0o755)
    os.chmod(d, 0o755)
    pd.private_dir(d)
    assert stat.S_IMODE(os.lstat(d).st_mode) == 0o700


@pytest.mark.parametrize("how", PLANTS)
def test_a_planted_folder_is_refused_with_one_line_naming_it(tmp_path, how):
    place = tmp_path / "base" / "cache"
    (tmp_path / "base").mkdir(mode=0o700)
    _plant(place, how)
    with pytest.raises(PrivatePlaceError) as e:
        pd.private_dir(place)
    msg = str(e.value)
    assert "\n" not in msg and str(place) in msg


def test_a_parent_writable_by_the_users_own_group_is_accepted(tmp_path):
    """A umask of 002 makes ~/.cache 0775 with the user's own group: not another user's place."""
    base = tmp_path / "cache"
    base.mkdir()
    os.chmod(base, 0o775)
    os.chown(base, -1, os.getegid())
    assert pd.private_dir(base / "x") == base / "x"


@as_root
def test_a_parent_writable_by_another_group_is_refused(tmp_path):
    base = tmp_path / "cache"
    base.mkdir()
    os.chmod(base, 0o775)
    os.chown(base, -1, os.getegid() + 4242)
    with pytest.raises(PrivatePlaceError):
        pd.private_dir(base / "x")


def test_a_sticky_open_parent_is_accepted(tmp_path):
    base = tmp_path / "tmp"
    base.mkdir()
    os.chmod(base, 0o1777)
    assert pd.private_dir(base / "x") == base / "x"


def test_verified_file_goes_by_digest_never_by_size(tmp_path):
    d = pd.private_dir(tmp_path / "d")
    good = b"the real bytes"
    digest = __import__("hashlib").sha256(good).hexdigest()
    f = d / "f"
    f.write_bytes(b"planted bytes!")   # the same size
    assert len(f.read_bytes()) == len(good) and not pd.verified_file(f, digest)
    pd.write_private(f, good)
    assert pd.verified_file(f, digest)
    link = d / "link"
    link.symlink_to(f)
    assert not pd.verified_file(link, digest)   # a link is never trusted, even to the right bytes


@as_root
def test_a_file_of_another_user_is_not_trusted_even_with_the_right_digest(tmp_path):
    d = pd.private_dir(tmp_path / "d")
    f = d / "f"
    f.write_bytes(b"x")
    os.chown(f, _nobody(), _nobody())
    assert not pd.verified_file(f, __import__("hashlib").sha256(b"x").hexdigest())


@pytest.mark.parametrize("how", PLANTS)
def test_the_cache_root_planted_is_refused(tmp_path, monkeypatch, how):
    place = tmp_path / "base" / "spurdiff"
    (tmp_path / "base").mkdir(mode=0o700)
    _plant(place, how)
    monkeypatch.setenv("SPURDIFF_CACHE", str(place))
    with pytest.raises(PrivatePlaceError):
        pd.cache_root()


@pytest.mark.parametrize("how", PLANTS)
def test_the_temporary_fallback_planted_is_refused(tmp_path, monkeypatch, how):
    """No home cache can be made (its parent is a file): $TMPDIR/spurdiff-<uid> is used, checked."""
    monkeypatch.delenv("SPURDIFF_CACHE", raising=False)
    (tmp_path / "not-a-folder").write_text("")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "not-a-folder" / "cache"))
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    os.chmod(tmp, 0o1777)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp))
    assert pd.cache_root() == tmp / f"spurdiff-{os.geteuid()}"   # unplanted: made, private
    os.rmdir(tmp / f"spurdiff-{os.geteuid()}")
    if how == "open-parent":
        pytest.skip("the temporary folder is sticky by design")
    _plant(tmp / f"spurdiff-{os.geteuid()}", how)
    with pytest.raises(PrivatePlaceError):
        pd.cache_root()


# ----------------------------------------------------------------------------- each place

def _fake_host(place: Path, marker: Path) -> None:
    """A planted 'host': a program that leaves ``marker`` when run."""
    place.mkdir(parents=True, exist_ok=True)
    host = place / "host"
    host.write_text(f"#!/bin/sh\ntouch {marker}\necho OK\n")
    host.chmod(0o755)


def _host_folder(cache: Path) -> Path:
    import hashlib

    from harness.check.processes import native
    return cache / f"check-host-{hashlib.sha256(native.HOST_SOURCE.encode()).hexdigest()[:12]}"


@pytest.mark.skipif(not any(map(__import__("shutil").which, ("cc", "gcc", "clang"))), reason="no C compiler")
@pytest.mark.parametrize("how", PLANTS)
def test_the_kits_bare_host_planted_is_never_run(cache, tmp_path, how):
    """Issue 45 item 1 (High): a host planted where the kit caches its bare C host is not run: the
    folder is refused (the rule SKIPs with the place, never PASSes)."""
    from harness.check.processes import native
    marker = tmp_path / "planted-host-ran"
    pd.private_dir(cache)
    folder = _host_folder(cache)
    _plant(folder, how)
    if folder.is_dir():
        _fake_host(folder, marker)
        if how == "other-user":
            for p in (folder, folder / "host"):
                os.chown(p, _nobody(), _nobody())
    native.host_binary.cache_clear()
    try:
        host, why = native.host_binary()
        named = folder.parent if how == "open-parent" else folder   # the folder open to others
        assert host is None and f"refusing the cache folder {named}:" in why and "\n" not in why
        status, reason = native.run_bare_host(Path("/nonexistent.so"), "cs", "g", tmp_path, 0.0, 0.01, 10.0)
        assert status == "SKIP" and str(named) in reason
    finally:
        native.host_binary.cache_clear()
    assert not marker.exists()


@pytest.mark.skipif(not any(map(__import__("shutil").which, ("cc", "gcc", "clang"))), reason="no C compiler")
def test_a_planted_host_inside_our_own_folder_is_rebuilt_not_run(cache, tmp_path):
    """A 'host' in our private folder whose digest is not the recorded one (a truncated or swapped
    file) is compiled anew; the recorded digest itself is not enough."""
    from harness.check.processes import native
    marker = tmp_path / "planted-host-ran"
    native.host_binary.cache_clear()
    try:
        host, _ = native.host_binary()
        good = host.read_bytes()
        _fake_host(host.parent, marker)
        native.host_binary.cache_clear()
        host2, _ = native.host_binary()
        assert host2 == host and host.read_bytes() == good
        r = subprocess.run([str(host)], capture_output=True, text=True)
        assert r.returncode == 2 and "usage" in r.stderr
    finally:
        native.host_binary.cache_clear()
    assert not marker.exists()


@pytest.mark.parametrize("how", PLANTS)
def test_the_sweep_snapshot_folder_planted_is_refused(cache, how):
    import hashlib

    from harness.scene.schema import SceneError
    from harness.sweep.execution.fmu_files import snapshot
    data = b"PK fake fmu bytes"
    digest = hashlib.sha256(data).hexdigest()
    pd.private_dir(cache)
    place = cache / "sweep-fmus" / digest
    pd.private_dir(place.parent)
    _plant(place, how)
    with pytest.raises(SceneError) as e:
        snapshot("M", data, digest)
    assert str(place) in str(e.value) and "\n" not in str(e.value)


def test_a_same_size_snapshot_of_other_bytes_is_replaced(cache):
    """The old check trusted a file whose size matched: 20 of 20 runs failed on a planted one."""
    import hashlib

    from harness.sweep.execution.fmu_files import snapshot
    data = b"PK the real fmu"
    digest = hashlib.sha256(data).hexdigest()
    p = snapshot("M", data, digest)
    p.write_bytes(b"X" * len(data))
    assert snapshot("M", data, digest).read_bytes() == data
    assert stat.S_IMODE(os.lstat(p.parent).st_mode) == 0o700


@pytest.mark.parametrize("how", PLANTS)
def test_the_runtime_cache_planted_is_refused_before_anything_is_read(tmp_path, how):
    from harness.build import runtime_bundle
    place = tmp_path / "base" / "fmus"
    (tmp_path / "base").mkdir(mode=0o700)
    _plant(place, how)
    with pytest.raises(runtime_bundle.RuntimeBundleError) as e:
        runtime_bundle.ensure_runtime({"M": ("m", {})}, cache=place)
    assert str(place) in str(e.value)


@pytest.mark.parametrize("how", PLANTS)
def test_the_win64_download_folder_planted_is_refused(tmp_path, monkeypatch, how):
    """A download planted in the downloads folder is not taken (the folder is refused before the file
    is looked at)."""
    from harness.build import runtime_win64 as rw
    place = tmp_path / "base" / "spurdiff" / "win64"   # the default: <user cache>/spurdiff/win64
    (tmp_path / "base").mkdir(mode=0o700)
    (tmp_path / "base" / "spurdiff").mkdir(mode=0o700)
    _plant(place, how)
    if place.is_dir():
        (place / rw.EMBED_SDIST).write_bytes(b"planted")
    monkeypatch.delenv("SPURDIFF_WIN64_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "base"))
    assert rw.download_dir() == place
    with pytest.raises(rw.Win64Unavailable) as e:
        rw._pip_download(rw.download_dir())
    assert str(place) in str(e.value)
    with pytest.raises(rw.Win64Unavailable):
        rw._private(rw.download_dir())
