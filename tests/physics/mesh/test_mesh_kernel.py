"""The compiled kernel of the mesh levels (fmu_src/native/kernels/mesh_kernel.c) against the pure-Python
reference: the same states after every communication step (to 1e-12 relative; they are in fact
equal bit for bit: both factor with the same LU, integrator.lu_factor) over the paper scenes' loads and the hard
cases, at every level and effect, with each integration method (solver.method); the choice of
implementation (solver.kernel); the FMU runs it, also in a C host with a bare environment."""
from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

from harness.measure.bench.mesh_cases import paper_case
from harness.build.fmu import kernel_library
from spurdiff.errors import ParameterError, StepError
from spurdiff.differential.mesh import MeshDifferential, MeshParams, kernel
from spurdiff.differential.params import DifferentialParams

RTOL = 1e-12
SCALE = np.array([1.0, 1e-5, 1e-5, 1e-5, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0])   # rad, m, rad/s (the error norm's)
EFFECTS = {
    "none": {}, "backlash": {"backlash": True}, "stiffness wave": {"meshStiffnessVariation": True},
    "flank friction": {"flankFriction": True}, "no pin friction": {"pinFriction": False},
    "all": {"backlash": True, "meshStiffnessVariation": True, "flankFriction": True},
}


@pytest.fixture(scope="module", autouse=True)
def compiled_kernel():
    """Compiled by the build code into the FMU folder, as `spurdiff build` does."""
    return kernel_library()


def pair(level, case, drive="speed", law=None, tau_c=2100.0, **mesh):
    """The same model twice: the Python reference and the compiled kernel."""
    out = []
    for impl in ("python", "compiled"):
        p = DifferentialParams(carrierDrive=drive, lockingLaw=law or case["lockingLaw"],
                               J_carrier=13.0 if drive == "torque" else 0.0)
        m = MeshDifferential(p, MeshParams(level=level, kernel=impl, **mesh))
        m.w_ref = m.w_start_carrier = case["w0"]
        m.tau_c = tau_c if drive == "torque" else 0.0
        m.tau_L, m.tau_R = case["loads"]
        m.initialize()
        out.append(m)
    assert out[0].kernel_in_use.startswith("python") and out[1].kernel_in_use == "compiled"
    return out


def difference(a, b) -> float:
    """Largest state difference, relative to the state (or its scale where it is near zero)."""
    ya, yb = np.array(list(a.y)), np.array(list(b.y))      # (a list, or the kernel's array)
    sc = np.maximum(np.abs(ya), SCALE[:ya.size])
    return float(np.max(np.abs(ya - yb) / sc))


def step_both(a, b, n, h, t0=0.0, inputs=None) -> float:
    worst = 0.0
    for k in range(n):
        if inputs:
            for m in (a, b):
                inputs(m, k)
        a.do_step(t0 + k * h, h)
        b.do_step(t0 + k * h, h)
        worst = max(worst, difference(a, b))
        assert worst <= RTOL, f"step {k}: states differ by {worst:.3g} (relative)"
    for name in ("tau_drive", "tau_mesh_L", "tau_mesh_R", "locking_torque", "locking_capacity", "power_loss",
                 "work_in", "energy_loss", "parametric_work", "wc", "phic", "phi_R"):
        va, vb = getattr(a, name), getattr(b, name)
        assert abs(va - vb) <= RTOL * max(abs(va), 1.0), f"{name}: {va!r} vs {vb!r}"
    for name in ("n_internal_steps", "n_rejected_steps", "n_mode_switches", "n_contact_transitions", "s"):
        assert getattr(a, name) == getattr(b, name), name
    assert a.solver_counts() == b.solver_counts()      # the same Jacobians and factorizations reused
    return worst


METHODS = ("ros34pw2", "rodas5p")


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("effects", list(EFFECTS))
@pytest.mark.parametrize("level", ["compliant", "contact"])
@pytest.mark.parametrize("scene", ["paper-straight", "paper-cornering"])
def test_kernel_agrees_with_the_reference_on_the_paper_scenes(scene, level, effects, method):
    """From unloaded meshes (the start transient: impacts, stick-slip, ringing) and preloaded."""
    case = paper_case(scene)
    for preload, n in ((False, 6), (True, 3)):
        a, b = pair(level, case, preload=preload, method=method, **EFFECTS[effects])
        step_both(a, b, n, case["step"])


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("level,effects", [("compliant", "backlash"), ("contact", "all"), ("contact", "none")])
def test_kernel_agrees_with_the_torque_drive(level, effects, method):
    a, b = pair(level, paper_case("paper-cornering"), drive="torque", preload=False, method=method,
                **EFFECTS[effects])
    step_both(a, b, 6, 1e-3)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("level", ["compliant", "contact"])
def test_kernel_agrees_through_a_torque_reversal_in_the_backlash(level, method):
    case = paper_case("paper-straight")
    a, b = pair(level, case, law="pinFriction", backlash=True, pinFriction=False, method=method)

    def reverse(m, k):
        if k == 2:
            m.tau_L, m.tau_R = 1050.0, 1050.0
    step_both(a, b, 8, 1e-3, inputs=reverse)
    assert a.n_contact_transitions > 0


@pytest.mark.parametrize("method", METHODS)
def test_kernel_agrees_through_break_away_and_re_stick(method):
    """Pin-load law: the load difference ramps through the capacity and back."""
    case = dict(paper_case("paper-straight"), lockingLaw="pinFriction")
    a, b = pair("contact", case, method=method)
    KT0 = a.K * 2100.0

    def ramp(m, k):
        D = KT0 * (0.9 + 0.05 * k) if k < 5 else KT0 * (1.1 - 0.1 * (k - 5))
        m.tau_L, m.tau_R = -1050.0 - D / 2, -1050.0 + D / 2
    step_both(a, b, 10, 1e-3, inputs=ramp)
    assert a.n_mode_switches > 0


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("h,n", [(1e-2, 3), (1e-5, 30)])
def test_kernel_agrees_at_coarse_and_tiny_steps(h, n, method):
    a, b = pair("contact", paper_case("paper-cornering"), preload=False, backlash=True, method=method)
    step_both(a, b, n, h)


@pytest.mark.parametrize("method", METHODS)
def test_kernel_agrees_with_a_ten_times_rated_torque_step(method):
    a, b = pair("compliant", paper_case("paper-straight"), backlash=True, method=method)
    step_both(a, b, 4, 1e-3, inputs=lambda m, k: setattr(m, "tau_L", -10500.0) if k == 1 else None)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("level,effects", [("contact", "none"), ("compliant", "backlash")])
def test_kernel_agrees_over_a_run_with_dense_output(level, effects, method):
    """The solver comparison's one call (run_dense: one step over the run, the states at the
    output times by the dense output) from unloaded meshes, the same in C as in Python."""
    a, b = pair(level, paper_case("paper-straight"), preload=False, method=method, **EFFECTS[effects])
    times = np.linspace(0.0, 0.02, 21)[1:]
    ya, yb = np.array(a.run_dense(0.02, times)), np.array(b.run_dense(0.02, times))
    assert ya.tolist() == yb.tolist()          # bit for bit, the dense output's order of operations too
    assert np.array_equal(ya[-1], list(a.y)) and a.n_internal_steps == b.n_internal_steps > 20
    # the dense output between the steps is as accurate as steps that stop at the output times (the
    # do_step loop at the same tolerance), against 1 ms steps of a tight tolerance (the rattle of
    # the backlash case is sensitive: both errors about 0.25 rad/s there, 7e-7 in the contact case)
    _, c = pair(level, paper_case("paper-straight"), preload=False, tolerance=1e-10, **EFFECTS[effects])
    _, d = pair(level, paper_case("paper-straight"), preload=False, method=method, **EFFECTS[effects])
    ref, loop = [], []
    for k in range(20):
        c.do_step(k * 1e-3, 1e-3)
        d.do_step(k * 1e-3, 1e-3)
        ref.append(list(c.y))
        loop.append(list(d.y))
    sc = SCALE[:ya.shape[1]]
    assert np.max(np.abs(ya - ref) / sc) <= 1.5 * np.max(np.abs(np.array(loop) - ref) / sc) + 1e-7
    with pytest.raises(ParameterError, match="times"):
        b.run_dense(0.02, [0.01, 0.005])


@pytest.mark.parametrize("method", METHODS)
def test_kernel_agrees_after_a_state_is_loaded_from_outside(method):
    """load_state_vector drops the integrator's memory of the old state in both implementations
    (its f at y and its Jacobian; the Python reference reused the old f0 and they parted by 2e-8)."""
    a, b = pair("contact", paper_case("paper-straight"), preload=False, method=method)
    step_both(a, b, 3, 1e-3)
    y = a.state_vector()
    y[1] *= 1.01                       # mesh A1 deflected 1 % more
    for m in (a, b):
        m.load_state_vector(y)
    step_both(a, b, 3, 1e-3, t0=3e-3)


def test_rodas5p_takes_a_jacobian_at_every_step_and_ros34pw2_reuses_it():
    """RODAS5P is not a W-method: a Jacobian at the end of every accepted step (and at the
    start), in both implementations; ROS34PW2 reuses one for up to 10 steps."""
    counts = {}
    for method in METHODS:
        a, b = pair("contact", paper_case("paper-straight"), preload=False, method=method)
        step_both(a, b, 5, 1e-3)
        counts[method] = b.solver_counts()
    r, w = counts["rodas5p"], counts["ros34pw2"]
    assert r["jacobians"] >= r["steps"] and r["factorizations"] >= r["steps"], r
    assert w["jacobians"] < w["steps"] / 4, w


def test_compiled_evaluation_equals_the_reference_evaluation():
    """rhs, Jacobian and side values at states off the trajectory, stuck and slipping planets."""
    from spurdiff.differential.mesh.forces import evaluate
    from spurdiff.differential.mesh.layout import constant_jacobian

    rng = np.random.default_rng(1)
    a, b = pair("contact", paper_case("paper-cornering"), drive="torque", backlash=True, flankFriction=True,
                meshStiffnessVariation=True)
    for modes in ([0, 0], [1, -1], [0, 1]):
        a.s = list(modes)
        for _ in range(5):
            N = len(a.y)
            y = (np.array(a.y) + rng.normal(size=N) * SCALE[:N] * np.array([1, 3, 3, 3, 1, 1, 1, 1, 1, 1])).tolist()
            f_py, f_c = [0.0] * N, [0.0] * N
            J_py, J_c = [[0.0] * N for _ in range(N)], [[0.0] * N for _ in range(N)]
            for J in (J_py, J_c):
                constant_jacobian(J, a.rbA, a.rb1, a.rbB, a.rb2, a.speed_drive)
            sv_py = evaluate(a, y, f_py, J_py)
            sv_c = b._kernel.evaluate(a, y, f_c, J_c)
            assert f_py == f_c and J_py == J_c and tuple(sv_py) == sv_c


@pytest.mark.parametrize("method", METHODS)
def test_a_failed_step_leaves_the_compiled_model_unchanged(method):
    case = paper_case("paper-straight")
    _, m = pair("compliant", case, backlash=True, pinFriction=False, maxInternalSteps=10, method=method)
    m.do_step(0.0, 1e-3)
    m.tau_L = m.tau_R = 1050.0
    before = json.dumps(m.get_state())
    with pytest.raises(StepError, match="maxInternalSteps"):
        m.do_step(1e-3, 1e-3)
    assert json.dumps(m.get_state()) == before


def test_the_choice_of_implementation(monkeypatch):
    case = paper_case("paper-straight")
    a, b = pair("contact", case)
    assert a._kernel is None and b._kernel is not None
    monkeypatch.setattr(kernel, "load", lambda: (None, "no library here"))
    m = MeshDifferential(DifferentialParams(), MeshParams(level="contact"))
    m.initialize()
    assert m.kernel_in_use == "python (no library here)"
    with pytest.raises(ParameterError, match="kernel") as e:
        MeshDifferential(DifferentialParams(), MeshParams(level="contact", kernel="compiled")).initialize()
    assert "no library here" in str(e.value)
    with pytest.raises(ParameterError, match="kernel"):
        MeshDifferential(DifferentialParams(), MeshParams(kernel="fast")).initialize()


def test_a_stale_or_foreign_library_is_refused(tmp_path, monkeypatch):
    """A library whose structures do not match (another source) is not loaded, and says why."""
    lib = tmp_path / "mesh_kernel-stale.so"
    src = tmp_path / "k.c"
    src.write_text(f"int mk_abi(void) {{ return {kernel.ABI}; }}\nlong mk_sizeof_params(void) {{ return 8; }}\n"
                   "long mk_sizeof_state(void) {{ return 8; }}\n")
    subprocess.run(["cc", "-shared", "-fPIC", str(src), "-o", str(lib)], check=True)
    monkeypatch.setattr(kernel, "SEARCH_PATH", [tmp_path])
    monkeypatch.setattr(kernel, "_candidates", lambda: [lib])
    kernel.reset()
    try:
        got, why = kernel.load()
        assert got is None and "structure sizes differ" in why
    finally:
        kernel.reset()


@pytest.mark.parametrize("method", METHODS)
def test_the_fmu_runs_the_kernel_with_the_reference_results(differential_fmu, method):
    from fmpy import simulate_fmu

    start = {"meshModel": "contact", "backlash": True, "flankFriction": True, "mesh.preload": False,
             "carrier.w_ref": 1.389, "left.tau": -1110.201, "right.tau": -989.799, "solver.method": method}
    logs = []
    runs = {k: simulate_fmu(str(differential_fmu), stop_time=0.02, output_interval=1e-3,
                            start_values={**start, "solver.kernel": k},
                            logger=lambda *a: logs.append(str(a[-1])), debug_logging=True)
            for k in ("python", "compiled")}
    for name in ("carrier.tauDrive", "left.tauMesh", "mesh.F_12", "left.w", "energyLoss", "internalSteps"):
        assert np.array_equal(runs["python"][name], runs["compiled"][name]), name
    assert any("compiled implementation" in s for s in logs) and any("python (kernel = python)" in s for s in logs)


def test_the_fmu_parameter_solver_method_reaches_the_integrator(differential_fmu):
    """solver.method = rodas5p through fmpy takes the steps of a direct RODAS5P run (fewer than
    ROS34PW2's over the unloaded start), auto (the default) RODAS5P's at the contact level; an
    unknown method is refused, naming the parameter."""
    from fmpy import simulate_fmu

    from spurdiff.gears.design_sets import fmu_parameters
    # the paper's gear set from rest, as the direct model below (DifferentialParams() is the paper's set)
    start = {**fmu_parameters("paper"), "differential.w_start": 0.0, "meshModel": "contact", "mesh.preload": False,
             "carrier.w_ref": 1.389, "left.tau": -1050.0, "right.tau": -1050.0, "tolerance": 1e-8}
    steps = {}
    for method in ("auto",) + METHODS:
        res = simulate_fmu(str(differential_fmu), stop_time=0.01, output_interval=1e-3,
                           start_values={**start, "solver.method": method})
        steps[method] = int(res["internalSteps"][-1])
        m = MeshDifferential(DifferentialParams(), MeshParams(level="contact", preload=False, tolerance=1e-8,
                                                             method=method))
        m.w_ref = m.w_start_carrier = 1.389
        m.tau_L = m.tau_R = -1050.0
        m.initialize()
        for k in range(10):
            m.do_step(k * 1e-3, 1e-3)
        assert steps[method] == m.n_internal_steps, method
    assert steps["rodas5p"] < steps["ros34pw2"] / 2 and steps["auto"] == steps["rodas5p"], steps
    logs = []
    with pytest.raises(Exception, match="ExitInitializationMode"):
        simulate_fmu(str(differential_fmu), stop_time=0.01, start_values={**start, "solver.method": "rk4"},
                     logger=lambda *a: logs.append(str(a[-1])), debug_logging=True)
    assert any("solver.method = 'rk4' is invalid: allowed auto | ros34pw2 | rodas5p" in s for s in logs), logs[-5:]


HOSTS = Path(__file__).resolve().parents[4] / "shared" / "hosts"   # ../shared/hosts beside the checkout


@pytest.mark.skipif(not (HOSTS / "fmusim").is_file(), reason=f"{HOSTS / 'fmusim'} is absent")
@pytest.mark.parametrize("method", METHODS)
def test_fmusim_runs_the_compiled_kernel_with_a_bare_environment(differential_fmu, tmp_path, method):
    """The Reference FMUs' fmusim, started with env -i: the log names the compiled implementation
    and the results equal fmpy's run of the Python reference, with each method."""
    from fmpy import simulate_fmu

    start = {"meshModel": "contact", "backlash": True, "mesh.preload": False, "carrier.w_ref": 1.389,
             "left.tau": -1050.0, "right.tau": -1040.0, "solver.method": method}
    args = []
    for k, v in start.items():
        args += ["--start-value", k, str(v).lower() if isinstance(v, bool) else str(v)]
    out, log = tmp_path / "out.csv", tmp_path / "log.txt"
    r = subprocess.run([str(HOSTS / "fmusim"), "--interface-type", "cs", "--output-interval", "1e-3",
                        "--stop-time", "0.02", *args, "--logging-on", "--log-file", str(log),
                        "--output-file", str(out), str(differential_fmu)],
                       cwd=tmp_path, env={"PATH": "/usr/bin:/bin"}, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    assert "contact: compiled implementation" in log.read_text()
    ref = simulate_fmu(str(differential_fmu), stop_time=0.02, output_interval=1e-3,
                       start_values={**start, "solver.kernel": "python"})
    rows = np.genfromtxt(out, delimiter=",", names=True)
    for name in ("carrier.tauDrive", "mesh.F_A1", "left.w"):
        col = name.replace(".", "")   # genfromtxt drops the dots from the column names
        got = rows[col][-len(ref):] if col in rows.dtype.names else None
        assert got is not None, rows.dtype.names
        assert np.allclose(got, ref[name], rtol=1e-12, atol=1e-9), name


def test_the_kernel_bench_measures_both_implementations():
    """The lines of `spurdiff bench` section 6 come from real runs (values printed, never asserted
    against targets) and from the stored solve_ivp points of `spurdiff accuracy`."""
    from harness.measure.bench.mesh import solver_ratios, step_costs
    from harness.measure.bench.mesh_ivp import OURS

    c = step_costs(repeats=1)
    assert all(c[k]["internal"] > 0 and c[k]["comm"] > 0 for k in ("python", "compiled"))
    assert 0 < c["compiled"]["in_kernel"] and 1.0 <= c["compiled"]["steps_per_comm"] < 2.0
    rows = solver_ratios()
    assert {r["ours"] for r in rows} == set(OURS.values())
    assert all(r["best"] >= r["worst"] > 0 for r in rows) and {r["against"] for r in rows} == {"any", "restarted"}
    # the stored points give the ratios (each ratio: its solve_ivp front's wall over ours, at our error)
    one_call = {r["ours"]: r for r in rows if r["against"] == "any"}
    assert one_call[OURS["rodas5p one call"]]["worst"] > one_call[OURS["ros34pw2 one call"]]["worst"]
