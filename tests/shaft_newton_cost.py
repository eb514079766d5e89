"""Issue 19 item 3 (cost): inner-model evaluations per shaft sub-step of spurdiff.shafts (the
Newton on the sun torques), the differential with two WheelLoads in plain Python (tests/physics/test_shafts.py
Loop, the interface model connected) at 1, 5 and 20 ms, 0.8 s of each case.

    .venv/bin/python tests/shaft_newton_cost.py
"""
import sys, math, time
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parent / "physics"))   # tests/physics/test_shafts.py
from test_shafts import make, Loop, start, R_WHEEL
cases = {
 "steady 300 N m, split mu": dict(tau_c=lambda t: 300.0, mu=lambda t: (0.6, 1.0), vx=lambda t: 10.0),
 "stick-slip patch": dict(tau_c=lambda t: 300.0, mu=lambda t: (0.05 if 0.1 <= t < 0.3 else 1.0, 1.0), vx=lambda t: 10.0),
 "sine torque": dict(tau_c=lambda t: 150.0 + 100.0 * math.sin(8.0 * t), mu=lambda t: (0.8, 1.0), vx=lambda t: 10.0),
 "mu 0 one side": dict(tau_c=lambda t: 300.0, mu=lambda t: (0.0, 1.0), vx=lambda t: 5.0),
}
out = {}
for h in (1e-3, 5e-3, 2e-2):
    for name, kw in cases.items():
        diff, wheels = make(w0=10.0 / R_WHEEL)
        loop = start(Loop(diff, wheels, **kw))
        t0 = time.perf_counter()
        rows = loop.run(0.8, h)
        dt = time.perf_counter() - t0
        out[(name, h)] = rows[-1]
        print(f"{name:28s} h={h*1e3:4g} ms  evals/substep {diff.n_evals / diff.n_substeps:.3f}  jacobians/substep {diff.n_jacobians / diff.n_substeps:.3f}  substeps {diff.n_substeps}  wall {dt:.2f}s  end wL {rows[-1,6]:.12g} tauL {rows[-1,8]:.12g}")
