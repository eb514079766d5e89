"""One case per FMU for the host tests (constant inputs as start values; fmpy gives the reference)."""
STOP, STEP = 0.05, 1e-3
CASES = {
    "SpurDifferential": {"carrier.w_ref": 1.389, "left.tau": -1050.0, "right.tau": -1040.0},
    "WheelLoad": {"flange.w": 30.0, "Fz": 4000.0, "mu": 0.9, "vx": 10.0},
    "Vehicle": {"rearLeft.Fx": 500.0, "rearRight.Fx": 480.0, "speedTarget": 10.0, "pathRadius": 20.0},
}
