"""SpurDifferential.fmu alone in fmpy, for either interface (docs/use-the-fmu.md).

The load case: a steady left turn of the main job (R = 20 m at 10 m/s): the wheel ends of the two
half-shafts turn at the rear wheels' speeds (inner 29.5455 rad/s, outer 31.8866 rad/s), the
carrier is driven by 152.4 N m (carrierDrive = torque). The differential slips at its locking
capacity, so the shaft torques settle at T0 (1 + K) / 2 and T0 (1 - K) / 2 (K, the locking
coefficient, is the FMU's calculated parameter lockingCoefficient).

  --interface wheel   shaftCoupling = wheel: the FMU owns the half-shafts. Drive leftWheel.phi,
                      leftWheel.w, rightWheel.phi, rightWheel.w (the wheel ends' angle and speed:
                      the angle must advance with the speed) and carrier.tau; read
                      leftShaft.tau / rightShaft.tau. Any step up to 20 ms; fmpy's simulate_fmu
                      with an input table does it (default step 5 ms).
  --interface torque  shaftCoupling = torque (the default): your host owns the half-shafts. Read
                      left.phi, left.w (and right), compute the shaft torque, set left.tau /
                      right.tau (a load is negative) every step. The suns' 1,530 rad/s mode then
                      runs through the coupling: a step of at most about 0.45 ms (default 0.2 ms),
                      so this is a do-step loop on fmpy's FMU2Slave.

fmpy warns "missing input" for every input variable absent from an input table, needed or not;
``input_table`` fills the inputs you do not drive with their start values.

Run:  python fmpy_differential.py [--interface wheel|torque] [--fmu PATH] [--stop T] [--step H]
(PATH: ``spurdiff fmu SpurDifferential`` prints it.) Needs fmpy and numpy only.
"""
from __future__ import annotations

import argparse
import shutil
import subprocess
import sys

import numpy as np

W_INNER, W_OUTER = 29.5455, 31.8866   # rad/s, wheel ends of the left (inner) and right half-shafts
DRIVE_TORQUE = 152.4                  # N m on the carrier
SHAFT_C, SHAFT_D = 8000.0, 10.0       # N m/rad, N m s/rad: the half-shafts (the FMU's leftShaft.c/d defaults)
OUTPUTS = ["leftShaft.tau", "rightShaft.tau", "lockingTorque", "lockingCapacity", "carrier.w", "left.w",
           "right.w", "stuck"]


def start_values(interface: str) -> dict:
    """Parameters for the load case: the carrier torque-driven, starting at the mean wheel speed, the
    suns at the wheel speeds (kinematics: w_left + w_right = 2 w_carrier)."""
    wc = 0.5 * (W_INNER + W_OUTER)
    return {"carrierDrive": "torque", "shaftCoupling": interface, "carrier.w_start": wc,
            "differential.w_start": W_INNER - wc, "carrier.tau": DRIVE_TORQUE}


def input_table(model_description, time: np.ndarray, driven: dict, starts: dict) -> np.ndarray:
    """fmpy's input table: the driven inputs (name -> array over ``time``) and every other input at
    its start value (``starts`` first, else the model description's), so fmpy warns about none."""
    inputs = [v for v in model_description.modelVariables if v.causality == "input"]
    table = np.zeros(len(time), dtype=[("time", np.float64)] + [(v.name, np.float64) for v in inputs])
    table["time"] = time
    for v in inputs:
        table[v.name] = driven[v.name] if v.name in driven else float(starts.get(v.name, v.start))
    return table


def run_wheel(fmu: str, stop: float, step: float) -> dict:
    from fmpy import read_model_description, simulate_fmu
    md = read_model_description(fmu)
    t = np.arange(0.0, stop + 0.5 * step, step)
    starts = start_values("wheel")
    driven = {"leftWheel.phi": W_INNER * t, "leftWheel.w": np.full_like(t, W_INNER),
              "rightWheel.phi": W_OUTER * t, "rightWheel.w": np.full_like(t, W_OUTER)}
    r = simulate_fmu(fmu, start_values=starts, input=input_table(md, t, driven, starts), step_size=step,
                     output_interval=step, stop_time=stop, output=OUTPUTS)
    return {n: np.asarray(r[n], dtype=float) for n in ("time", *OUTPUTS)}


def run_torque(fmu: str, stop: float, step: float) -> dict:
    from fmpy import extract, read_model_description
    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu_dir = extract(fmu)   # a new temporary folder, removed after the run
    try:
        return _run_torque(md, vr, fmu_dir, stop, step)
    finally:
        shutil.rmtree(fmu_dir, ignore_errors=True)


def _run_torque(md, vr: dict, fmu_dir: str, stop: float, step: float) -> dict:
    from fmpy.fmi2 import FMU2Slave
    s = FMU2Slave(guid=md.guid, unzipDirectory=fmu_dir, modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="diff")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    for name, value in start_values("torque").items():
        (s.setString if isinstance(value, str) else s.setReal)([vr[name]], [value])

    sun = [vr[n] for n in ("left.phi", "left.w", "right.phi", "right.w")]
    flange = [vr["left.tau"], vr["right.tau"]]

    def shaft_torques(t: float) -> list[float]:
        # the host's half-shafts: sun flange to wheel end, the wheel end turning at its speed;
        # the torque on the sun flange is minus the shaft torque (Modelica sign: a load is negative)
        pL, wL, pR, wR = s.getReal(sun)
        return [-(SHAFT_C * (pL - W_INNER * t) + SHAFT_D * (wL - W_INNER)),
                -(SHAFT_C * (pR - W_OUTER * t) + SHAFT_D * (wR - W_OUTER))]

    s.setReal(flange, shaft_torques(0.0))
    s.exitInitializationMode()
    out_vr = [vr[n] for n in OUTPUTS]
    n = int(round(stop / step))
    rows = [[0.0, *s.getReal(out_vr)]]
    from fmpy.fmi1 import FMICallException
    for k in range(n):
        t = k * step
        s.setReal(flange, shaft_torques(t))   # inputs at the communication point, held over the step
        try:
            s.doStep(currentCommunicationPoint=t, communicationStepSize=step)
        except FMICallException as e:         # fmi2Discard: the FMU logged why; the state is kept at t
            raise SystemExit(f"fmi2DoStep refused the step at t = {t:.6g} s ({e}): with shaftCoupling = torque "
                             "the suns' shaft mode runs through the coupling; use a smaller --step") from None
        rows.append([(k + 1) * step, *s.getReal(out_vr)])
    s.terminate()
    s.freeInstance()
    data = np.array(rows)
    result = {"time": data[:, 0]}
    result.update({name: data[:, i + 1] for i, name in enumerate(OUTPUTS)})
    # the flange torques the FMU got are its inputs; the shaft torques on the wheels are their negatives
    return result


def summary(result: dict, since: float) -> dict:
    """Means over t >= since of the quantities a reader checks."""
    m = result["time"] >= since - 1e-12
    return {n: float(np.mean(result[n][m])) for n in OUTPUTS}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--interface", choices=("wheel", "torque"), default="wheel")
    ap.add_argument("--fmu", help="SpurDifferential.fmu (default: the path `spurdiff fmu SpurDifferential` prints)")
    ap.add_argument("--stop", type=float, default=0.5, help="stop time, s (default 0.5)")
    ap.add_argument("--step", type=float, help="communication step, s (default 5e-3 wheel, 2e-4 torque)")
    ap.add_argument("--csv", help="write the time series to this CSV file")
    args = ap.parse_args(argv)
    fmu = args.fmu or subprocess.run(["spurdiff", "fmu", "SpurDifferential"], check=True, capture_output=True,
                                     text=True).stdout.strip()
    step = args.step or (5e-3 if args.interface == "wheel" else 2e-4)
    result = (run_wheel if args.interface == "wheel" else run_torque)(fmu, args.stop, step)
    if args.csv:
        names = ["time", *OUTPUTS]
        np.savetxt(args.csv, np.column_stack([result[n] for n in names]), delimiter=",", header=",".join(names),
                   comments="")
    s = summary(result, since=0.6 * args.stop)
    print(f"shaftCoupling = {args.interface}, step {step:g} s, means over {0.6 * args.stop:g} to {args.stop:g} s:")
    print(f"  inner (left) shaft torque  {s['leftShaft.tau']:.4f} N m")
    print(f"  outer (right) shaft torque {s['rightShaft.tau']:.4f} N m")
    print(f"  locking torque             {s['lockingTorque']:.4f} N m (capacity {s['lockingCapacity']:.4f})")
    print(f"  carrier speed              {s['carrier.w']:.4f} rad/s; suns {s['left.w']:.4f} / {s['right.w']:.4f}")
    print(f"  stuck                      {s['stuck']:.3g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
