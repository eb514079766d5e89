"""The first hour with the FMU alone (issue 31, docs/use-the-fmu.md): each FMU's default experiment
does something a user recognises in fmpy and in fmusim; the recipes per interface run as shipped
(fmpy script, C host, SSP in libcosim) and give the same steady turn."""
from __future__ import annotations

import csv
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

from harness.interop.recipes import fmpy_differential as recipe
from harness.interop.starter import write_starter


# the hosts started here unpack their FMU into a temporary folder they may never remove: tests/conftest.py
pytestmark = pytest.mark.usefixtures("children_scratch_in_tmp_path")


HERE = Path(__file__).resolve().parent
HOSTS = HERE.parents[2] / "shared" / "hosts"
DOC = HERE.parents[1] / "docs" / "use-the-fmu.md"
BARE_ENV = {"PATH": "/usr/bin:/bin"}
STOP = 0.5


# ------------------------------------------------------------------ default experiments
def _fmusim(fmu: Path, tmp_path: Path) -> dict[str, np.ndarray]:
    out = tmp_path / f"{fmu.stem}.csv"
    r = subprocess.run([str(HOSTS / "fmusim"), "--interface-type", "cs", "--output-file", str(out), str(fmu)],
                       env=BARE_ENV, capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    rows = list(csv.reader(open(out, newline="")))
    names = [n.strip().strip('"') for n in rows[0]]
    return {n: np.array([float(row[i]) for row in rows[1:]]) for i, n in enumerate(names)}


def _fmpy(fmu: Path, capsys) -> dict[str, np.ndarray]:
    res = simulate_fmu(str(fmu))           # no inputs, no start values: the default experiment
    assert "missing input" not in capsys.readouterr().out
    return {n: np.asarray(res[n], dtype=float) for n in res.dtype.names}


@pytest.mark.parametrize("host", ["fmpy", pytest.param("fmusim", marks=pytest.mark.skipif(
    not (HOSTS / "fmusim").exists(), reason="fmusim (../shared/hosts) is absent"))])
def test_default_experiments_do_something_a_user_recognises(host, fmu_files, tmp_path, capsys):
    run = (lambda f: _fmusim(f, tmp_path)) if host == "fmusim" else (lambda f: _fmpy(f, capsys))
    # the differential: slip, then stick: sun A starts 20 rad/s ahead of the carrier, the locking friction
    # stops it within 10 ms and then holds the uneven load (-200 / -300 N m) locked
    d = run(fmu_files["SpurDifferential"])
    assert d["time"][-1] == pytest.approx(0.3)
    assert d["stuck"][0] == 0.0 and d["stuck"][-1] == 1.0 and d["left.w"][0] == pytest.approx(1.389 + 20.0)
    late = d["time"] >= 0.01
    for n, value in (("carrier.w", 1.389), ("left.w", 1.389), ("right.w", 1.389), ("carrier.tauDrive", 500.0),
                     ("left.tauMesh", 200.0), ("right.tauMesh", 300.0), ("lockingTorque", -100.0)):
        assert np.allclose(d[n][late], value, rtol=1e-9), n
    assert np.all(d["stuck"][late] == 1.0) and np.all(d["capacity.exceeded"] == 0.0)
    # the wheel: a locked-wheel skid at 10 m/s under 3000 N, the wheel held by its shaft, settling
    w = run(fmu_files["WheelLoad"])
    assert w["slip"][-1] == -1.0 and -0.95 < w["Fx"][-1] / 3000.0 < -0.85
    assert abs(w["wheel.w"][-1]) < 1e-6 and w["shaft.tau"][-1] == pytest.approx(w["Fx"][-1] * 0.3266, rel=1e-3)
    # the car: the main job's steady turn, 10 m/s on R = 20 m
    c = run(fmu_files["Vehicle"])
    late = c["time"] >= 5.0
    assert np.allclose(c["vx"][late], 10.0, rtol=1e-3) and np.allclose(c["yawRate"][late], 0.5, rtol=2e-3)
    assert np.allclose(c["ay"][late], 5.0, rtol=2e-3) and np.allclose(c["driveTorque"][late], 152.0, rtol=0.03)


def test_the_differentials_default_experiment_is_quiet_and_slips_then_sticks(fmu_files):
    """Issue 46 item 4: with debug logging on, every message of the default experiment is status OK (no
    rating finding, no stack-up warning, no run-time alarm); the relative speed sun A - carrier falls from
    20 rad/s to 0 while the locking slips at its capacity, then the differential sticks and holds the
    uneven split; every output the torque interface computes at the rigid level moves."""
    logged = []

    def logger(component, instance, status, category, message):
        logged.append((status, category.decode(), message.decode()))

    d = simulate_fmu(str(fmu_files["SpurDifferential"]), debug_logging=True, logger=logger)
    assert logged and all(s == 0 for s, _, _ in logged), [m for m in logged if m[0] != 0]
    assert not any("error" in m.lower() or "warning" in m.lower() for _, _, m in logged), logged
    t, wd = d["time"], d["left.w"] - d["carrier.w"]
    slipping, stuck = d["stuck"] == 0.0, d["stuck"] == 1.0
    k = int(np.argmax(stuck))                        # the first stuck point: slip, then stick for good
    assert k > 3 and np.all(slipping[:k]) and np.all(stuck[k:]) and t[k] < 0.02
    assert wd[0] == pytest.approx(20.0) and np.all(np.diff(wd[:k + 1]) < 0.0) and np.all(np.abs(wd[k:]) < 1e-9)
    # slipping, the locking torque is the capacity (sliding); stuck, it is the load difference, inside it
    assert np.allclose(np.abs(d["lockingTorque"][1:k]), d["lockingCapacity"][1:k], rtol=1e-9)
    assert np.all(np.abs(d["lockingTorque"][k:]) < d["lockingCapacity"][k:])
    names = [n for n in d.dtype.names if n != "time"]
    moving = [n for n in names if np.ptp(d[n]) > 0.0]
    # still by design: the half-shaft outputs (shaftCoupling = wheel), the mesh levels' (meshModel =
    # rigid), the imposed carrier speed and the two alarms, which must not fire
    still = {"leftShaft.tau", "rightShaft.tau", "leftShaft.dwWheel", "rightShaft.dwWheel", "leftShaft.tauEnd",
             "rightShaft.tauEnd", "leftShaft.phi_rel", "rightShaft.phi_rel", "potentialEnergy", "parametricWork",
             "contactTransitions", "loadedFlanks", "carrier.w", "overspeed", "capacity.exceeded"}
    assert set(names) - set(moving) == still and len(moving) >= 22, (len(moving), len(names))


# ------------------------------------------------------------------ the theory and the doc's table
@pytest.mark.skipif(shutil.which("gcc") is None, reason="no C compiler (gcc) for our own C host")
def test_the_differentials_default_experiment_in_our_c_host_is_fmpys(fmu_files, tmp_path):
    """The same default experiment (no start values, 300 steps of 1 ms) in our own C host
    (tests/c_host/fmi2_any_host.c, a bare environment, a folder with a space and 'ü'): every output at
    0.3 s is fmpy's (bit for bit but the angles, to rounding)."""
    import zipfile

    from host_cases import build_c_host

    fmu = fmu_files["SpurDifferential"]
    exe = build_c_host("fmi2_any_host", tmp_path / "fmi2_any_host")
    unpacked = tmp_path / "unpacked ü"
    with zipfile.ZipFile(fmu) as z:
        z.extractall(unpacked)
    md = read_model_description(str(unpacked))
    de = md.defaultExperiment
    steps = round((float(de.stopTime) - float(de.startTime)) / float(de.stepSize))
    outs = [v for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    r = subprocess.run([str(exe), str(unpacked / "binaries" / "linux64" / "SpurDifferential.so"), md.guid,
                        (unpacked / "resources").as_uri(), str(steps), repr(float(de.stepSize)), "1", "get",
                        ",".join(str(v.valueReference) for v in outs)],
                       env=BARE_ENV, capture_output=True, text=True, timeout=120, cwd=tmp_path)
    found = re.findall(r"^run 0 status 0 (.*)$", r.stdout, re.M)
    assert r.returncode == 0 and len(found) == 1, r.stdout[-2000:] + r.stderr[-2000:]
    got = {int(k): float(v) for k, v in (kv.split("=") for kv in found[0].split())}
    d = simulate_fmu(str(fmu))
    assert d["time"][-1] == pytest.approx(float(de.stopTime)) and len(outs) >= 30
    # fmpy steps from n h to (n + 1) h, so its step sizes differ from 1 ms in the last bits; our host
    # steps exactly 1 ms: the angles, integrated over the step sizes, agree to rounding, the rest bit for bit
    differ = {v.name: (got[v.valueReference], float(d[v.name][-1])) for v in outs
              if got[v.valueReference] != float(d[v.name][-1])}
    angles = {n for n in differ if n.endswith(".phi")}
    assert set(differ) == angles, differ
    assert all(abs(a - b) <= 1e-14 * abs(b) for a, b in differ.values()), differ


def _doc_row(recipe_name: str) -> list[str]:
    """The cells of docs/use-the-fmu.md's measured table row of ``recipe_name`` ("fmpy, wheel", ...)."""
    for line in DOC.read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if cells[0].startswith(recipe_name):
            return cells
    raise AssertionError(f"{DOC.name} has no table row for {recipe_name!r}")


def _shaft_torques_theory(params, w_c: float, T0: float) -> tuple[float, float, float]:
    """(inner, outer shaft torque, K_v) of a slipping differential, T0 (1 +- K_v) / 2: spurdiff's locking
    law with the sliding lever at carrier speed ``w_c`` (the planets' centrifugal pin loads), sun A
    (left, inner) behind the carrier, as harness.scene.theory computes a scene's theory.INST.K_sliding."""
    from spurdiff.differential.inertia import mass_properties
    from spurdiff.differential.locking import pin_friction
    from spurdiff.differential.speed_law import breakaway_at_speed

    p = params
    assert p.lockingLaw == "pinFriction" and p.lockingPreload == 0.0   # T0 (1 +- K) / 2 needs no preload
    geo = p.validate()
    mp = mass_properties(p, geo)
    masses = (mp.m_planet1, mp.m_planet2) if p.pinSpeedLoads else (0.0, 0.0)
    pf = pin_friction(geo, p.mu_sliding, p.r_collar, p.lockingPreload, p.lockingLaw, p.pinModel, p.pairHandedness,
                      p.pinContactFactor)
    K = breakaway_at_speed(pf, geo, masses, w_c, T0, -1.0).K
    return 0.5 * T0 * (1.0 + K), 0.5 * T0 * (1.0 - K), K


def _recipe_params():
    """The DifferentialParams of the fmpy / C recipes: the FMU's start values with the recipe's parameters."""
    from spurdiff.fmi.differential_fmu import VARIABLES, differential_params

    values = {v.name: v.start for v in VARIABLES if v.causality == "parameter" and v.start is not None}
    values.update({k: v for k, v in recipe.start_values("wheel").items() if k in values})
    return differential_params(values)


# ------------------------------------------------------------------ the fmpy recipe
@pytest.fixture(scope="module")
def recipe_runs(fmu_files):
    fmu = str(fmu_files["SpurDifferential"])
    return {"wheel": recipe.run_wheel(fmu, STOP, 5e-3), "torque": recipe.run_torque(fmu, STOP, 2e-4)}


def test_fmpy_recipe_both_interfaces_reach_the_same_steady_turn(recipe_runs):
    means = {k: recipe.summary(r, since=0.6 * STOP) for k, r in recipe_runs.items()}
    for interface, s in means.items():
        r = recipe_runs[interface]
        tail = r["time"] >= 0.6 * STOP
        for n in ("leftShaft.tau", "rightShaft.tau", "lockingTorque"):   # steady: settled over the window
            assert np.ptp(r[n][tail]) < 2e-5 * abs(s[n]), (interface, n, np.ptp(r[n][tail]))
        assert s["stuck"] == 0.0                                           # it turns: the suns slip
        assert s["lockingTorque"] == pytest.approx(s["lockingCapacity"], rel=1e-9)   # at full capacity
        assert s["leftShaft.tau"] + s["rightShaft.tau"] == pytest.approx(recipe.DRIVE_TORQUE, rel=1e-6)
        assert s["leftShaft.tau"] - s["rightShaft.tau"] == pytest.approx(s["lockingTorque"], rel=1e-6)
        assert s["left.w"] == pytest.approx(recipe.W_INNER, rel=1e-6) and s["right.w"] == pytest.approx(recipe.W_OUTER, rel=1e-6)
    for n in ("leftShaft.tau", "rightShaft.tau", "lockingTorque"):
        assert means["wheel"][n] == pytest.approx(means["torque"][n], rel=1e-6), n
    # the theory: the inner sun behind the carrier (left.w < carrier.w), slipping at K_v of the carrier speed;
    # the coupling (half-shafts, the wheel interface's step mean) moves the means by 5e-8 (measured)
    for interface, s in means.items():
        assert s["left.w"] < s["carrier.w"]
        inner, outer, K = _shaft_torques_theory(_recipe_params(), s["carrier.w"], recipe.DRIVE_TORQUE)
        assert s["leftShaft.tau"] == pytest.approx(inner, rel=1e-6), interface
        assert s["rightShaft.tau"] == pytest.approx(outer, rel=1e-6), interface
        assert s["lockingTorque"] == pytest.approx(K * recipe.DRIVE_TORQUE, rel=1e-6), interface
    # docs/use-the-fmu.md's table quotes these runs to its 4 decimals
    for interface, row in (("wheel", _doc_row("fmpy, wheel")), ("torque", _doc_row("fmpy, torque"))):
        documented = [float(c.split()[0]) for c in row[2:5]]
        got = [means[interface][n] for n in ("leftShaft.tau", "rightShaft.tau", "lockingTorque")]
        assert [f"{g:.4f}" for g in got] == [f"{d:.4f}" for d in documented], (interface, got, documented)


def test_fmpy_recipe_script_runs_as_shipped_without_missing_input_warnings(fmu_files, tmp_path):
    files, cmd = write_starter("fmpy", "wheel", tmp_path)
    r = subprocess.run([sys.executable, "fmpy_differential.py", "--interface", "wheel", "--fmu", "SpurDifferential.fmu",
                        "--stop", str(STOP)], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "missing input" not in r.stdout + r.stderr
    assert f"inner (left) shaft torque  {_doc_row('fmpy, wheel')[2]} N m" in r.stdout   # the doc's table


def test_input_table_fills_every_input_so_fmpy_warns_about_none(fmu_files, capsys):
    md = read_model_description(str(fmu_files["SpurDifferential"]))
    t = np.array([0.0, 1.0])
    table = recipe.input_table(md, t, {"leftWheel.w": np.array([1.0, 2.0])}, {"carrier.tau": 5.0})
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    assert list(table.dtype.names) == ["time"] + inputs
    assert list(table["leftWheel.w"]) == [1.0, 2.0] and set(table["carrier.tau"]) == {5.0}
    assert set(table["carrier.w_ref"]) == {1.389}      # not driven: its start value
    # without the filling fmpy prints a warning per input it was not given
    simulate_fmu(str(fmu_files["SpurDifferential"]), input=table[["time", "leftWheel.w"]], stop_time=0.002,
                 step_size=1e-3)
    assert capsys.readouterr().out.count("missing input") == len(inputs) - 1


# ------------------------------------------------------------------ the C host
@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
@pytest.mark.parametrize("interface", ["wheel", "torque"])
def test_c_host_starter_compiles_runs_bare_and_equals_the_fmpy_recipe(interface, recipe_runs, tmp_path):
    files, cmd = write_starter("c", interface, tmp_path)
    cc = subprocess.run(["cc", "-O2", "-Wall", "-Werror", "-o", "host", "host.c", "-ldl"], cwd=tmp_path,
                        capture_output=True, text=True)
    assert cc.returncode == 0, cc.stderr
    r = subprocess.run(["./host", str(STOP)], cwd=tmp_path, env=BARE_ENV, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    got = {m.group(1): float(m.group(2)) for m in
           (re.match(r"^(\D+?)\s+(-?\d+\.\d+)", line) for line in r.stdout.splitlines()[1:]) if m}
    assert len(got) == 4, r.stdout
    s = recipe.summary(recipe_runs[interface], since=0.6 * STOP)
    assert got["inner (left) shaft torque"] == pytest.approx(s["leftShaft.tau"], rel=1e-9)
    assert got["outer (right) shaft torque"] == pytest.approx(s["rightShaft.tau"], rel=1e-9)
    assert got["locking torque"] == pytest.approx(s["lockingTorque"], rel=1e-9)
    assert got["carrier speed"] == pytest.approx(s["carrier.w"], rel=1e-9)


# ------------------------------------------------------------------ the SSP in libcosim
def test_ssp_starters_run_in_libcosim_and_both_interfaces_agree(tmp_path):
    pytest.importorskip("libcosimpy", reason="libcosimpy is not installed (pip install libcosimpy)")
    means = {}
    for interface in ("wheel", "torque"):
        out = tmp_path / interface
        files, cmd = write_starter("ssp", interface, out, duration=0.3)
        r = subprocess.run([sys.executable, *cmd.split()[1:]], cwd=out, capture_output=True, text=True,
                           timeout=300, env={**os.environ, "PYTHONUNBUFFERED": "1"})
        assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
        # the starter's "name value" lines; libcosim also prints the FMU's log lines (time-stamped) on stdout
        rows = [m.groups() for m in map(re.compile(r"^\s*([A-Za-z][\w.]*)\s+(-?[\d.]+(?:[eE][-+]?\d+)?)$").match, r.stdout.splitlines()[1:]) if m]
        means[interface] = {k: float(v) for k, v in rows}
    w, t = means["wheel"], means["torque"]
    for n in ("diff.leftShaft.tau", "diff.rightShaft.tau", "diff.lockingTorque"):   # 5 ms wheel vs 0.2 ms torque
        assert w[n] == pytest.approx(t[n], rel=2e-3), n
    assert w["diff.leftShaft.tau"] - w["diff.rightShaft.tau"] == pytest.approx(w["diff.lockingTorque"], rel=1e-3)
    # the main job's turn: the car's axle torque (152.4 N m steady; its speed controller still rising over
    # the first 0.3 s), the carrier at the mean rear wheel speed, the suns slipping at the theory's K_v
    from harness.scene.spec import load_scene
    from harness.scene.theory import diff_params

    params = diff_params(load_scene("vehicle-cornering"), "diff")
    for interface, m in means.items():
        T0 = m["diff.leftShaft.tau"] + m["diff.rightShaft.tau"]
        assert T0 == pytest.approx(recipe.DRIVE_TORQUE, rel=0.03), interface
        assert m["diff.carrier.w"] == pytest.approx(0.5 * (recipe.W_INNER + recipe.W_OUTER), rel=1e-3), interface
        # means of a product over a window in which T0 rises (and the suns' inertia torque): 2e-6 measured
        inner, outer, K = _shaft_torques_theory(params, m["diff.carrier.w"], T0)
        assert m["diff.leftShaft.tau"] == pytest.approx(inner, rel=1e-4), interface
        assert m["diff.rightShaft.tau"] == pytest.approx(outer, rel=1e-4), interface


# ------------------------------------------------------------------ two runs in one Python process
_TWO_RUNS = """
import sys
from fmpy import extract, simulate_fmu
diff, wheel = sys.argv[1:3]
if sys.argv[3] == "extract":   # the workaround: extract once, keep the folders for the process's life
    diff, wheel = extract(diff), extract(wheel)
simulate_fmu(diff)
simulate_fmu(wheel)
simulate_fmu(wheel)
print("three runs ok")
"""


def _two_runs(fmu_files, how: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", _TWO_RUNS, str(fmu_files["SpurDifferential"]),
                           str(fmu_files["WheelLoad"]), how], capture_output=True, text=True, timeout=300,
                          cwd="/", env={k: v for k, v in os.environ.items() if k != "PYTHONPATH"})


def test_several_runs_in_one_process_work_from_extracted_folders(fmu_files):
    """The workaround docs/use-the-fmu.md gives for the known problem below."""
    r = _two_runs(fmu_files, "extract")
    assert r.returncode == 0 and "three runs ok" in r.stdout, r.stdout[-2000:] + r.stderr[-2000:]


def test_several_simulate_fmu_calls_on_fmu_files_in_one_process(fmu_files):
    """Each FMU imports its own package under a private name per extraction folder (issue 25):
    simulate_fmu's deleted folders are never reused."""
    r = _two_runs(fmu_files, "files")
    assert r.returncode == 0 and "three runs ok" in r.stdout, r.stderr[-500:]
