"""Theory values a scene compares with, computed from the parameters the run actually uses (issue 41
item 6): ``{theory.INST.NAME}`` in a table's ``theory``, a check's ``var`` or ``expect_var``.

``INST`` is a SpurDifferential instance of the scene; its parameters are the FMU's start values
overridden as the run overrides them (the scene's effects, its gear set, its own parameters and
any ``--set``), so ``spurdiff run vehicle-cornering --set diff.mu_pin=0.3`` compares with the K of
mu = 0.3. The theory is the quasi-static break-away of the locking law
(:func:`spurdiff.differential.speed_law.breakaway_at_speed`: the pin law the parameters select,
the planets' centrifugal pin loads at the recorded carrier speed when ``pinSpeedLoads`` is on),
evaluated at every recorded sample at the operating point the run recorded: the carrier speed
``INST.carrier.w``, the sun torque sum ``INST.left.tauMesh + INST.right.tauMesh`` (T0) and the
direction of ``INST.left.w - INST.carrier.w`` (sun A ahead or behind; stuck, the direction the sun
torque difference pushes, the more loaded sun falling behind). NAME:

* ``K``, ``K_sliding``: ``|T_A - T_B| / |T0|`` at break-away with the static lever (``mu_pin``)
  or the sliding one (``mu_pinDynamic``, or ``mu_pin`` where that is 0: the slipping differential);
* ``lockingTorque``, ``lockingTorqueSliding``: ``|T_A - T_B|`` there (N m; defined at T0 = 0 too).

With ``lockingLaw = paper`` every one is the paper's K (times |T0|, plus the preload). The
recorded variables these need are added to the scene's recording.
"""
from __future__ import annotations

import math
import numpy as np

from harness.scene.schema import SceneError

PREFIX = "theory."
NAMES = ("K", "K_sliding", "lockingTorque", "lockingTorqueSliding")
DIFF_FMU = "SpurDifferential"


def parse(where: str, ref: str, instances: dict[str, str] | set[str]) -> tuple[str, str]:
    """(instance, name) of ``theory.INST.NAME``; a SceneError names what does not fit."""
    parts = ref.split(".")
    if len(parts) != 3 or parts[0] != "theory":
        raise SceneError(f"{where}: {ref!r} is not of the form 'theory.INSTANCE.NAME'")
    _, inst, name = parts
    if inst not in instances:
        raise SceneError(f"{where}: {ref!r} names unknown FMU instance {inst!r}; allowed: {', '.join(sorted(instances))}")
    if isinstance(instances, dict) and instances[inst] != DIFF_FMU:
        raise SceneError(f"{where}: {ref!r}: only a {DIFF_FMU} instance has a locking theory")
    if name not in NAMES:
        raise SceneError(f"{where}: {ref!r}: unknown theory value {name!r}; allowed: {', '.join(NAMES)}")
    return inst, name


def needed(inst: str) -> list[str]:
    """The recorded variables the theory of instance ``inst`` reads."""
    return [f"{inst}.carrier.w", f"{inst}.left.w", f"{inst}.left.tauMesh", f"{inst}.right.tauMesh"]


def diff_params(scene, inst: str):
    """The DifferentialParams instance ``inst`` runs with: the FMU's start values, then the scene's
    parameter sources (effects, gear set, own parameters with any --set)."""
    from spurdiff.fmi.differential_fmu import VARIABLES, differential_params

    values = {v.name: v.start for v in VARIABLES if v.causality == "parameter" and v.start is not None}
    values.update(scene.parameters_of(inst))
    return differential_params(values)


_LAWS: dict[str, dict] = {}    # repr(parameters) -> the break-away functions (a run asks several times)


def _law(p):
    """The break-away functions (static, sliding lever) of one parameter set."""
    from spurdiff.differential.inertia import mass_properties
    from spurdiff.differential.locking import paper_locking_coefficient, pin_friction
    from spurdiff.differential.speed_law import breakaway_at_speed

    key = repr(p)
    if key in _LAWS:
        return _LAWS[key]
    geo = p.validate()
    mp = mass_properties(p, geo)
    masses = (mp.m_planet1, mp.m_planet2) if p.pinSpeedLoads else (0.0, 0.0)
    out = {}
    for sliding in (False, True):
        mu = p.mu_sliding if sliding else p.mu_pin
        if p.lockingLaw == "paper":
            K = paper_locking_coefficient(mu, p.r_collar, geo.table.nPairs, geo.r_a, geo.r_1, geo.r_b, geo.r_2)
            out[sliding] = (lambda wc, T0, s, K=K: (K * abs(T0) + p.lockingPreload, K))
            continue
        pf = pin_friction(geo, mu, p.r_collar, p.lockingPreload, "pinFriction", p.pinModel, p.pairHandedness,
                          p.pinContactFactor)

        def at(wc, T0, s, pf=pf):
            b = breakaway_at_speed(pf, geo, masses, wc, T0, s)
            return b.locking_torque, b.K
        out[sliding] = at
    if len(_LAWS) > 16:
        _LAWS.clear()
    _LAWS[key] = out
    return out


def series(result, ref: str) -> np.ndarray:
    """The theory value ``theory.INST.NAME`` at every recorded sample of ``result``."""
    inst, name = parse(f"scene {result.scene.name}", ref, {i.name for i in result.scene.instances})
    try:
        law = _law(diff_params(result.scene, inst))[name in ("K_sliding", "lockingTorqueSliding")]
    except Exception as exc:   # a parameter set the FMU refuses: the run failed for that already
        raise SceneError(f"scene {result.scene.name}: {ref}: no theory for these parameters: {exc}") from None
    wc, wl = result[f"{inst}.carrier.w"], result[f"{inst}.left.w"]
    TA, TB = result[f"{inst}.left.tauMesh"], result[f"{inst}.right.tauMesh"]
    T0 = TA + TB
    torque = name.startswith("lockingTorque")
    out = np.empty(len(wc))
    memo: dict[tuple, float] = {}
    for k in range(len(wc)):
        d = float(wl[k] - wc[k])
        if d == 0.0:    # stuck: the direction the suns' torque difference pushes (the more loaded sun falls behind)
            dT = float(TA[k] - TB[k])
            sd = 0.0 if dT == 0.0 else -math.copysign(1.0, dT)
        else:
            sd = math.copysign(1.0, d)
        key = (float(wc[k]), float(T0[k]), sd)
        if key not in memo:
            dirs = (sd,) if sd != 0.0 else (1.0, -1.0)   # stuck: the easier direction
            vals = [law(key[0], key[1], s) for s in dirs]
            memo[key] = min(x[0] for x in vals) if torque else min(x[1] for x in vals)
        out[k] = memo[key]
    return out


__all__ = ["PREFIX", "NAMES", "parse", "needed", "series", "diff_params"]
