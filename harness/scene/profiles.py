"""Input profiles of a scene (``inputs = {"inst.var" = ...}``): a constant, a piecewise-linear
table of [time, value] pairs, or a step (``{time, before, after, rise}``), each a function of
time the master applies at every communication point."""
from __future__ import annotations

import math
from dataclasses import dataclass

from harness.common.messages import shown
from harness.scene.schema import SceneError, number as _number, table as _table_of, unknown as _unknown


@dataclass
class Profile:
    """An input profile: constant, piecewise-linear table, or a step."""

    kind: str
    value: float = 0.0
    times: tuple[float, ...] = ()
    values: tuple[float, ...] = ()

    def __call__(self, t: float) -> float:
        if self.kind == "constant":
            return self.value
        ts, vs = self.times, self.values
        if t <= ts[0]:
            return vs[0]
        if t >= ts[-1]:
            return vs[-1]
        for i in range(1, len(ts)):
            if t <= ts[i]:
                t0, t1 = ts[i - 1], ts[i]
                if t1 == t0:
                    return vs[i]
                return vs[i - 1] + (vs[i] - vs[i - 1]) * (t - t0) / (t1 - t0)
        return vs[-1]


def parse_profile(where: str, spec) -> Profile:
    """An input profile from a scene's ``inputs`` value; a bad one is one line naming ``where``."""
    if isinstance(spec, bool):
        raise SceneError(f"{where}: allowed a number, {{table = [[t, v], ...]}} or {{step = ...}}")
    if isinstance(spec, (int, float)):
        if not math.isfinite(float(spec)):
            raise SceneError(f"{where} = {shown(spec)}: allowed a finite number")
        return Profile("constant", float(spec))
    if isinstance(spec, dict):
        _unknown(where, spec, {"table", "step"})
        if len(spec) != 1:
            raise SceneError(f"{where}: give one of 'table' or 'step'")
        if "table" in spec:
            rows = spec["table"]
            if not isinstance(rows, list) or not all(isinstance(r, list) and len(r) == 2 for r in rows):
                raise SceneError(f"{where}.table: allowed a list of [time, value] pairs")
            ts = tuple(_number(f"{where}.table time", r[0]) for r in rows)
            vs = tuple(_number(f"{where}.table value", r[1]) for r in rows)
            if not ts or any(b < a for a, b in zip(ts, ts[1:])):
                raise SceneError(f"{where}.table: times must be finite and non-decreasing, values finite")
            return Profile("table", times=ts, values=vs)
        st = _table_of(f"{where}.step", spec["step"])
        _unknown(f"{where}.step", st, {"time", "before", "after", "rise"})
        t0 = _number(f"{where}.step.time", st.get("time", 0.0))
        rise = _number(f"{where}.step.rise", st.get("rise", 0.0), minimum=0.0)
        b = _number(f"{where}.step.before", st.get("before", 0.0))
        a = _number(f"{where}.step.after", st.get("after", 0.0))
        return Profile("table", times=(t0, t0 + rise), values=(b, a))
    raise SceneError(f"{where}: allowed a number, {{table = [[t, v], ...]}} or {{step = {{time, before, after}}}}")
