"""From a scene name and command-line overrides to a runnable scene and its FMU files."""
from __future__ import annotations

import math
import tomllib
from dataclasses import replace
from pathlib import Path

from harness.common.messages import cut, shown
from harness.scene.recording import MAX_STEPS
from harness.scene.spec import Scene, SceneError, divides, load_scene, parameter_value


def _parse_value(text: str):
    """A --set value: a TOML value (number, true/false, "string"), else the bare word as a string.
    Its FMI type decides later what it means (:func:`typed_parameters`)."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text  # bare word: a string
    except (RecursionError, ValueError) as e:   # nested too deep; an integer of more than 4300 digits
        reason = "nested too deep" if isinstance(e, RecursionError) else "a number too long to read"
        raise SceneError(f"--set value {shown(text)}: {reason}; allowed: a number, true/false or a string") from None


def prepare_scene(name: str, mesh: str | None = None, step: float | None = None, duration: float | None = None,
                  algorithm: str | None = None, sets: list[str] | None = None,
                  max_steps: int | None = MAX_STEPS) -> Scene:
    """Load a scene and apply overrides (``sets``: 'instance.parameter=value'). A run of more than
    ``max_steps`` communication steps is refused with its estimate (None: no step limit; the
    memory limit of the recording always holds)."""
    from harness.run.master import check_recording

    scene = load_scene(name)
    effects = dict(scene.effects)
    if mesh:
        effects["meshModel"] = mesh
    changes = {"effects": effects}
    for label, value in (("step", step), ("duration", duration)):
        if value is not None:
            if not (value > 0 and math.isfinite(value)):
                raise SceneError(f"--{label} = {shown(value)}: allowed a finite number > 0")
            changes[label] = float(value)
    if algorithm:
        changes["algorithm"] = algorithm
    scene = replace(scene, **changes)
    if step is not None:
        scene = replace(scene, output_interval=max(scene.output_interval, scene.step))
    if scene.step > scene.duration:
        raise SceneError(f"step = {scene.step} s is longer than duration = {scene.duration} s")
    if step is not None or duration is not None:
        divides("--step/--duration", scene.step, scene.duration)
    check_recording(scene, f"scene {scene.name}", max_steps)
    names = {i.name for i in scene.instances}
    for item in sets or []:
        if "=" not in item or "." not in item.split("=", 1)[0]:
            raise SceneError(f"--set {shown(item)}: allowed INSTANCE.PARAMETER=VALUE")
        key, value = item.split("=", 1)
        inst, param = key.split(".", 1)
        if inst not in names:
            raise SceneError(f"--set {shown(item)}: unknown instance {shown(inst)}; allowed: {', '.join(sorted(names))}")
        scene.instance(inst).parameters[param] = _parse_value(value)
    return scene


def typed_parameters(scene: Scene, fmu_files: dict[str, Path]) -> Scene:
    """Convert every parameter value of the scene (and the differential's effects) by the FMI type
    of its variable in the FMU's modelDescription: ``pinFriction = "off"`` is false, ``nPairs = true``
    and values out of the int32 range are refused. Raises a one-line SceneError naming the parameter."""
    from harness.fmi.instance import fmu_cache

    for spec in scene.instances:
        _, md = fmu_cache().get(fmu_files[spec.fmu])
        variables = {v.name: v for v in md.modelVariables}
        for prefix, params in reversed(scene.parameter_sources(spec.name)):   # own parameters first
            for name, value in list(params.items()):
                v = variables.get(name)
                if v is None:
                    allowed = sorted(n for n, x in variables.items() if x.causality == "parameter")
                    raise SceneError(f"{prefix}{cut(name)}: {spec.fmu} has no parameter {shown(name)}; allowed: "
                                     f"{', '.join(allowed)}")
                if v.causality not in ("parameter", "input"):
                    raise SceneError(f"{prefix}{cut(name)} is a {v.causality}, not a parameter")
                params[name] = parameter_value(f"{prefix}{cut(name)}", v.type, value)
    return scene


def fmu_files_for(scene: Scene, build_missing: bool = True, dest: Path | None = None,
                  fmi_version: int = 2) -> dict[str, Path]:
    """Paths of the FMUs the scene uses, building missing or outdated ones: the FMI 2.0 FMUs, or
    with ``fmi_version = 3`` the FMI 3.0 ones (``NAME-fmi3.fmu``, :mod:`harness.build.fmu3`)."""
    from harness.build import fmu3 as build3
    from harness.build.fmu import FMUS, build, fmu_path   # here: the rest of this module runs where no build can (a Windows master)

    needed = sorted({i.fmu for i in scene.instances})
    for n in needed:
        if n not in FMUS:
            raise SceneError(f"scene {scene.name}: unknown FMU {shown(n)}; allowed: {', '.join(sorted(FMUS))}")
    if fmi_version not in build3.FMI_VERSIONS:
        raise SceneError(f"FMI version {shown(fmi_version)}: allowed 2 or 3")
    if fmi_version == 3:
        paths = build3.build(needed, dest, quiet=True) if build_missing else [build3.fmu_path(n, dest) for n in needed]
    elif build_missing:
        paths = build(needed, dest, quiet=True)
    else:
        paths = [fmu_path(n, dest) for n in needed]
    return dict(zip(needed, paths))


def explain_failure(scene: Scene, failure) -> str:
    """A run failure in one line; a failure at initialization also names the parameters given to
    that instance (the FMU's own reason, e.g. 'math domain error', may not name the culprit)."""
    text = str(failure)
    spec = next((i for i in scene.instances if i.name == getattr(failure, "instance", None)), None)
    if spec is None or getattr(failure, "time", 1.0) != 0.0 or not spec.parameters:
        return text
    given = [f"{k} = {shown(v)}" for k, v in spec.parameters.items() if k not in text]
    if len(given) < len(spec.parameters):   # the reason names a parameter already
        return text
    more = f", ... ({len(given)} in all)" if len(given) > 8 else ""
    return f"{text} (parameters given to {spec.name}: {', '.join(given[:8])}{more})"
