"""Through SpurDifferential-fmi3.fmu (fmpy): the outputs fmi3GetOutputDerivatives answers are exactly
those the interface declares a derivative for (spurdiff.fmi.differential_fmu.output_rates: the suns'
and the carrier's speeds and angles, and with shaftCoupling = wheel the half-shafts' six more),
every other Float64 output is refused by name, and each answered derivative is the limit of central
differences of that output taken through the FMU (fmi3GetFMUState / fmi3SetFMUState, doSteps of H - d and H + d, Richardson with d and d/2; the
tolerance from d as in tests/physics/test_output_derivatives.py). Issue 47 item 4."""
from __future__ import annotations

import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave

from harness.fmi.instance import fmu_cache
from spurdiff.fmi import differential_fmu as D

EPS = 2.220446049250313e-16
RIGID = {"shaftCoupling": "torque", "carrierDrive": "torque", "carrier.tau": 200.0, "J_carrier": 2.0,
         "left.tau": -120.0, "right.tau": -60.0, "differential.w_start": 0.5, "carrier.w_start": 5.0}
WHEEL = {"shaftCoupling": "wheel", "carrierDrive": "torque", "carrier.tau": 300.0, "J_carrier": 2.0,
         "leftWheel.w": 5.0, "rightWheel.w": 5.2, "differential.w_start": 0.3, "carrier.w_start": 5.0}


@pytest.fixture(scope="module")
def diff3(fmu_files):
    from harness.build.fmu3 import build

    return build(["SpurDifferential"], quiet=True)[0]


def started(path, params: dict) -> FMU3Slave:
    unzipdir, md = fmu_cache().get(path)
    s = FMU3Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="d3")
    s.log = []
    s.md = md
    s.vr = {v.name: v.valueReference for v in md.modelVariables}
    s.instantiate(loggingOn=True, logMessage=lambda env, st, cat, msg: s.log.append((st, msg.decode())))
    s.enterInitializationMode(startTime=0.0)
    for k, v in params.items():
        (s.setString if isinstance(v, str) else s.setFloat64)([s.vr[k]], [v])
    s.exitInitializationMode()
    return s


@pytest.mark.parametrize("params, count", [(RIGID, 6), (WHEEL, 12)], ids=["rigid-torque", "shafts-wheel"])
def test_the_fmu_answers_exactly_the_declared_derivatives(diff3, params, count):
    """Six without the half-shafts (the suns' and the carrier's speeds and angles), twelve with them."""
    s = started(diff3, params)
    s.doStep(0.0, 1e-4)
    outputs = [v.name for v in s.md.modelVariables if v.causality == "output" and v.type in ("Float64", "Real")]
    answered = {}
    for n in outputs:
        try:
            answered[n] = s.getOutputDerivatives([s.vr[n]], [1])[0]
        except FMICallException:
            assert "has no derivative" in s.log[-1][1], (n, s.log[-1])
    values = {v.name: v.start for v in D.VARIABLES}
    values.update(params)
    m = D.build_model(values)
    m.do_step(0.0, 1e-4)
    rates = D.output_rates(m)
    bind = {v.name: v.bind for v in D.VARIABLES}
    want = {n for n in outputs if bind[n] in rates}
    assert set(answered) == want and len(want) == count
    assert {n: answered[n] for n in want} == {n: rates[bind[n]] for n in want}   # the model's numbers
    s.terminate()
    s.freeInstance()


def test_each_derivative_through_the_fmu_is_the_limit_of_its_central_differences(diff3):
    s = started(diff3, RIGID)
    t, H = 0.0, 1e-4
    for _ in range(5):
        s.doStep(t, H)
        t += H
    saved = s.getFMUState()
    names = ["carrier.w", "carrier.phi", "left.w", "left.phi", "right.w", "right.phi"]
    refs = [s.vr[n] for n in names]

    def end_of(h):
        s.setFMUState(saved)
        s.doStep(t, h)
        return dict(zip(names, s.getFloat64(refs)))

    end_of(H)
    rates = dict(zip(names, s.getOutputDerivatives(refs, [1] * len(refs))))
    d = H / 16.0
    ys = {k: end_of(H + k * d / 2.0) for k in (-2, -1, 1, 2)}
    for n in names:
        D1 = (ys[2][n] - ys[-2][n]) / (2.0 * d)
        D2 = (ys[1][n] - ys[-1][n]) / d
        R = (4.0 * D2 - D1) / 3.0
        tol = abs(D2 - D1) / 3.0 + 64.0 * EPS * max(abs(ys[k][n]) for k in ys) / (d / 2.0)
        assert abs(R - rates[n]) <= tol, (n, rates[n], R, tol)
        assert abs(rates[n]) <= 2.0 * tol or abs(R + rates[n]) > tol, n
    s.freeFMUState(saved)
    s.terminate()
    s.freeInstance()
