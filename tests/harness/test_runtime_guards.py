"""Every guard of the runtime builder (harness/build/runtime_bundle.py), each exercised on its own, so that
removing or weakening it fails a test here (issue 47 item 3; the mutations are listed in
tests/mutations_guards.toml). Fast: no FMU is built; the runtime's assembly is replaced by a stub
where only the cache logic is tested. The built runtime itself is tested in test_runtime_bundle.py."""
from __future__ import annotations

import fcntl
import json
import os
import shutil
import subprocess
import threading
import time
import zipfile
from pathlib import Path

import pytest

from harness.build import elf
from harness.build import runtime_bundle as rb

needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="no gcc to make a test library")


def _aged(path: Path, t: float) -> Path:
    os.utime(path, (t, t))
    return path


# ----------------------------------------------------------------------------- the cache's pruning

def test_prune_keeps_the_newest_module_lists_not_one_fewer(tmp_path):
    """Issue 47: the module lists pruned one too many survived every test. (Earlier builds' numpy closures
    are removed: no build makes or reads one now.)"""
    for i in range(4):
        (tmp_path / f"runtime-modules-{i}.json").write_text("[]")
        _aged(tmp_path / f"runtime-modules-{i}.json", 1000 + i)
    (tmp_path / "runtime-numpy-modules-0.json").write_text("{}")    # an earlier build's numpy closure: goes
    rb._prune(tmp_path, keep=tmp_path / "runtime-x")
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == [f"runtime-modules-{i}.json" for i in range(4 - rb.KEEP_RUNTIMES, 4)]
    assert rb.KEEP_RUNTIMES == 2 and len(left) == 2


def test_prune_keeps_the_runtime_in_use_even_when_it_is_the_oldest(tmp_path):
    for i, name in enumerate(["runtime-old", "runtime-b", "runtime-c", "runtime-d"]):
        (tmp_path / name).mkdir()
        _aged(tmp_path / name, 1000 + i)
    rb._prune(tmp_path, keep=tmp_path / "runtime-old")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["runtime-d", "runtime-old"]


def test_prune_removes_dead_work_folders_but_not_files_of_that_name(tmp_path):
    (tmp_path / ".runtime-abc-123").mkdir()
    (tmp_path / ".runtime.lock").write_text("")
    rb._prune(tmp_path, keep=tmp_path / "runtime-x")
    assert sorted(p.name for p in tmp_path.iterdir()) == [".runtime.lock"]


# ----------------------------------------------------------------------------- cached values

def test_a_cached_list_is_read_not_made_again_and_written_whole(tmp_path):
    calls = []
    path = tmp_path / "runtime-modules-k.json"
    make = lambda: calls.append(1) or ["a", "b"]   # noqa: E731
    assert rb._cached_json(path, make) == ["a", "b"]
    assert rb._cached_json(path, make) == ["a", "b"] and calls == [1]
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]   # no staged file left


def test_a_cached_list_replaces_a_link_planted_at_its_name(tmp_path):
    victim = tmp_path / "victim"
    path = tmp_path / "runtime-modules-k.json"
    path.symlink_to(victim)            # dangling: not a file, so the list is made and written
    rb._cached_json(path, lambda: ["a"])
    assert not victim.exists() and not path.is_symlink() and json.loads(path.read_text()) == ["a"]


def test_the_cache_key_changes_with_the_builders_own_code():
    ident = rb.interpreter_id()
    for code in rb.CODE_FILES:
        assert code.read_bytes() in ident
    assert Path(rb.__file__).resolve() in rb.CODE_FILES and rb.PROBE in rb.CODE_FILES


@pytest.fixture()
def stub_runtime(tmp_path, monkeypatch):
    """ensure_runtime with the module list cached and the assembly a stub (counts its calls)."""
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    fmus = {"M": ("m", {})}
    monkeypatch.setattr(rb, "package_digest", lambda f: "pkg")
    monkeypatch.setattr(rb, "_RUNTIMES", {})
    interp = rb._digest(*rb.interpreter_id())
    key1 = rb._digest(interp, "pkg")
    (cache / f"runtime-modules-{key1[:16]}.json").write_text(json.dumps(["os.py"]))
    folder = cache / f"runtime-{rb._digest(interp, 'os.py')[:16]}"
    calls = []

    def assemble(dest, items):
        calls.append(dest)
        (dest / "manifest.json").write_text(json.dumps({"preload": [], "libpython": "python/lib/x"}))
        return {"unpacked_bytes": 0, "zipped_bytes": 0, "notes": []}

    monkeypatch.setattr(rb, "assemble", assemble)
    return cache, fmus, folder, calls


def test_a_half_made_runtime_folder_is_made_again(stub_runtime):
    cache, fmus, folder, calls = stub_runtime
    folder.mkdir()
    (folder / "junk").write_text("left by a build that died")
    rt = rb.ensure_runtime(fmus, cache=cache)
    assert rt.folder == folder and len(calls) == 1 and not (folder / "junk").exists()
    assert (folder / "manifest.json").is_file()
    rb._RUNTIMES.clear()
    rb.ensure_runtime(fmus, cache=cache)
    assert len(calls) == 1    # complete now: taken from the cache
    assert not list(cache.glob(".runtime-*"))


def test_the_runtime_is_made_under_the_lock(stub_runtime):
    cache, fmus, folder, calls = stub_runtime
    with open(cache / ".runtime.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        t = threading.Thread(target=rb.ensure_runtime, args=(fmus,), kwargs={"cache": cache})
        t.start()
        time.sleep(0.5)
        made_while_locked = list(calls)
        fcntl.flock(lock, fcntl.LOCK_UN)
    t.join(30)
    assert made_while_locked == [] and len(calls) == 1


# ----------------------------------------------------------------------------- the module list

def test_a_module_the_runtime_does_not_carry_is_refused(tmp_path, monkeypatch):
    pkg = tmp_path / "M" / "resources" / "spurdiff_fmus"
    pkg.mkdir(parents=True)
    outside = tmp_path / "elsewhere" / "evil.py"
    monkeypatch.setattr(rb, "_run_probe", lambda spec: {"modules": {"os": str(rb.STDLIB / "os.py"),
                                                                    "evil": str(outside)}})
    with pytest.raises(rb.RuntimeBundleError) as e:
        rb.module_list({"M": (pkg, {})})
    assert "evil" in str(e.value) and str(outside) in str(e.value)


def test_carried_means_the_stdlib_without_its_site_packages_or_the_package(tmp_path):
    import numpy     # the harness's, which the FMU's runtime does not carry

    pkg = tmp_path / "pkg"
    packages = {"M": (pkg, {})}
    assert rb._carried(rb.STDLIB / "json" / "__init__.py", packages)
    assert rb._carried(rb.DYNLOAD / "_json.so", packages)
    assert not rb._carried(rb.STDLIB / "site-packages" / "x.py", packages)
    assert not rb._carried(Path(numpy.__file__).resolve(), packages)
    assert rb._carried(pkg / "a.py", packages)
    assert not rb._carried(tmp_path / "other" / "a.py", packages)


def test_stdlib_items_leave_out_the_denied_the_builtin_and_the_foreign():
    import numpy     # the harness's: foreign to the FMU's runtime

    mods = {
        "json.decoder": str(rb.STDLIB / "json" / "decoder.py"),
        "tkinter": str(rb.STDLIB / "tkinter" / "__init__.py"),
        "_sysconfigdata__linux": str(rb.STDLIB / "_sysconfigdata__linux.py"),
        "sys": None,
        "numpy": str(Path(numpy.__file__).resolve()),
        "thing": str(rb.STDLIB / "site-packages" / "thing.py"),
        "_json": str(next(rb.DYNLOAD.glob("_json*.so"))),
        "abc": None,
        "idlelib": None,          # no file known: taken by its folder, unless denied
        "test": None,
    }
    items = rb.stdlib_items(mods)
    assert "json" in items and "abc.py" in items and any(i.startswith("lib-dynload/_json") for i in items)
    assert not any(i.startswith(("tkinter", "_sysconfigdata", "site-packages", "sys", "numpy", "idlelib", "test"))
                   for i in items), items


def test_test_folders_and_bytecode_are_not_copied():
    assert sorted(rb._ignore_tests("x", ["test", "tests", "idle_test", "__pycache__", "a.pyc", "a.py", "sub"])) == \
        ["__pycache__", "a.pyc", "idle_test", "test", "tests"]


def test_a_probe_that_fails_is_one_error_with_its_last_line(tmp_path):
    spec = {"path": [], "fmus": [{"package": str(tmp_path / "missing"), "class": "M",
                                  "module": "m", "experiment": {}, "steps": 1}]}
    with pytest.raises(rb.RuntimeBundleError) as e:
        rb._run_probe(spec, timeout=120)
    assert "\n" not in str(e.value) and "failed:" in str(e.value)


# ----------------------------------------------------------------------------- assembling

def test_no_shared_libpython_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(rb, "libpython", lambda: None)
    with pytest.raises(rb.RuntimeBundleError) as e:
        rb.assemble(tmp_path / "r", [])
    assert "no shared libpython" in str(e.value)


def test_sourceless_compilation_removes_the_sources_and_refuses_a_broken_one(tmp_path):
    (tmp_path / "home" / "pkg").mkdir(parents=True)
    (tmp_path / "home" / "pkg" / "a.py").write_text("X = 1\n")
    rb._compile_sourceless(tmp_path / "home")
    assert [p.name for p in (tmp_path / "home" / "pkg").iterdir()] == ["a.pyc"]
    (tmp_path / "home" / "pkg" / "b.py").write_text("def (:\n")
    with pytest.raises(rb.RuntimeBundleError):
        rb._compile_sourceless(tmp_path / "home")


def test_the_pure_stdlib_is_zipped_stored_and_the_rest_kept(tmp_path):
    pylib = tmp_path / "pylib"
    for d in ("lib-dynload", "json"):
        (pylib / d).mkdir(parents=True)
    (pylib / "json" / "__init__.pyc").write_bytes(b"x" * 100)
    (pylib / "os.pyc").write_bytes(b"y" * 100)
    (pylib / "LICENSE.txt").write_text("l")
    rb._zip_pure_stdlib(pylib, tmp_path / "std.zip")
    assert sorted(p.name for p in pylib.iterdir()) == ["LICENSE.txt", "lib-dynload"]
    with zipfile.ZipFile(tmp_path / "std.zip") as z:
        assert sorted(z.namelist()) == ["json/__init__.pyc", "os.pyc"]
        assert all(i.compress_type == zipfile.ZIP_STORED for i in z.infolist())


def test_libraries_are_bundled_dependencies_first_and_system_ones_never(tmp_path):
    """_ssl needs libssl and libcrypto (libssl needs libcrypto); readline needs libreadline, which
    needs libtinfo (a name sorted after it: the order must come from the dependencies)."""
    exts = {m: next(rb.DYNLOAD.glob(f"{m}*.so"), None) for m in ("_ssl", "readline")}
    if any(e is None for e in exts.values()) or elf.locate("libssl.so.3", exts["_ssl"]) is None \
            or elf.locate("libreadline.so.8", exts["readline"]) is None:
        pytest.skip("this Python's _ssl / readline do not use findable libssl.so.3 / libreadline.so.8")
    root = tmp_path / "rt"
    sources = {}
    for ext in exts.values():
        copy = root / rb.PYLIB / "lib-dynload" / ext.name
        copy.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(ext, copy)
        sources[copy] = ext
    (root / rb.LIB).mkdir(parents=True, exist_ok=True)
    preload = rb._bundle_libraries(root, sources)
    names = [Path(p).name for p in preload]
    assert names.index("libcrypto.so.3") < names.index("libssl.so.3")
    if "libtinfo.so.6" in elf.dynamic(elf.locate("libreadline.so.8", exts["readline"])).needed:
        assert names.index("libtinfo.so.6") < names.index("libreadline.so.8")
    assert not set(names) & rb.SYSTEM_LIBRARIES
    assert all((root / p).is_file() for p in preload)


@needs_gcc
def test_a_library_not_found_is_refused_naming_it(tmp_path):
    (tmp_path / "f.c").write_text("int f(void) { return 1; }\n")
    (tmp_path / "g.c").write_text("int f(void); int g(void) { return f(); }\n")
    subprocess.run(["gcc", "-shared", "-fPIC", "-o", tmp_path / "libgone.so", tmp_path / "f.c",
                    "-Wl,-soname,libgone.so.7"], check=True)
    root = tmp_path / "rt"
    (root / rb.LIB).mkdir(parents=True)
    subprocess.run(["gcc", "-shared", "-fPIC", "-o", root / "g.so", tmp_path / "g.c", "-L", tmp_path, "-lgone"],
                   check=True)
    with pytest.raises(rb.RuntimeBundleError) as e:
        rb._bundle_libraries(root, {})
    assert "libgone.so.7" in str(e.value) and "not found" in str(e.value)


@needs_gcc
def test_a_copied_library_loses_its_runpath(tmp_path):
    from harness.build.elf import find_patchelf
    if not find_patchelf():
        pytest.skip("no patchelf")
    (tmp_path / "g.c").write_text("int g(void) { return 1; }\n")
    lib = tmp_path / "g.so"
    subprocess.run(["gcc", "-g", "-shared", "-fPIC", "-o", lib, tmp_path / "g.c", "-Wl,-rpath,/tmp/planted"],
                   check=True)
    assert elf.dynamic(lib).rpath or elf.dynamic(lib).runpath
    notes: list[str] = []
    rb._tidy_elf(lib, notes)
    assert not elf.dynamic(lib).rpath and not elf.dynamic(lib).runpath and notes == []
