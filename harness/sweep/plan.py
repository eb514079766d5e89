"""Planning a sweep: the scene with the sweep's overrides, the FMUs built and snapshotted, and every
parameter and metric name checked against them."""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from harness.common.messages import shown
from harness.scene.schema import SceneError, parameter_value
from harness.scene.spec import refs_of
from harness.sweep.execution.fmu_files import fmu_ref
from harness.sweep.jobs import Job, Task
from harness.sweep.sampling import expand
from harness.sweep.spec import Sweep, SweepError
from harness.sweep.theory import THEORIES

@dataclass
class Plan:
    sweep: Sweep
    job: Job
    tasks: list[Task]
    fmu_files: dict[str, Path]


def plan_sweep(sweep: Sweep, duration: float | None = None, timeout: float | None = None,
               build: bool = True, max_steps: int | None = None) -> Plan:
    """Load the scene with the sweep's overrides, build the FMUs, check every name against them.
    A run of more than ``max_steps`` communication steps (default :data:`harness.scene.recording.MAX_STEPS`)
    is refused with its estimate."""
    from harness.scene.recording import MAX_STEPS
    from fmpy import read_model_description

    from harness.run.runner import fmu_files_for, prepare_scene

    where = sweep.source.name if sweep.source else sweep.name
    ov = dict(sweep.overrides)
    if duration is not None:
        ov["duration"] = duration
    scene = prepare_scene(sweep.scene, mesh=ov.get("mesh"), step=ov.get("step"), duration=ov.get("duration"),
                          algorithm=ov.get("algorithm"), max_steps=max_steps or MAX_STEPS)
    refs = {n: fmu_ref(n, p) for n, p in fmu_files_for(scene, build_missing=build).items()}
    files = {n: Path(r.path) for n, r in refs.items()}
    variables = {}
    for spec in scene.instances:
        if spec.fmu not in variables:
            md = read_model_description(str(files[spec.fmu]))
            variables[spec.fmu] = {v.name: v for v in md.modelVariables}
    insts = {i.name: i for i in scene.instances}

    def parameter(label: str, key: str) -> None:
        inst, param = key.split(".", 1)
        if inst not in insts:
            raise SweepError(f"{where}: {label} {shown(key)}: scene {scene.name} has no instance {shown(inst)}; "
                             f"allowed: {', '.join(insts)}")
        vs = variables[insts[inst].fmu]
        if param not in vs or vs[param].causality != "parameter":
            allowed = sorted(n for n, v in vs.items() if v.causality == "parameter")
            raise SweepError(f"{where}: {label} {shown(key)}: {insts[inst].fmu} has no parameter {shown(param)}; "
                             f"allowed: {', '.join(allowed)}")
        return vs[param].type

    def typed(label: str, type_: str, value):
        try:
            return parameter_value(f"{where}: {label}", type_, value)
        except SceneError as e:
            raise SweepError(str(e)) from None

    for key, value in sweep.fixed.items():
        t = parameter("fixed", key)
        inst, param = key.split(".", 1)
        scene.instance(inst).parameters[param] = typed(f"fixed.{key}", t, value)
    params = []
    for p in sweep.params:
        t = parameter("parameters", p.name)
        if p.values is not None:
            p = replace(p, values=[typed(f"parameters {shown(p.name)}.values", t, v) for v in p.values])
        elif t in ("Boolean", "String") or (t in ("Integer", "Enumeration") and not p.integer):
            raise SweepError(f"{where}: parameters {shown(p.name)}: range = {list(p.range)} for a {t} parameter; allowed: "
                             + ("values = [...]" if t in ("Boolean", "String") else "integer = true with the range"))
        else:
            for x in p.range:
                typed(f"parameters {shown(p.name)}.range", t, int(round(x)) if p.integer else x)
        params.append(p)
    sweep = replace(sweep, params=params)
    metrics = []
    for m in sweep.metrics:
        if m.kind == "stat":
            for ref in refs_of(m.var):
                inst, _, var = ref.partition(".")
                if inst not in insts or var not in variables[insts[inst].fmu]:
                    raise SweepError(f"{where}: metrics {shown(m.name)}: {shown(ref)} is not a variable of the scene; "
                                     f"allowed: 'instance.variable' with instance one of {', '.join(insts)}")
                if variables[insts[inst].fmu][var].type not in ("Real", "Integer", "Boolean", "Enumeration"):
                    raise SweepError(f"{where}: metrics {shown(m.name)}: {shown(ref)} is a {variables[insts[inst].fmu][var].type}; "
                                     "allowed: numeric variables (Real, Integer, Boolean, Enumeration)")
                if ref not in scene.record:
                    scene.record.append(ref)
            if m.window and m.window[1] > scene.duration * (1 + 1e-9):
                raise SweepError(f"{where}: metrics {shown(m.name)}: window {list(m.window)} ends after the scene's "
                                 f"duration {scene.duration:g} s")
        elif m.kind == "theory":
            fmu = THEORIES[m.theory][1]
            fits = [i for i in scene.instances if i.fmu == fmu]
            if m.instance:
                if m.instance not in insts or insts[m.instance].fmu != fmu:
                    raise SweepError(f"{where}: metrics {shown(m.name)}: instance = {shown(m.instance)}; allowed: "
                                     f"{', '.join(i.name for i in fits) or 'none (no ' + fmu + ' in the scene)'}")
            elif len(fits) != 1:
                raise SweepError(f"{where}: metrics {shown(m.name)}: give instance = one of "
                                 f"{', '.join(i.name for i in fits) or 'none (no ' + fmu + ' in the scene)'}")
            else:
                m = replace(m, instance=fits[0].name)
        metrics.append(m)
    job = Job(scene=scene, fmus=refs, metrics=metrics,
              timeout=timeout if timeout is not None else sweep.timeout)
    return Plan(sweep, job, expand(sweep), files)
