"""The FMUs' win64 binaries and runtime under wine: our C host (tests/c_host/fmi2_any_host.c)
cross-built with mingw-w64 runs each FMU from a folder on drive C: with a space and a non-ASCII
character in its path (resource URI file:///C:/...), gives the linux64 binary's outputs, exits
cleanly, and the FMI-contract and hostile-input checks a C host can drive hold.

Skipped with the reason where wine or mingw-w64 is not installed (.ci/run installs both from Debian
when it can) or the FMUs were built without their win64 side. One wineserver (``wineserver -p``)
in a prefix of the per-user cache serves every run; it is stopped at the end. Each process runs
the FMU several times; ``SPURDIFF_WINE_PROCESSES`` sets how many processes per FMU (default 1;
the closing note of issue 33 ran 20). The coupled scene (vehicle-cornering) runs under the harness's own
master on a Windows CPython with fmpy (tests/harness/win64_master.py), one wine process per count;
the FMI 3.0 FMUs' binaries/x86_64-windows under our FMI 3.0 C host (tests/c_host/fmi3_host.c).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
import urllib.parse
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from host_cases import CASES, MINGW, STEP, STOP, build_c_host  # noqa: E402

PROCESSES = int(os.environ.get("SPURDIFF_WINE_PROCESSES", "1"))
RUNS_PER_PROCESS = 2
# (input for NaN, parameter, value outside its range) per FMU, as tests/fmus/test_fmu_contract.py
CONTRACT = {"SpurDifferential": ("left.tau", "mu_pin", -0.5),
            "WheelLoad": ("Fz", "tyre.C", 2.5),
            "Vehicle": ("rearLeft.Fx", "vehicle.l_f", 3.0)}
ODD = "spurdiff wine ü"

pytestmark = [
    pytest.mark.skipif(shutil.which("wine") is None, reason="wine is not installed (Debian: apt-get install wine64)"),
    pytest.mark.skipif(shutil.which(MINGW) is None,
                       reason=f"{MINGW} is not installed (Debian: apt-get install gcc-mingw-w64-x86-64)"),
]


@pytest.fixture(scope="module")
def wine(tmp_path_factory):
    """The environment of the wine runs: a prefix in the per-user cache (made once), one
    persistent wineserver started here with its output away from the tests' pipes.

    The prefix is shared by the modules that run wine (this one, test_win64_uri.py), which
    pytest-xdist may run at once on different workers, and by other test
    sessions of the user: a module holds it alone, from its wineserver's start to its ``wineserver
    -k``, which would end another module's wine runs (an exclusive lock beside the prefix; seen once:
    a run under wine ended with exit 1 and no output), and the folders under ``C:/spurdiff wine ü``
    are then its own too."""
    import fcntl

    from harness.build.runtime_win64 import download_dir
    from harness.common.private_dir import private_dir

    prefix = private_dir(download_dir()) / "wineprefix"    # the folder made (0700) on a fresh machine
    env = {**os.environ, "WINEPREFIX": str(prefix), "WINEDEBUG": "-all", "WINEDLLOVERRIDES": "mscoree,mshtml="}
    quiet = {"stdin": subprocess.DEVNULL, "stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "env": env}
    with open(prefix.parent / "wineprefix.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        subprocess.run(["wineserver", "-p"], timeout=60, **quiet)
        r = subprocess.run(["wineboot", "-i"], timeout=300, **quiet)   # makes the prefix once, starts its services
        if r.returncode != 0:
            pytest.skip(f"wineboot failed (exit {r.returncode}): this wine cannot make a prefix")
        yield env, prefix
        subprocess.run(["wineserver", "-k"], timeout=60, **quiet)   # the server started above, in this prefix


@pytest.fixture(scope="module")
def hosts(tmp_path_factory):
    out = tmp_path_factory.mktemp("hosts")
    exe, elf = out / "fmi2_any_host.exe", out / "fmi2_any_host"
    build_c_host("fmi2_any_host", exe, windows=True)
    build_c_host("fmi2_any_host", elf)
    return exe, elf


@pytest.fixture(scope="module")
def unpacked(fmu_files, wine):
    """Each FMU unzipped into C:/spurdiff wine ü/<name>/ of the prefix (drive_c)."""
    _, prefix = wine
    root = prefix / "drive_c" / ODD
    shutil.rmtree(root, ignore_errors=True)
    out = {}
    for name, path in fmu_files.items():
        with zipfile.ZipFile(path) as z:
            if f"binaries/win64/{name}.dll" not in z.namelist():
                pytest.skip(f"{name}.fmu has no binaries/win64 (built where mingw-w64 was missing)")
            z.extractall(root / name)
        out[name] = root / name
    yield out
    shutil.rmtree(root, ignore_errors=True)


def _model(folder: Path):
    root = ET.parse(folder / "modelDescription.xml").getroot()
    vrs = {v.get("name"): (int(v.get("valueReference")), v.get("causality"), v.find("Real") is not None)
           for v in root.iter("ScalarVariable")}
    return root.get("guid"), vrs


def _win(name: str, *rest: str) -> tuple[str, str]:
    """(the binary as a Windows path, the resources as a file:///C:/ URI) of FMU ``name``."""
    binary = "C:\\" + ODD + "\\" + name + "\\" + "\\".join(rest)
    uri = "file:///C:/" + urllib.parse.quote(f"{ODD}/{name}/resources")
    return binary, uri


def _args(folder: Path, name: str) -> tuple[list[str], list[str], list[int], list[str]]:
    guid, vrs = _model(folder)
    steps = str(int(round(STOP / STEP)))
    sets = [f"{vrs[k][0]}={v!r}" for k, v in CASES[name].items()]
    outs = [vr for vr, causality, real in vrs.values() if causality == "output" and real][:64]
    return [guid], [steps, repr(STEP)], outs, sets


def _outputs(stdout: str) -> list[dict[int, float]]:
    runs = []
    for line in stdout.splitlines():
        if line.startswith("run ") and " status " in line:
            fields = line.split()
            assert fields[3] == "0", line
            runs.append({int(k): float(v) for k, v in (f.split("=") for f in fields[4:])})
    return runs


def _run(cmd: list[str], env=None, timeout=600) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          timeout=timeout, env=env)


@pytest.mark.parametrize("name", list(CASES))
def test_each_fmu_runs_under_wine_exits_cleanly_and_equals_linux64(name, wine, hosts, unpacked):
    env, _ = wine
    exe, elf = hosts
    folder = unpacked[name]
    guid, timing, outs, sets = _args(folder, name)
    get = ["get", ",".join(map(str, outs))]
    linux = _run([str(elf), str(folder / "binaries" / "linux64" / f"{name}.so"), *guid,
                  folder.joinpath("resources").as_uri(), *timing, "1", *sets, *get])
    assert linux.returncode == 0, linux.stdout[-2000:]
    (ref,) = _outputs(linux.stdout)
    binary, uri = _win(name, "binaries", "win64", f"{name}.dll")
    clean, worst = 0, 0.0
    for _ in range(PROCESSES):
        r = _run(["wine", str(exe), binary, *guid, uri, *timing, str(RUNS_PER_PROCESS), *sets, *get], env=env)
        assert r.returncode == 0, r.stdout[-3000:]
        runs = _outputs(r.stdout)
        assert len(runs) == RUNS_PER_PROCESS, r.stdout[-2000:]
        for got in runs:
            assert got.keys() == ref.keys()
            for vr, y in ref.items():
                worst = max(worst, abs(got[vr] - y) / max(1.0, abs(y)))
        clean += 1
    print(f"{name}: {clean} of {PROCESSES} wine processes exited 0, {RUNS_PER_PROCESS} runs each; "
          f"largest difference to linux64 over {len(ref)} outputs: {worst:.3g} (relative, or absolute below 1)")
    assert worst <= 1e-9


@pytest.mark.parametrize("name", list(CASES))
def test_the_native_start_under_wine_equals_the_python_start(name, wine, hosts, unpacked):
    """The defaults kept (no value set): the win64 loader's native start (fmu_src/native/fmi/native_start.c,
    its kernels loaded from the FMU's resources as DLLs) answers without a warning and gives the
    Python-started run's numbers (SPURDIFF_FMU_START=python) bit for bit."""
    env, _ = wine
    exe, _ = hosts
    guid, timing, outs, _ = _args(unpacked[name], name)
    binary, uri = _win(name, "binaries", "win64", f"{name}.dll")
    got = {}
    for mode in ("auto", "python"):
        r = _run(["wine", str(exe), binary, *guid, uri, *timing, "1", "get", ",".join(map(str, outs))],
                 env={**env, "SPURDIFF_FMU_START": mode})
        assert r.returncode == 0 and "native start is not used" not in r.stdout, r.stdout[-3000:]
        (got[mode],) = _outputs(r.stdout)
    assert len(got["auto"]) == len(outs) and got["auto"] == got["python"]


@pytest.mark.parametrize("name", list(CASES))
def test_the_contract_a_c_host_can_drive_holds_under_wine(name, wine, hosts, unpacked):
    env, _ = wine
    exe, _ = hosts
    folder = unpacked[name]
    guid, vrs = _model(folder)
    nan_input, param, bad = CONTRACT[name]
    out = next(vr for vr, causality, real in vrs.values() if causality == "output" and real)
    binary, uri = _win(name, "binaries", "win64", f"{name}.dll")
    r = _run(["wine", str(exe), binary, guid, uri, "5", repr(STEP), "contract", str(vrs[nan_input][0]),
              str(vrs[param][0]), repr(bad), str(out)], env=env)
    print(r.stdout)
    assert r.returncode == 0 and "0 failed" in r.stdout.splitlines(), r.stdout[-3000:]
    says = dict(line.strip().split(" says: ", 1) for line in r.stdout.splitlines() if " says: " in line)
    assert param in says["bad-parameter"]          # the refusal names the parameter
    assert nan_input in says["nan-input"]          # and the input that was not a number


@pytest.mark.parametrize("damage", ["a damaged runtime archive", "a key twice"])
def test_a_damaged_win64_runtime_is_refused_with_the_reason(damage, wine, hosts, unpacked):
    """instantiate returns NULL with the cause logged, the host goes on and exits by itself."""
    env, _ = wine
    exe, _ = hosts
    name = "Damaged"   # a copy of WheelLoad's folder beside the others: C:/spurdiff wine ü/Damaged
    folder = unpacked["WheelLoad"].parent / name
    shutil.rmtree(folder, ignore_errors=True)
    shutil.copytree(unpacked["WheelLoad"], folder)
    guid, timing, outs, sets = _args(folder, "WheelLoad")
    fresh = wine[1] / "drive_c" / "spurdiff-damaged-runtime"   # unpacked (and so checked) afresh there
    shutil.rmtree(fresh, ignore_errors=True)
    if damage == "a damaged runtime archive":
        archive = folder / "resources" / "runtime" / "win64.zip"
        data = bytearray(archive.read_bytes())
        data[len(data) // 2] ^= 0xFF
        archive.write_bytes(bytes(data))
        expected = f"C:/{ODD}/{name}/resources/runtime/win64.zip has SHA-256"
    else:
        cfg = folder / "resources" / "python_runtime_win64.cfg"
        cfg.write_text(cfg.read_text() + "guid=again\n")
        expected = "'guid' given twice"
    binary, uri = _win(name, "binaries", "win64", "WheelLoad.dll")
    r = _run(["wine", str(exe), binary, *guid, uri, *timing, "1", *sets, "get", str(outs[0])],
             env={**env, "SPURDIFF_FMU_START": "python",   # the Python's start refused (not the native one's)
                  "SPURDIFF_FMU_RUNTIME_DIR": "C:/spurdiff-damaged-runtime"})
    shutil.rmtree(folder, ignore_errors=True)
    assert not fresh.exists() or not any(p.name.startswith("python-") for p in fresh.iterdir())   # nothing kept
    shutil.rmtree(fresh, ignore_errors=True)
    assert r.returncode == 4, r.stdout[-2000:]     # the host's "instantiate failed"
    assert expected in r.stdout, r.stdout
    print(r.stdout.splitlines()[0])


def test_the_runtime_is_unpacked_once_and_old_leftovers_are_swept_under_wine(wine, hosts, unpacked):
    """runtime_unpack.h on Windows: a Python start unpacks the runtime's archives into a fresh folder
    (SPURDIFF_FMU_RUNTIME_DIR, a Windows path) and removes a dead unpack's temporary folder and another
    runtime's folder unused for 40 days; a runtime used 10 days ago, a temporary folder younger than ten
    minutes and a foreign folder stay (a living process's: tests/fmus/test_runtime_unpack.py). The runtime's folder is found (not unpacked again) by the next start."""
    env, prefix = wine
    exe, _ = hosts
    base = prefix / "drive_c" / "spurdiff-sweep ü"
    shutil.rmtree(base, ignore_errors=True)
    base.mkdir()
    old = time.time() - 40 * 86400
    planted = {"dead unpack": base / f".python-{'a' * 16}.{0xFFFFFF0}.1",
               "fresh unpack": base / f".python-{'b' * 16}.{0xFFFFFF0}.2",   # untouched for less than ten minutes
               "runtime unused 40 days": base / f"python-{40:016x}",
               "runtime used 10 days ago": base / f"python-{10:016x}",
               "foreign": base / "not-ours"}
    for label, d in planted.items():
        (d / "python").mkdir(parents=True)
        (d / "python" / "f.txt").write_text("x")
        if label.startswith("runtime"):
            (d / ".spurdiff-runtime").write_text("0" * 64 + "\n")
            days = 40 if "40" in label else 10
            os.utime(d / ".spurdiff-runtime", (time.time() - days * 86400,) * 2)
        elif label == "dead unpack":
            os.utime(d, (old, old))
    folder = unpacked["WheelLoad"]
    guid, timing, outs, sets = _args(folder, "WheelLoad")
    binary, uri = _win("WheelLoad", "binaries", "win64", "WheelLoad.dll")
    run_env = {**env, "SPURDIFF_FMU_START": "python", "SPURDIFF_FMU_RUNTIME_DIR": "C:/spurdiff-sweep ü"}
    try:
        r = _run(["wine", str(exe), binary, *guid, uri, *timing, "1", *sets, "get", str(outs[0])], env=run_env)
        assert r.returncode == 0, r.stdout[-3000:]
        runtimes = [p for p in base.iterdir() if p.name.startswith("python-") and p not in planted.values()]
        assert len(runtimes) == 1 and (runtimes[0] / ".spurdiff-runtime").is_file(), sorted(base.iterdir())
        assert (runtimes[0] / "python-win64").is_dir() and (runtimes[0] / "python" / "lib" / "python311.zip").is_file()
        gone = {label for label, d in planted.items() if not d.exists()}
        assert gone == {"dead unpack", "runtime unused 40 days"}, gone
        os.utime(runtimes[0] / ".spurdiff-runtime", (old, old))
        lib = runtimes[0] / "python-win64" / "python311.dll"
        inode = lib.stat().st_ino
        r = _run(["wine", str(exe), binary, *guid, uri, *timing, "1", *sets, "get", str(outs[0])], env=run_env)
        assert r.returncode == 0, r.stdout[-3000:]
        assert lib.stat().st_ino == inode                                        # found, not unpacked again
        assert (runtimes[0] / ".spurdiff-runtime").stat().st_mtime > old + 86400  # and its use recorded
    finally:
        shutil.rmtree(base, ignore_errors=True)


# ---------------------------------------------------------------- the coupled scene, Windows master
MASTER = Path(__file__).resolve().parent / "win64_master.py"
SCENE = "vehicle-cornering"
# what the Windows master imports beyond the standard library, at the versions the harness runs here
MASTER_WHEELS = ("fmpy", "attrs", "lxml")
# and numpy (fmpy's and the harness's), at the newest version that runs under wine 8 (what the tests run
# the win64 binaries in): numpy 2.2.0 and later abort at import there (wine 8's ucrtbase lacks
# ``crealf``; 2.2.6 and 2.4.6 measured)
MASTER_NUMPY = "2.1.3"


def _versions() -> dict[str, str]:
    from importlib.metadata import version

    return {**{p: version(p) for p in MASTER_WHEELS}, "numpy": MASTER_NUMPY}


@pytest.fixture(scope="module")
def windows_python():
    """A Windows CPython of the build's 3.X with fmpy, attrs, lxml and numpy: the embeddable
    distribution the win64 runtime is made from, with ``win_amd64`` wheels (pip download) in its
    Lib/site-packages; made once in the per-user cache. The harness comes from this checkout."""
    from harness.build.runtime_win64 import TAG, Win64Unavailable, _embeddable, _pip_download, download_dir

    versions = _versions()
    home = download_dir() / ("master-python" + TAG + "-" + "-".join(f"{p}{v}" for p, v in sorted(versions.items())))
    exe = home / "python.exe"
    if not (home / "ready").is_file():
        wheels = download_dir() / "master" / "wheels"
        pins = [f"{p}=={v}" for p, v in versions.items()]
        r = subprocess.run([sys.executable, "-m", "pip", "download", "--no-deps", "--disable-pip-version-check", "-q",
                            "--only-binary=:all:", "--platform", "win_amd64", "--python-version", TAG[0] + "." + TAG[1:],
                            "-d", str(wheels), *pins], capture_output=True, text=True, timeout=600)
        if r.returncode != 0:
            pytest.skip(f"pip download {' '.join(pins)} for win_amd64 failed: {(r.stderr or r.stdout).strip()[-300:]}")
        try:
            sdist = _pip_download(download_dir() / "downloads")
        except Win64Unavailable as e:
            pytest.skip(str(e))
        shutil.rmtree(home, ignore_errors=True)
        site = home / "Lib" / "site-packages"
        site.mkdir(parents=True)
        emb = _embeddable(sdist)
        prefix = f"cp{TAG}/"
        for n in emb.namelist():
            if n.startswith(prefix) and not n.endswith("/"):
                (home / n[len(prefix):]).write_bytes(emb.read(n))
        # the embeddable's module path: its standard library, its folder, and the wheels' folder
        (home / f"python{TAG}._pth").write_text(f"python{TAG}.zip\r\n.\r\nLib\\site-packages\r\n")
        chosen = [next(wheels.glob(f"{p}-{v}-*.whl")) for p, v in versions.items()]
        for wheel in chosen:
            with zipfile.ZipFile(wheel) as z:
                z.extractall(site)
        (home / "ready").write_text("\n".join(w.name for w in chosen) + "\n")
    return exe


def _wine_path(p: Path) -> str:
    """A Linux path as wine's drive Z: sees it."""
    return "Z:" + str(p.resolve()).replace("/", "\\")


def _recorded(path: Path) -> dict:
    import json

    data = json.loads(path.read_text(encoding="utf-8"))
    assert data["failure"] is None, data["failure"]
    data["rows"] = [[float(x) for x in row] for row in data["rows"]]
    return data


@pytest.mark.parametrize("fmi", [2, 3])
def test_the_coupled_scene_under_a_windows_master_equals_linux64(fmi, wine, windows_python, fmu_files, tmp_path):
    """vehicle-cornering (car, differential, two wheels) run by the harness's own master on a Windows
    CPython with fmpy under wine, loading the FMUs' Windows binaries (FMI 2.0: binaries/win64, FMI
    3.0: binaries/x86_64-windows), extracted into a folder with a space and a non-ASCII character on
    drive C:; every recorded variable against the same master on linux64 (relative difference, or
    absolute below 1, at most 1e-9)."""
    from harness.build.fmu3 import WINDOWS_PLATFORM, build

    env, prefix = wine
    names = ("SpurDifferential", "WheelLoad", "Vehicle")
    files = {n: fmu_files[n] for n in names} if fmi == 2 else dict(zip(names, build(list(names), quiet=True)))
    platform = "win64" if fmi == 2 else WINDOWS_PLATFORM
    for name, path in files.items():
        with zipfile.ZipFile(path) as z:
            if f"binaries/{platform}/{name}.dll" not in z.namelist():
                pytest.skip(f"{path.name} has no binaries/{platform} (built where mingw-w64 was missing)")
    pairs = files
    linux_out = tmp_path / "linux64.json"
    r = _run([sys.executable, str(MASTER), SCENE, str(linux_out), str(tmp_path), *(f"{n}={p}" for n, p in pairs.items())])
    assert r.returncode == 0, r.stdout[-3000:]
    ref = _recorded(linux_out)
    extract = prefix / "drive_c" / f"{ODD} master"
    clean, worst, first = 0, {}, None
    try:
        for k in range(PROCESSES):
            shutil.rmtree(extract, ignore_errors=True)
            extract.mkdir(parents=True)
            out = tmp_path / f"win64-{k}.json"
            r = _run(["wine", _wine_path(windows_python), _wine_path(MASTER), SCENE, _wine_path(out),
                      f"C:\\{ODD} master", *(f"{n}={_wine_path(p)}" for n, p in pairs.items())], env=env)
            assert r.returncode == 0, r.stdout[-3000:]
            got = _recorded(out)
            assert got["platform"] == "win32" and got["names"] == ref["names"] and len(got["rows"]) == len(ref["rows"])
            for i, name in enumerate(ref["names"], 1):
                d = max(abs(a[i] - b[i]) / max(1.0, abs(a[i])) for a, b in zip(ref["rows"], got["rows"]))
                worst[name] = max(worst.get(name, 0.0), d)
            differ = [a[0] for a, b in zip(ref["rows"], got["rows"]) if a != b]
            if differ:
                first = differ[0] if first is None else min(first, differ[0])
            clean += 1
    finally:
        shutil.rmtree(extract, ignore_errors=True)
    print(f"{SCENE}, FMI {fmi}.0: {clean} of {PROCESSES} wine processes (Windows CPython {got['python']}, fmpy "
          f"{_versions()['fmpy']}) exited 0; {len(ref['rows'])} rows of {len(ref['names'])} variables; "
          f"first row differing from linux64: {'none' if first is None else f't = {first:g} s'}; largest difference "
          f"(relative, or absolute below 1) per instance:")
    for inst in dict.fromkeys(n.split(".")[0] for n in worst):
        mine = {n: d for n, d in worst.items() if n.split(".")[0] == inst}
        print(f"  {inst}: {max(mine.values()):.3g} ({', '.join(f'{n} {d:.2g}' for n, d in mine.items())})")
    assert max(worst.values()) <= 1e-9


# ---------------------------------------------------------------- FMI 3.0: binaries/x86_64-windows


@pytest.fixture(scope="module")
def fmi3_under_wine(fmu_files, wine, tmp_path_factory):
    """The FMI 3.0 FMUs unzipped into C:/spurdiff wine ü/<name>-fmi3/, and tests/c_host/fmi3_host.c
    built for linux64 and (with mingw-w64, -municode) for win64."""
    from harness.build.fmu3 import build

    _, prefix = wine
    paths = dict(zip(fmu_files, build(list(fmu_files), quiet=True)))
    root = prefix / "drive_c" / ODD
    out = {}
    for name, path in paths.items():
        with zipfile.ZipFile(path) as z:
            if f"binaries/x86_64-windows/{name}.dll" not in z.namelist():
                pytest.skip(f"{path.name} has no binaries/x86_64-windows (built where mingw-w64 was missing)")
            shutil.rmtree(root / f"{name}-fmi3", ignore_errors=True)
            z.extractall(root / f"{name}-fmi3")
        out[name] = root / f"{name}-fmi3"
    bins = tmp_path_factory.mktemp("hosts3")
    exe, elf = bins / "fmi3_host.exe", bins / "fmi3_host"
    build_c_host("fmi3_host", exe, windows=True)
    build_c_host("fmi3_host", elf)
    yield out, exe, elf
    for folder in out.values():
        shutil.rmtree(folder, ignore_errors=True)


def _gets(stdout: str) -> dict[int, float]:
    return {int(line.split()[1]): float(line.split()[2]) for line in stdout.splitlines() if line.startswith("get ")}


@pytest.mark.parametrize("name", list(CASES))
def test_each_fmi3_fmu_runs_under_wine_and_equals_linux64(name, wine, fmi3_under_wine):
    """The FMI 3.0 loader cross-built for Windows (binaries/x86_64-windows/<model>.dll, fmi3_loader.c
    on the FMI 2.0 loader) run by our FMI 3.0 C host under wine, resourcePath a native path with a
    drive letter, a space and a non-ASCII character; the linux64 binary's outputs from the same host."""
    from fmpy import read_model_description

    env, _ = wine
    folders, exe, elf = fmi3_under_wine
    folder = folders[name]
    md = read_model_description(str(folder))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outs = [v.valueReference for v in md.modelVariables if v.causality == "output" and v.type == "Float64"][:64]
    rest = [str(STOP), str(STEP), *(f"set:{vr[k]}={v!r}" for k, v in CASES[name].items()), *(f"get:{o}" for o in outs)]
    linux = _run([str(elf), str(folder / "binaries" / "x86_64-linux" / f"{name}.so"), md.guid,
                  str(folder / "resources"), *rest])
    assert linux.returncode == 0 and "freed" in linux.stdout, linux.stdout[-2000:]
    ref = _gets(linux.stdout)
    assert len(ref) == len(outs)
    win_dir = f"C:\\{ODD}\\{name}-fmi3\\"
    clean, worst = 0, 0.0
    for _ in range(PROCESSES):
        r = _run(["wine", str(exe), f"{win_dir}binaries\\x86_64-windows\\{name}.dll", md.guid, f"{win_dir}resources\\",
                  *rest], env=env)
        assert r.returncode == 0 and "status 0" in r.stdout and "freed" in r.stdout, r.stdout[-3000:]
        got = _gets(r.stdout)
        assert got.keys() == ref.keys()
        worst = max([worst, *(abs(got[k] - y) / max(1.0, abs(y)) for k, y in ref.items())])
        clean += 1
    print(f"{name}-fmi3: {clean} of {PROCESSES} wine processes exited 0; largest difference to linux64 over "
          f"{len(ref)} outputs: {worst:.3g} (relative, or absolute below 1)")
    assert worst <= 1e-9


def test_an_fmi3_resource_path_without_a_drive_letter_is_refused_under_wine(wine, fmi3_under_wine):
    env, _ = wine
    folders, exe, _ = fmi3_under_wine
    from fmpy import read_model_description

    md = read_model_description(str(folders["WheelLoad"]))
    win_dir = f"C:\\{ODD}\\WheelLoad-fmi3\\"
    r = _run(["wine", str(exe), f"{win_dir}binaries\\x86_64-windows\\WheelLoad.dll", md.guid,
              f"{ODD}\\WheelLoad-fmi3\\resources\\", str(STOP), str(STEP)], env=env)
    assert r.returncode == 4, r.stdout[-2000:]    # the host's "instantiate failed"
    assert "is not an absolute path to the FMU's extracted resources folder" in r.stdout, r.stdout
