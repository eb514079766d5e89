"""The load-capacity block of SpurDifferential (spurdiff.fmi.differential_fmu): safety factors as
calculated parameters equal to spurdiff.gears.capacity's report, the run's largest stresses as
outputs, one logged warning when a run exceeds the static strength, carried by the FMU state; the
rating's findings at initialization are logged once as information (fmi2OK), not as a warning."""
import pytest

from spurdiff.fmi import differential_fmu as D
from spurdiff.fmi.adapter import fmu_class
from spurdiff.gears import capacity as cap
from spurdiff.gears.design_sets import fmu_parameters

H = 1e-3


class _Logged(fmu_class(D)):
    def __init__(self, **kw):
        super().__init__(**kw)
        self.logged = []

    def log(self, msg, status=0, category=None, debug=None):
        self.logged.append((int(status), msg))


# the paper's set under its straight-line load, no start slip (the default experiment before issue 46): a
# set the rating finds overloaded at 2100 N m, which these tests of the rating's mechanics need
PAPER_CASE = {**fmu_parameters("paper"), "differential.w_start": 0.0, "left.tau": -1050.0, "right.tau": -1050.0}


def _fmu(**values):
    f = _Logged(instance_name="cap", resources=".", logging_on=True)
    f.values.update({**PAPER_CASE, **values})
    f.fmi2_setup_experiment(False, 0.0, 0.0, False, 0.0)
    f.fmi2_enter_initialization_mode()
    return f, f.fmi2_exit_initialization_mode()


def _steps(f, n, t=0.0):
    for _ in range(n):
        assert f.fmi2_do_step(t, H) == 0
        t += H
    return t


def test_safety_factors_are_the_reports():
    f, status = _fmu(**{"capacity.T0": 1000.0})
    assert status == 0
    geo = f.model.geometry
    bores = {"planet1": 2 * f.values["r_collar"], "planet2": 2 * f.values["r_collar"]}
    from spurdiff.differential.watches import rating_forces
    p = f.model.params
    # the locked split at break-away, K_gamma of 3 pairs, K_v at the start's pitch-line speed (0 here)
    rep = cap.capacity_report(geo, rating_forces(geo, p.mu_pin, p.r_collar, 1000.0, p.lockingLaw, p.pinModel, p.pairHandedness, p.pinContactFactor), bores=bores,
                              v=cap.pitch_line_speed(geo, f.model.wd))
    assert rep.meshes[0].K_gamma == 1.1 and rep.meshes[0].F_n > cap.nominal_mesh_forces(geo, 1000.0)["A1"]
    for r in rep.meshes:
        for g in r.gears:
            assert f.values[f"capacity.mesh{r.mesh}.{g.gear}.S_H"] == g.S_H
            assert f.values[f"capacity.mesh{r.mesh}.{g.gear}.S_F"] == g.S_F
    assert f.values["capacity.S_H_static"] == rep.S_H_static
    assert [s for s, m in f.logged if "load capacity at capacity.T0 = 1000 N m" in m] == [0]


def test_the_bushing_wall_sets_the_planets_bore_as_spurdiff_info_does():
    """capacity.bushingWall: the planets' bore is 2 (r_collar + wall), as harness.measure.info rates the
    bronze pin set; a thicker wall leaves a thinner rim, so the planets' root safety falls."""
    from spurdiff.differential.bushing import bushing
    b = bushing("bronze")
    f, status = _fmu(**{"r_collar": b.journalRadius, "capacity.bushingWall": b.bushingWall})
    assert status == 0
    geo = f.model.geometry
    bore = 2.0 * (b.journalRadius + b.bushingWall)
    from spurdiff.differential.watches import rating_forces
    p = f.model.params
    rep = cap.capacity_report(geo, rating_forces(geo, p.mu_pin, p.r_collar, f.values["capacity.T0"], p.lockingLaw, p.pinModel, p.pairHandedness, p.pinContactFactor),
                              bores={"planet1": bore, "planet2": bore}, v=0.0)
    for r in rep.meshes:
        for g in r.gears:
            assert f.values[f"capacity.mesh{r.mesh}.{g.gear}.S_F"] == g.S_F
    thin, _ = _fmu(**{"r_collar": b.journalRadius, "capacity.bushingWall": 4.0 * b.bushingWall})
    assert thin.values["capacity.meshB2.planet2.S_F"] < f.values["capacity.meshB2.planet2.S_F"]
    assert thin.values["capacity.meshB2.sunB.S_F"] == f.values["capacity.meshB2.sunB.S_F"]


def test_largest_stress_output_and_one_warning_when_the_limit_is_exceeded():
    # a light load (100 N m per sun): below the static strength
    f, _ = _fmu(**{"left.tau": -100.0, "right.tau": -100.0})
    f.logged.clear()
    t = _steps(f, 20)
    w = f.model.capacity_watch
    F = f.values["mesh.F_A1"]
    assert f.values["capacity.sigmaHMax"] == w.sigma_H_max > 0.0
    assert f.values["capacity.exceeded"] == 0.0 and f.logged == []
    from spurdiff.differential.watches import rating_forces
    p = f.model.params
    ref = cap.StressWatch(f.model.geometry, rating_forces(f.model.geometry, p.mu_pin, p.r_collar, 2100.0, p.lockingLaw, p.pinModel,
                                        p.pairHandedness, p.pinContactFactor),
                          cond=w.cond, bores=w.bores, v=w.v)
    ref.update(F, f.values["mesh.F_B2"], f.values["mesh.F_12"])
    assert w.sigma_H_max == pytest.approx(ref.sigma_H_max, rel=1e-12)
    saved = f.fmi2_get_state()
    light = f.values["capacity.sigmaHMax"]
    # ten times the paper's load: over the limit, logged once as a warning
    f.values["left.tau"] = f.values["right.tau"] = -10500.0
    f._inputs_ok = False
    t2 = _steps(f, 20, t)
    assert f.values["capacity.exceeded"] == 1.0
    warnings = [m for s, m in f.logged if s == 1 and "exceed the static strength" in m]
    assert len(warnings) == 1
    assert f.values["capacity.sigmaHMax"] > w.sigma_HG_static
    assert f.values["capacity.sigmaHMax"] == pytest.approx(light * (10500 / 100) ** 0.5, rel=1e-9)   # sqrt(load)
    # the FMU state carries the watch: back to the light run, not exceeded
    assert f.fmi2_set_state(saved) == 0
    assert f.model.capacity_watch.exceeded is False
    back = f.fmi2_deserialize_state(f.fmi2_serialize_state(f.fmi2_get_state()))
    assert f.fmi2_set_state(back) == 0 and f.model.capacity_watch.sigma_H_max == pytest.approx(ref.sigma_H_max)
    assert t2 > t


@pytest.mark.parametrize("name,value,needle", [
    ("capacity.material", "unobtainium", "capacity.material"),
    ("capacity.T0", 0.0, "capacity.T0"),
    ("capacity.bushingWall", -1e-3, "capacity.bushingWall"),
    ("capacity.bushingWall", float("nan"), "capacity.bushingWall"),
    ("capacity.K_gamma", 0.5, "capacity.K_gamma"),
    ("capacity.K_gamma", float("inf"), "capacity.K_gamma"),
])
def test_bad_capacity_parameters_fail_initialization_naming_them(name, value, needle):
    f, status = _fmu(**{name: value})
    assert status == 3
    assert any(needle in m for s, m in f.logged if s == 3)


def test_through_the_built_fmu_the_warning_reaches_the_hosts_logger_once(differential_fmu):
    """The built FMU (our C bridge, fmpy): the findings' line at initialization as information and one
    fmi2Warning message when the paper's set under the paper's straight-line load (2100 N m, the default
    experiment before issue 46) exceeds the static contact strength."""
    from harness.fmi.instance import Instance

    inst = Instance("capacity", differential_fmu)
    inst.slave.setupExperiment(startTime=0.0)
    inst.set_values(PAPER_CASE)
    inst.slave.enterInitializationMode()
    inst.slave.exitInitializationMode()
    t = 0.0
    for _ in range(5):
        inst.do_step(t, H)
        t += H
    warnings = [m for s, m in inst.messages if s == 1]
    assert [s for s, m in inst.messages if "load capacity at capacity.T0 = 2100 N m" in m] == [0]
    assert sum("exceed the static strength" in m for m in warnings) == 1
    (sH,), (ex,) = inst.read([inst.var("capacity.sigmaHMax")], "x"), inst.read([inst.var("capacity.exceeded")], "x")
    assert ex == 1.0 and sH > 2.2e9
    inst.close()


def test_the_fmu_rates_at_its_start_speed_with_k_gamma_and_the_duty_cycle():
    """K_v at the pitch-line speed of the start state (sun A 5 rad/s behind the carrier: m z_A 5 / 2
    = 0.27 m/s), K_gamma from capacity.K_gamma (0: 1.10 for 3 pairs), the limited life computed and
    named in the start message."""
    f, status = _fmu(**{"differential.w_start": -5.0, "capacity.K_gamma": 1.25})
    assert status == 0
    w = f.model.capacity_watch
    assert w.v == pytest.approx(0.003 * 36 * 5.0 / 2, rel=1e-12)
    r = w.report.meshes[0]
    assert r.K_gamma == 1.25 and r.v == w.v and r.K_v > 1.0
    assert r.K_v == pytest.approx(cap.dynamic_factor(6, 1.0, 1.25 * r.F_t, r.b * 1e3, 13, 36 / 13, w.v), rel=1e-12)
    assert w.life.entries and min(e.S for e in w.life.entries) == w.life.S
    g, _ = _fmu()
    assert g.model.capacity_watch.report.meshes[0].K_gamma == 1.1 and g.model.capacity_watch.v == 0.0
    assert any("limited life over the duty cycle" in m for s, m in g.logged)
