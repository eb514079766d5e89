"""The FMUs' declarations without FMI: each variable's binding is used and answered by the model
(spurdiff.fmi.binding), and the differential's start values are its data file's."""
from __future__ import annotations

import pytest

INTERFACES = {"SpurDifferential": "spurdiff.fmi.differential_fmu", "WheelLoad": "spurdiff.fmi.wheel_fmu",
              "Vehicle": "spurdiff.fmi.vehicle_fmu"}
# the configurations a model class depends on: the differential's shaft coupling and fidelity
CONFIGS = {"SpurDifferential": ({}, {"meshModel": "contact"}, {"shaftCoupling": "wheel"},
                                {"shaftCoupling": "wheel", "meshModel": "contact"}),
           "WheelLoad": ({},), "Vehicle": ({},)}


@pytest.mark.parametrize("name", list(INTERFACES))
def test_every_binding_is_used_and_every_output_answered(name):
    """Each input is pushed in some configuration of the model, each output read in every one
    (compiling the pull refuses an output the model does not answer), and the pulled values are
    those the model's attributes hold."""
    import importlib

    from spurdiff.fmi.binding import _has, bindings, resolve

    iface = importlib.import_module(INTERFACES[name])
    assert iface.FMU_NAME == name
    io = bindings(iface.VARIABLES)
    pushed = set()
    for config in CONFIGS[name]:
        values = {v.name: v.start for v in iface.VARIABLES}
        values.update(config)
        model = iface.build_model(values)
        push, pull = io.io(model)
        pushed |= {v.name for v in io.inputs if _has(model, v.bind)}
        pull(model, values)
        for v in io.outputs:
            x = resolve(model, v.bind)
            assert values[v.name] == (int(x) if v.kind == "Integer" else x), v.name
    assert pushed == {v.name for v in io.inputs}
    # every variable but the calculated ones computed in build_model has a binding
    unbound = {v.name for v in iface.VARIABLES if v.bind is None and v.causality != "calculatedParameter"}
    assert unbound <= {"wheel.w_startFromFlange", "tyre.k_startSteady"}, unbound


def test_the_differentials_start_values_are_its_data_file():
    """The parameters' start values are differential.toml's (keys: the FMU's names) but for the gear set,
    default_experiment.toml's (the designed set, sun B 17 mm wide, issue 46), and setting a parameter
    reaches its field in the parameter objects."""
    from spurdiff.fmi import differential_fmu as d
    from spurdiff.datafile import DIFFERENTIAL_DATA, read_data
    from spurdiff.gears.design_sets import fmu_parameters

    data = read_data(bundled=DIFFERENTIAL_DATA)
    flat = {}
    for key, value in data.items():
        if isinstance(value, dict):
            flat.update({f"{key}.{k}": v for k, v in value.items()})
        else:
            flat[key] = value
    designed = fmu_parameters("designed")
    assert fmu_parameters(d.DEFAULT_GEAR_TABLE) == {**designed, "sunB.b": 0.017}
    flat.update(designed, **{"sunB.b": 0.017})
    solver = {"solver.tolerance": "tolerance", "solver.maxInternalSteps": "maxInternalSteps",
              "solver.kernel": "solver.kernel", "solver.method": "solver.method"}
    starts = {v.name: v.start for v in d.VARIABLES}
    for key, value in flat.items():
        name = solver.get(key, key)
        if name in starts:
            assert starts[name] == value and type(starts[name]) is type(value), name
    assert sum(name in starts for name in (solver.get(k, k) for k in flat)) >= 60
    values = dict(starts, **{"sunB.x": 1.1, "meshA1.backlash": 2e-4, "rightShaft.c": 7000.0, "mu_pin": 0.2})
    s = d.setup(values)
    assert (s.diff.table.sunB.x, s.mesh.backlashA1, s.shafts.right.c, s.diff.mu_pin) == (1.1, 2e-4, 7000.0, 0.2)
    assert s.diff.table.sunA == d.Setup().diff.table.sunA   # the rest as the defaults
