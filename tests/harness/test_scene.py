"""Scene methods the master, the SSP export, the direct runner and the sweeps share: the parameters
an instance gets, and the wiring checked against the FMUs' variables (one check for every host)."""
from __future__ import annotations

from types import SimpleNamespace as V

import pytest

from harness.scene.spec import SceneError, parse_scene

DATA = {"name": "t", "duration": 0.01, "step": 1e-3,
        "effects": {"meshModel": "compliant", "backlash": True},
        "fmus": {"diff": {"fmu": "SpurDifferential", "parameters": {"backlash": False, "mu_pin": 0.2}},
                 "wheel": {"fmu": "WheelLoad", "parameters": {"mu": 0.9}}},
        "inputs": {"diff.carrier.tau": 10.0},
        "connections": {"wheel.flange.phi": "diff.left.phi"},
        "record": ["diff.lockingTorque"]}


def variables(changes=None):
    out = {"diff": {"carrier.tau": V(causality="input", type="Real", unit="N.m"),
                    "left.phi": V(causality="output", type="Real", unit="rad"),
                    "lockingTorque": V(causality="output", type="Real", unit="N.m"),
                    "meshModel": V(causality="parameter", type="String", unit=None),
                    "backlash": V(causality="parameter", type="Boolean", unit=None),
                    "mu_pin": V(causality="parameter", type="Real", unit="1")},
           "wheel": {"flange.phi": V(causality="input", type="Real", unit="rad"),
                     "mu": V(causality="parameter", type="Real", unit="1")}}
    for ref, var in (changes or {}).items():
        inst, name = ref.split(".", 1)
        out[inst][name] = var
    return out


def test_the_differential_gets_the_effects_under_its_own_parameters_and_no_other_instance_does():
    sc = parse_scene(DATA)
    assert sc.parameters_of("diff") == {"meshModel": "compliant", "backlash": False, "mu_pin": 0.2}
    assert sc.parameters_of("wheel") == {"mu": 0.9}
    assert [p for p, _ in sc.parameter_sources("diff")] == ["effects.", "diff."]


def test_the_wiring_of_a_good_scene_gives_its_connections():
    links = parse_scene(DATA).check_wiring(variables())
    assert [(ti, tv.unit, fi, fv.causality) for ti, tv, fi, fv in links] == [("wheel", "rad", "diff", "output")]


@pytest.mark.parametrize("change, words", [
    ({"wheel.flange.phi": V(causality="input", type="Real", unit="m")}, "units differ"),
    ({"wheel.flange.phi": V(causality="output", type="Real", unit="rad")}, "is a output, not an input"),
    ({"diff.left.phi": V(causality="input", type="Real", unit="rad")}, "is a input, not an output"),
    ({"diff.left.phi": V(causality="output", type="Integer", unit="rad")}, "only Real variables can be connected"),
    ({"diff.carrier.tau": V(causality="parameter", type="Real", unit="N.m")}, "not an input (parameters go in"),
    ({"diff.lockingTorque": V(causality="output", type="String", unit=None)}, "only numeric variables"),
    ({"diff.mu_pin": V(causality="output", type="Real", unit="1")}, "diff.mu_pin is a output, not a parameter"),
])
def test_wiring_faults_are_one_line_naming_the_variable(change, words):
    with pytest.raises(SceneError) as e:
        parse_scene(DATA).check_wiring(variables(change))
    assert words in str(e.value) and "\n" not in str(e.value)


def test_a_missing_variable_is_named_with_its_instance():
    v = variables()
    del v["diff"]["lockingTorque"]
    with pytest.raises(SceneError, match="diff: FMU has no variable 'lockingTorque'"):
        parse_scene(DATA).check_wiring(v)


def _with_diff(**spec):
    data = {**DATA, "fmus": {**DATA["fmus"], "diff": {**DATA["fmus"]["diff"], **spec}}}
    return data


def test_a_named_gear_set_gives_its_parameters_between_the_effects_and_the_instance_own():
    """``gearSet = "designed"`` in [fmus.diff] sets the designed set's geometry (fmu_parameters),
    the instance's own parameters still win; no gearSet, no gear parameters."""
    from spurdiff.gears.design_sets import fmu_parameters

    designed = fmu_parameters("designed")
    assert designed["planet2.x"] != fmu_parameters("paper")["planet2.x"]
    sc = parse_scene(_with_diff(gearSet="designed", parameters={"mu_pin": 0.2, "sunA.b": 0.02}))
    got = sc.parameters_of("diff")
    assert got == {"meshModel": "compliant", "backlash": True, **designed, "mu_pin": 0.2, "sunA.b": 0.02}
    assert [p for p, _ in sc.parameter_sources("diff")] == ["effects.", "diff.gearSet = designed: ", "diff."]
    assert sc.instance("diff").gear_set == "designed"
    assert "sunA.x" not in parse_scene(DATA).parameters_of("diff")


@pytest.mark.parametrize("where, value, words", [
    ("diff", "bronze", "gearSet = 'bronze'; allowed: paper | designed"),
    ("diff", 3, "allowed a string"),
    ("wheel", "designed", "only a SpurDifferential instance has a gear set"),
])
def test_a_bad_gear_set_is_one_line_naming_it(where, value, words):
    data = {**DATA, "fmus": {**DATA["fmus"], where: {**DATA["fmus"][where], "gearSet": value}}}
    with pytest.raises(SceneError) as e:
        parse_scene(data)
    assert words in str(e.value) and f"fmus.{where}.gearSet" in str(e.value) and "\n" not in str(e.value)


def test_the_vehicle_scenes_run_the_designed_gear_set_and_the_paper_scenes_the_paper_set():
    """Issue 27: the designed set is the data set the vehicle scenes use; the paper scenes keep the
    paper's, named (issue 46: the FMU's default experiment runs another set), with its whole table."""
    from harness.scene.spec import available, load_scene
    from spurdiff.gears.design_sets import fmu_parameters

    for name in available():
        sc = load_scene(name)
        want = "paper" if name.startswith("paper-") else "designed"
        assert sc.instance("diff").gear_set == want, name
        assert sc.instance("diff").gear_parameters == fmu_parameters(want), name
