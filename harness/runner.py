"""From a scene name and command-line overrides to a runnable scene and its FMU files."""
from __future__ import annotations

import math
import tomllib
from dataclasses import replace
from pathlib import Path

from harness.build import DEFAULT_DEST, FMUS, build
from harness.scene import Scene, SceneError, load_scene


def _parse_value(text: str):
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text  # bare word: a string


def prepare_scene(name: str, mesh: str | None = None, step: float | None = None, duration: float | None = None,
                  algorithm: str | None = None, sets: list[str] | None = None) -> Scene:
    """Load a scene and apply overrides (``sets``: 'instance.parameter=value')."""
    scene = load_scene(name)
    effects = dict(scene.effects)
    if mesh:
        effects["meshModel"] = mesh
    changes = {"effects": effects}
    for label, value in (("step", step), ("duration", duration)):
        if value is not None:
            if not (value > 0 and math.isfinite(value)):
                raise SceneError(f"--{label} = {value!r}: allowed a finite number > 0")
            changes[label] = float(value)
    if algorithm:
        changes["algorithm"] = algorithm
    scene = replace(scene, **changes)
    if step is not None:
        scene = replace(scene, output_interval=max(scene.output_interval, scene.step))
    if scene.step > scene.duration:
        raise SceneError(f"step = {scene.step} s is longer than duration = {scene.duration} s")
    names = {i.name for i in scene.instances}
    for item in sets or []:
        if "=" not in item or "." not in item.split("=", 1)[0]:
            raise SceneError(f"--set {item!r}: allowed INSTANCE.PARAMETER=VALUE")
        key, value = item.split("=", 1)
        inst, param = key.split(".", 1)
        if inst not in names:
            raise SceneError(f"--set {item!r}: unknown instance {inst!r}; allowed: {', '.join(sorted(names))}")
        scene.instance(inst).parameters[param] = _parse_value(value)
    return scene


def fmu_files_for(scene: Scene, build_missing: bool = True, dest: Path = DEFAULT_DEST) -> dict[str, Path]:
    """Paths of the FMUs the scene uses, building missing or outdated ones."""
    needed = sorted({i.fmu for i in scene.instances})
    for n in needed:
        if n not in FMUS:
            raise SceneError(f"scene {scene.name}: unknown FMU {n!r}; allowed: {', '.join(sorted(FMUS))}")
    if build_missing:
        paths = build(needed, dest, quiet=True)
    else:
        paths = [Path(dest) / f"{n}.fmu" for n in needed]
    return dict(zip(needed, paths))
