"""The master's fixed-step Gauss-Seidel loop (Master._gauss_seidel, its lookups made once) does what
its generic step (Master._communication_step, _add_work, the recording reads and _sample, which
the variable-step master uses) does, bit for bit; a refusal in the middle of a run ends it with the
steps done and the rows recorded so far."""
from __future__ import annotations

import numpy as np

from harness.run.master import Master, run_scene
from harness.run.runner import fmu_files_for, prepare_scene
from harness.scene.spec import parse_scene


class GenericLoop(Master):
    """The loop as the generic methods run it (Master.run's loop before _gauss_seidel)."""

    def _gauss_seidel(self, n_steps, h, rec_every, energy, prev_power, record, done):
        for k in range(n_steps):
            self._communication_step(k * h, h, self._order, False)
            done[0] = k + 1
            prev_power = self._add_work(energy, prev_power, h)
            if (k + 1) % rec_every == 0 or k + 1 == n_steps:
                for name in self._order:
                    self._read_outputs(name, self._rec_ports)
                record(self._sample((k + 1) * h))


def test_the_fixed_step_loop_equals_the_generic_step_bit_for_bit():
    scene = prepare_scene("vehicle-cornering", duration=0.2)
    files = fmu_files_for(scene)
    fast = run_scene(scene, files)
    generic = GenericLoop(scene, files).run()
    assert fast.ok and generic.ok and fast.steps == generic.steps == 40
    assert fast.data.shape == generic.data.shape and fast.data.shape[0] == 41
    assert np.array_equal(fast.data, generic.data)
    assert fast.coupling_energy == generic.coupling_energy and set(fast.coupling_energy) == {"left half-shaft", "right half-shaft"}
    assert all(e["work_from"] != 0.0 for e in fast.coupling_energy.values())


def test_a_refusal_mid_run_keeps_the_steps_done_and_the_rows_recorded():
    """left.tau leaves its declared range at t = 5 ms: that step is refused (fmi2Discard), the run
    stops there naming the instance and the input, with 5 steps done and 6 rows (t = 0 to 5 ms)."""
    scene = parse_scene({
        "name": "mid-run-refusal", "duration": 0.01, "step": 1e-3, "output_interval": 1e-3,
        "fmus": {"diff": {"fmu": "SpurDifferential", "parameters": {"carrierDrive": "speed"}}},
        "inputs": {"diff.carrier.w_ref": 1.389, "diff.right.tau": -1050.0,
                   "diff.left.tau": {"table": [[0.0, -1050.0], [0.0049, -1050.0], [0.005, -2e6]]}},
        "record": ["diff.left.w"]})
    for cls in (Master, GenericLoop):
        r = cls(scene, fmu_files_for(scene)).run()
        assert not r.ok and r.failure.instance == "diff" and r.failure.time == 0.005
        assert "left.tau" in r.failure.reason and "outside" in r.failure.reason
        assert r.steps == 5 and r.data.shape == (6, 2)
        assert np.array_equal(r.data[:, 0], np.arange(6) * 1e-3)
