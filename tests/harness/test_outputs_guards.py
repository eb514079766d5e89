"""Every guard of the output writer (harness/common/outputs.py), each exercised on its own, so that removing
it fails a test here (issue 45 item 6, issue 47 item 3; the mutations are listed in
tests/mutations_guards.toml). Fast: no FMU, no run; the end-to-end cases are in
tests/harness/hostile/test_hostile_outputs.py."""
from __future__ import annotations

import errno
import os
import stat
import threading

import pytest

from harness.common import outputs
from harness.common.outputs import LOCK_NAME, OutputError, OutputLock, StreamFile, atomic_file, private_path, probe, \
    write_bytes, write_text


def _only(folder, *names):
    return sorted(p.name for p in folder.iterdir()) == sorted(names)


# ----------------------------------------------------------------------------- whole files

def test_a_symlinked_output_is_refused_and_its_target_untouched(tmp_path):
    victim = tmp_path / "victim"
    victim.write_text("keep")
    (tmp_path / "out.csv").symlink_to(victim)
    for write in (lambda p: write_text(p, "x"), probe, StreamFile, lambda p: private_path(p).__enter__()):
        with pytest.raises(OutputError) as e:
            write(tmp_path / "out.csv")
        assert e.value.errno == errno.ELOOP and "symbolic link" in str(e.value)
    assert victim.read_text() == "keep"


def test_a_whole_file_replaces_a_planted_hard_link_never_writes_through_it(tmp_path):
    victim = tmp_path / "victim"
    victim.write_text("keep")
    os.link(victim, tmp_path / "out.csv")
    write_text(tmp_path / "out.csv", "new")
    assert victim.read_text() == "keep" and (tmp_path / "out.csv").read_text() == "new"


def test_a_whole_file_appears_only_complete(tmp_path):
    """Until the block ends the output keeps its old content (the data goes to a private name)."""
    out = tmp_path / "out.csv"
    out.write_text("old")
    with atomic_file(out) as fh:
        fh.write("new")
        fh.flush()
        assert out.read_text() == "old"
    assert out.read_text() == "new" and _only(tmp_path, "out.csv")


def test_an_error_inside_the_block_keeps_the_old_file_and_no_temporary(tmp_path):
    out = tmp_path / "out.csv"
    out.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_file(out) as fh:
            fh.write("half")
            raise RuntimeError("stop")
    assert out.read_text() == "old" and _only(tmp_path, "out.csv")


def test_an_oserror_inside_the_block_is_an_output_error_naming_the_place(tmp_path):
    out = tmp_path / "out.csv"
    with pytest.raises(OutputError) as e:
        with atomic_file(out):
            raise OSError(errno.ENOSPC, "No space left on device")
    assert e.value.errno == errno.ENOSPC and str(out) in str(e.value) and "[errno 28 ENOSPC]" in str(e.value)
    assert _only(tmp_path)


def test_the_temporary_name_is_created_exclusively_without_following_links(tmp_path, monkeypatch):
    """A link planted at the private name is not opened (O_EXCL | O_NOFOLLOW)."""
    victim = tmp_path / "victim"
    victim.write_text("keep")
    monkeypatch.setattr(outputs.uuid, "uuid4", lambda: type("U", (), {"hex": "0" * 32})())
    planted = tmp_path / f".out.csv.{os.getpid()}.00000000.tmp"
    planted.symlink_to(victim)
    with pytest.raises(OutputError) as e:
        write_text(tmp_path / "out.csv", "x")
    assert e.value.errno == errno.EEXIST
    assert victim.read_text() == "keep"


def test_private_path_renames_on_success_and_removes_on_error(tmp_path):
    out = tmp_path / "a.zip"
    with private_path(out) as tmp:
        tmp.write_bytes(b"zip")
        assert not out.exists()
    assert out.read_bytes() == b"zip"
    with pytest.raises(OutputError):
        with private_path(out) as tmp:
            tmp.write_bytes(b"half")
            raise OSError(errno.EIO, "I/O error")
    assert out.read_bytes() == b"zip" and _only(tmp_path, "a.zip")


def test_probe_leaves_nothing_behind(tmp_path):
    assert probe(tmp_path / "sub" / "x.csv") == tmp_path / "sub" / "x.csv"
    assert _only(tmp_path / "sub")


def test_a_folder_that_cannot_be_made_is_an_output_error(tmp_path):
    (tmp_path / "file").write_text("")
    with pytest.raises(OutputError) as e:
        write_bytes(tmp_path / "file" / "sub" / "x.bin", b"x")
    assert str(tmp_path / "file" / "sub") in str(e.value) and e.value.errno in (errno.ENOTDIR, errno.EEXIST)


def test_save_figure_writes_nothing_when_the_figure_fails(tmp_path):
    class Broken:
        def savefig(self, buf, **kw):
            buf.write(b"half a png")
            raise AttributeError("the PNG writer's error on a full disk")

    with pytest.raises(AttributeError):
        outputs.save_figure(Broken(), tmp_path / "p.png")
    assert _only(tmp_path)


# ----------------------------------------------------------------------------- streamed files

def test_a_streamed_file_replaces_a_planted_hard_link(tmp_path):
    victim = tmp_path / "victim"
    victim.write_text("keep")
    os.link(victim, tmp_path / "out.csv")
    f = StreamFile(tmp_path / "out.csv")
    f.write("a\n")
    f.close()
    assert victim.read_text() == "keep" and (tmp_path / "out.csv").read_text() == "a\n"


def test_a_partial_write_is_cut_back_to_the_last_complete_row(tmp_path, monkeypatch):
    f = StreamFile(tmp_path / "out.csv")
    f.write("h\n")
    f.flush()
    real = os.write
    calls = []

    def short(fd, data):
        if fd == f.fd and not calls:
            calls.append(1)
            return real(fd, bytes(data[:5]))      # "r1\nr2" of "r1\nr2\n"
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "write", short)
    f.write("r1\nr2\n")
    with pytest.raises(OutputError) as e:
        f.flush()
    monkeypatch.setattr(os, "write", real)
    assert "its first 2 lines" in str(e.value) and f.rows == 2
    with pytest.raises(OutputError) as again:   # the same error again, never a second write
        f.write("r3\n")
    assert again.value is e.value
    f.close()                                   # no second error
    assert (tmp_path / "out.csv").read_text() == "h\nr1\n"


def test_a_failed_stream_raises_its_first_error_on_flush_too(tmp_path, monkeypatch):
    f = StreamFile(tmp_path / "out.csv")
    f.failed = OutputError(tmp_path, "planted")
    with pytest.raises(OutputError) as e:
        f.flush()
    assert e.value is f.failed
    f.close()


# ----------------------------------------------------------------------------- the lock

def test_a_second_holder_is_refused_naming_the_first(tmp_path):
    with OutputLock(tmp_path, "spurdiff run A"):
        with pytest.raises(OutputError) as e:
            OutputLock(tmp_path, "spurdiff run B").acquire()
        assert "is in use by spurdiff run A (pid" in str(e.value)
    with OutputLock(tmp_path, "spurdiff run B"):   # released: free again
        pass
    assert not (tmp_path / LOCK_NAME).exists()


def test_the_holders_name_is_printable(tmp_path):
    with OutputLock(tmp_path, "run \x1b[2J\x07 evil"):
        with pytest.raises(OutputError) as e:
            OutputLock(tmp_path, "B").acquire()
    assert "\x1b" not in str(e.value) and "\x07" not in str(e.value)


def test_a_hard_linked_lock_file_is_refused(tmp_path):
    """Issue 45 item 6: the lock file's hard-link check (a lock file linked to a file of the user
    would be truncated and written through)."""
    victim = tmp_path / "victim"
    victim.write_text("keep")
    os.link(victim, tmp_path / LOCK_NAME)
    with pytest.raises(OutputError) as e:
        OutputLock(tmp_path, "run").acquire()
    assert "not a plain file of its own" in str(e.value) and e.value.errno == errno.EEXIST
    assert victim.read_text() == "keep"


def test_a_symlinked_lock_file_is_refused(tmp_path):
    victim = tmp_path / "victim"
    victim.write_text("keep")
    (tmp_path / LOCK_NAME).symlink_to(victim)
    with pytest.raises(OutputError) as e:
        OutputLock(tmp_path, "run").acquire()
    assert e.value.errno == errno.ELOOP and victim.read_text() == "keep"


def test_a_lock_that_is_not_a_file_is_refused(tmp_path):
    os.mkfifo(tmp_path / LOCK_NAME)
    with pytest.raises(OutputError) as e:
        OutputLock(tmp_path, "run").acquire()
    assert "not a plain file of its own" in str(e.value)
    assert stat.S_ISFIFO(os.lstat(tmp_path / LOCK_NAME).st_mode)


def test_a_lock_file_swapped_after_opening_is_taken_anew(tmp_path, monkeypatch):
    """The holder removed the file on release after we opened it: the lock we got is on a file
    nobody sees; the new file is opened and locked instead (else two holders at once)."""
    import fcntl
    real_flock = fcntl.flock
    swapped = []

    def flock(fd, op):
        if not swapped and op & fcntl.LOCK_EX:
            swapped.append(1)
            os.unlink(tmp_path / LOCK_NAME)     # the first holder releases
            (tmp_path / LOCK_NAME).write_text("")  # and a third process makes it anew
        return real_flock(fd, op)

    monkeypatch.setattr(fcntl, "flock", flock)
    lock = OutputLock(tmp_path, "run").acquire()
    try:
        assert os.path.samestat(os.fstat(lock.fd), os.lstat(tmp_path / LOCK_NAME)) and lock._tries == 1
    finally:
        lock.release()


def test_a_lock_file_that_keeps_changing_is_refused_not_retried_forever(tmp_path, monkeypatch):
    import fcntl
    real_flock = fcntl.flock

    def flock(fd, op):
        if op & fcntl.LOCK_EX:
            os.unlink(tmp_path / LOCK_NAME)
            (tmp_path / LOCK_NAME).write_text("")
        return real_flock(fd, op)

    monkeypatch.setattr(fcntl, "flock", flock)
    with pytest.raises(OutputError) as e:
        OutputLock(tmp_path, "run").acquire()
    assert "keeps changing" in str(e.value)


def test_release_removes_the_file_while_still_holding_it(tmp_path, monkeypatch):
    """The file goes before the lock: a waiter that opened it meanwhile sees it gone and retries."""
    import fcntl
    lock = OutputLock(tmp_path, "run").acquire()
    seen = []
    real = fcntl.flock
    monkeypatch.setattr(fcntl, "flock", lambda fd, op: (seen.append((op, (tmp_path / LOCK_NAME).exists())),
                                                        real(fd, op))[1])
    lock.release()
    assert seen == [(fcntl.LOCK_UN, False)]


def test_only_one_of_many_threads_holds_the_lock(tmp_path):
    held, refused = [], []
    barrier = threading.Barrier(8)

    def take(i):
        barrier.wait()
        try:
            lock = OutputLock(tmp_path, f"t{i}").acquire()
        except OutputError:
            refused.append(i)
            return
        held.append(lock)

    threads = [threading.Thread(target=take, args=(i,)) for i in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(held) >= 1 and len(held) + len(refused) == 8
    # flock locks belong to open files: every holder has its own, so exactly one may hold at a time
    assert len(held) == 1, held
    held[0].release()
