"""``spurdiff design`` (= ``python -m harness.cli.design``): for given tooth counts and centre
distances, profile shifts and tip diameters with margins: the teeth thinned for the backlash the
FMU simulates, an undercut margin on the generating shift, the basic rack's bottom clearance, a
specific-sliding limit, no tip interference, a least usable contact ratio, assembly and clearance
(:mod:`spurdiff.gears.design_search`); prints what changed against the input set, the design
checks with those limits and, with ``--torque``, the ISO 6336 load capacity of both sets at the
locked split with the limited life over the duty cycle; ``--write`` writes the set as a data file
(the bundled ``designed`` set, docs/capacity.md, was written so).

Input is checked: ``--input`` is read up to :data:`MAX_INPUT` bytes (a larger file, or a device
like /dev/zero, is one line naming it), its values are checked like FMU parameters; ``--write``
refuses a symlinked target and writes through a private temporary name in the target's folder,
then renames it into place."""
from __future__ import annotations

import argparse
import math
import sys
import tomllib
from pathlib import Path

HEADER = """# The designed gear set (`spurdiff design`, spurdiff/gears/design_search.py; docs/capacity.md):
# written by
#   {command}
# Tooth counts, module, rack, tool, face widths, axial layout and nPairs as the input set; centre
# distances {a} mm (A1, B2, 12). Profile shifts and tip diameters proposed with margins: each gear
# thinned for the backlash of its meshes ({j} mm at the operating pitch circles, A1, B2, 12) and cut
# at a generating shift >= {xm:g} beyond its undercut limit; tip clearances >= {c:g} m (the basic
# rack's bottom clearance 0.25 m); specific sliding >= -{z:g} at every start of active profile; no tip
# interference; usable contact ratio >= {eps:g} on every mesh; tip thickness >= {s:g} m; planet 2
# clear of sun A; neighbour clearance for nPairs. Keys as in differential.toml; SI units.
# Loaded by spurdiff.gears.design_sets.gear_set("designed")."""
MAX_INPUT = 1 << 20     # bytes: a gear-set file is a few hundred


def _read_input(path: str) -> str:
    """The text of ``--input``, at most MAX_INPUT bytes (a bigger file or an endless device is refused)."""
    from spurdiff.errors import ParameterError
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_INPUT + 1)
    except OSError as e:
        raise ParameterError("--input", path, "a readable TOML gear set", e.strerror or str(e)) from None
    if len(data) > MAX_INPUT:
        raise ParameterError("--input", path, f"a TOML gear set of at most {MAX_INPUT} bytes", "larger") from None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ParameterError("--input", path, "a UTF-8 TOML gear set", str(e)) from None


def _check_types(data: dict) -> None:
    """Every value of a gear-set file a number (tooth counts and nPairs integers), else a
    ParameterError naming it (``--input sunA.z``)."""
    from spurdiff.errors import ParameterError

    def need(name, v, integer):
        ok = isinstance(v, int) if integer else isinstance(v, (int, float))
        if isinstance(v, bool) or not ok:
            raise ParameterError(f"--input {name}", v, "an integer" if integer else "a number") from None

    for key, v in data.items():
        if isinstance(v, dict):
            for k, x in v.items():
                need(f"{key}.{k}", x, k == "z")
        else:
            need(key, v, key == "nPairs")


def _write_private(path: str, text: str) -> None:
    """Write ``text`` to ``path`` through a private temporary file in the same folder (mode 0600,
    created exclusively), renamed into place; a symlinked ``path`` is refused (the rename would
    replace the link, the write must not follow it)."""
    import os
    import tempfile
    from spurdiff.errors import ParameterError
    target = Path(path)
    if target.is_symlink():
        raise ParameterError("--write", path, "a file that is not a symbolic link", "refused") from None
    if target.exists() and not target.is_file():
        raise ParameterError("--write", path, "a regular file", "not one") from None
    folder = target.parent if str(target.parent) else Path(".")
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
        mask = os.umask(0o022)
        os.umask(mask)
        os.fchmod(fd, 0o666 & ~mask)          # private while written, the usual mode once in place
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, target)
        tmp = None
    except OSError as e:
        raise ParameterError("--write", path, "a writable file", e.strerror or str(e)) from None
    finally:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass


def _numbers(text: str, n: int, what: str, kind):
    from spurdiff.errors import ParameterError
    parts = [p.strip() for p in text.split(",")]
    if len(parts) != n:
        raise ParameterError(what, text, f"{n} comma-separated numbers")
    out = []
    for p in parts:
        try:
            v = kind(p)
        except ValueError:
            raise ParameterError(what, text, f"{n} comma-separated {'integers' if kind is int else 'numbers'}") from None
        if kind is float and not math.isfinite(v):
            raise ParameterError(what, text, "finite numbers")
        out.append(v)
    return out


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line (``spurdiff design: ...``), exit 2."""

    def error(self, message):
        from harness.cli import fail
        sys.exit(fail(self.prog, message + " (spurdiff design -h shows the options)"))


def _joined(argv: list[str]) -> list[str]:
    """``--teeth -5,13,...`` as ``--teeth=-5,13,...`` (a list starting with a minus sign is a value)."""
    out, i = [], 0
    while i < len(argv):
        if argv[i] in ("--teeth", "--centre-distances") and i + 1 < len(argv):
            out.append(f"{argv[i]}={argv[i + 1]}")
            i += 2
        else:
            out.append(argv[i])
            i += 1
    return out


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    ap = _Parser(prog="spurdiff design", description="propose profile shifts and tip diameters "
                                 "for given tooth counts and centre distances (no undercut, no interference, usable "
                                 "contact ratio >= 1.2, assembly and clearance), against an input set")
    ap.add_argument("--teeth", help="tooth counts sunA,planet1,sunB,planet2 (default: the input set's)")
    ap.add_argument("--centre-distances", dest="a", help="centre distances A1,B2,12 in mm (default: the input set's)")
    ap.add_argument("--input", help="input gear set, a TOML file with differential.toml's keys (default: the paper's)")
    ap.add_argument("--eps-min", type=float, default=1.1, help="least usable contact ratio (default 1.1)")
    ap.add_argument("--tip-thickness", type=float, default=0.3, help="least tip thickness, in modules (default 0.3)")
    ap.add_argument("--clearance", type=float, default=0.25, help="least tip clearances, in modules (default 0.25, "
                    "the basic rack's bottom clearance)")
    ap.add_argument("--undercut-margin", type=float, default=0.02, help="least margin of each generating shift "
                    "(thinned for the backlash) beyond the undercut limit, in x (default 0.02)")
    ap.add_argument("--sliding", type=float, default=4.0, help="largest magnitude of specific sliding at a start of "
                    "active profile (default 4)")
    ap.add_argument("--backlash", help="circumferential backlash A1,B2,12 in mm at the operating pitch circles, made by "
                    "thinning the teeth (default: differential.toml's mesh*.backlash, what the FMU simulates)")
    ap.add_argument("--torque", type=float, help="carrier torque T0 in N m: print the ISO 6336 capacity of both sets")
    ap.add_argument("--pin-diameter", type=float, help="diameter of the planets' pins in mm, for the rim factor Y_B "
                    "(default: 2 r_collar of differential.toml, the paper's 24 mm; 0: solid planets)")
    ap.add_argument("--scene-parameters", action="store_true", help="print the SpurDifferential parameters of the "
                    "proposed set as a TOML inline table, for a scene's [fmus.<diff>] parameters")
    ap.add_argument("--write", help="write the proposed set to this TOML file")
    args = ap.parse_args(_joined(argv))

    from spurdiff.errors import ParameterError
    from spurdiff.gears.design_search import GEARS, MESHES, Targets, propose, to_toml
    from spurdiff.gears.design_sets import table_from_data
    from spurdiff.gears.geometry import GearTable

    for name, v, lo, hi in (("--eps-min", args.eps_min, 1.0, 2.0), ("--tip-thickness", args.tip_thickness, 0.0, 1.0),
                            ("--clearance", args.clearance, 0.0, 0.5), ("--undercut-margin", args.undercut_margin, 0.0, 0.5),
                            ("--sliding", args.sliding, 0.5, 100.0)):
        if not (math.isfinite(v) and lo <= v <= hi):
            raise ParameterError(name, v, f"between {lo:g} and {hi:g}")
    if args.input:
        try:
            data = tomllib.loads(_read_input(args.input))
        except tomllib.TOMLDecodeError as e:
            raise ParameterError("--input", args.input, "a readable TOML gear set", str(e)) from None
        _check_types(data)
        try:
            base = table_from_data(data)
            base.validate()
        except ParameterError as e:
            raise ParameterError(f"--input {e.name}", e.value, e.allowed, e.hint) from None
        except (TypeError, ValueError, AttributeError) as e:
            raise ParameterError("--input", args.input, "a gear set with differential.toml's keys and numbers",
                                 str(e)) from None
    else:
        base = GearTable.paper()
    backlash = None
    if args.backlash:
        backlash = dict(zip(MESHES, (v / 1e3 for v in _numbers(args.backlash, 3, "--backlash", float))))
    targets = Targets(args.eps_min, args.tip_thickness, args.clearance, args.undercut_margin, args.sliding, backlash)
    targets.limits().validate()
    z = dict(zip(GEARS, _numbers(args.teeth, 4, "--teeth", int))) if args.teeth else \
        {n: getattr(base, n).z for n in GEARS}
    if args.a:
        a = dict(zip(MESHES, (v / 1e3 for v in _numbers(args.a, 3, "--centre-distances", float))))
    else:
        from spurdiff.gears.design import derive
        a = {me.name: me.a for me in derive(base).meshes}
    p = propose(z, a, base, targets)
    print(f"proposed gear set for z = {', '.join(str(z[n]) for n in GEARS)} (sunA, planet1, sunB, planet2), "
          f"centre distances {', '.join(f'{a[k] * 1e3:g}' for k in MESHES)} mm (A1, B2, 12); input -> proposed:")
    for line in p.changes():
        print("  " + line)
    lim = targets.limits()
    print(f"limits: undercut margin {lim.undercut_margin:g} on the generating shifts (backlash "
          f"{', '.join(f'{v * 1e3:g}' for v in lim.backlash_of().values())} mm by thinning), tip clearance "
          f">= {lim.clearance:g} m, specific sliding >= -{lim.sliding:g}, usable contact ratio >= {targets.eps_min:g}")
    print(f"design checks of the proposed set: {len(p.geometry.errors)} errors, {len(p.geometry.warnings)} warnings")
    for f in p.geometry.findings:
        print(f"  {f}")
    print(f"design checks of the input set: {len(p.before.errors)} errors, {len(p.before.warnings)} warnings")
    for f in p.before.findings:
        print(f"  {f}")
    _masses(p)
    if args.torque is not None:
        _capacity(args, p, MESHES)
    if args.scene_parameters:
        from spurdiff.gears.design_sets import fmu_parameters
        items = ", ".join(f'"{k}" = {v!r}' for k, v in fmu_parameters(p.table).items())
        print(f"scene parameters of the proposed set: {{ {items} }}")
    if args.write:
        cmd = "spurdiff design " + " ".join(a_ for a_ in _joined(argv) if not a_.startswith("--write")
                                             and a_ != args.write)
        text = to_toml(p, HEADER.format(command=cmd.strip(), a=", ".join(f"{a[k] * 1e3:g}" for k in MESHES),
                                        eps=args.eps_min, s=args.tip_thickness, c=args.clearance,
                                        j=", ".join(f"{v * 1e3:g}" for v in lim.backlash_of().values()),
                                        xm=lim.undercut_margin, z=lim.sliding))
        _write_private(args.write, text)
        print(f"written: {args.write}")
    return 0


def _masses(p) -> None:
    """The parts' masses of both sets (spurdiff.differential.inertia: bores removed, pins on the carrier,
    stepped planets) with the default parameters."""
    from spurdiff.differential.inertia import mass_properties
    from spurdiff.differential.params import DifferentialParams
    for label, geo in (("input", p.before), ("proposed", p.geometry)):
        mp = mass_properties(DifferentialParams(table=geo.table), geo)
        print(f"masses of the {label} set (bores removed, pins on the carrier): planet 1 / 2 {mp.m_planet1:.4f} / "
              f"{mp.m_planet2:.4f} kg, J {mp.J_planet1 * 1e6:.2f} / {mp.J_planet2 * 1e6:.2f} kg mm^2, "
              f"suns J {mp.J_sunA * 1e3:.4f} / {mp.J_sunB * 1e3:.4f} g m^2, pin {mp.m_pin:.4f} kg, "
              f"carrier with pins J {mp.J_carrier:.5f} kg m^2, with the planets' orbits {mp.J_carrier_total:.5f}")


def _capacity(args, p, MESHES) -> None:
    """The ISO 6336 capacity of the input and the proposed set at ``--torque``: the locked split at
    break-away (the default pin law and mu_pin), K_gamma of nPairs, K_v at vehicle-cornering's
    pitch-line speed; the limited life over the duty cycle; the ISO 6336-1 mesh stiffness."""
    from spurdiff.datafile import differential_default
    from spurdiff.differential.watches import rating_forces
    from spurdiff.errors import ParameterError
    from spurdiff.gears.capacity import capacity_report, life_report, pitch_line_speed, scaled, stiffness_comparison
    if not (math.isfinite(args.torque) and args.torque > 0.0):
        raise ParameterError("--torque", args.torque, "a finite carrier torque > 0 N m")
    K = {k: differential_default(f"mesh{k}.contactStiffness") for k in MESHES}
    e = differential_default("mesh.contactExponent")
    pin = 2.0 * differential_default("r_collar") if args.pin_diameter is None else args.pin_diameter / 1e3
    if not (math.isfinite(pin) and 0.0 <= pin < 0.2):
        raise ParameterError("--pin-diameter", args.pin_diameter, ">= 0 and < 200 mm")
    bores = {"planet1": pin, "planet2": pin} if pin > 0.0 else None
    mu, r_d = differential_default("mu_pin"), differential_default("r_collar")
    w_rel = 1.1706          # rad/s: vehicle-cornering's sun A relative to the carrier
    for label, geo in (("input", p.before), ("proposed", p.geometry)):
        F = rating_forces(geo, mu, r_d, args.torque)
        rep = capacity_report(geo, F, bores=bores, v=pitch_line_speed(geo, w_rel))
        print(f"ISO 6336 capacity of the {label} set at T0 = {args.torque:g} N m, the locked split at break-away "
              f"(mu_pin {mu:g}), sun A at {w_rel:g} rad/s to the carrier (planet pins {pin * 1e3:g} mm):")
        for line in rep.lines():
            print("  " + line)
        life = life_report(geo, scaled(F, 1.0 / args.torque), bores=bores)
        for line in life.lines():
            print("  " + line)
        print(f"mesh stiffness of the {label} set at T0 = {args.torque:g} N m, ISO 6336-1 against the paper's "
              f"IMPACT constants (e = {e:g}):")
        for c in stiffness_comparison(geo, F, K, e):
            print(f"  mesh {c.mesh:2s} F_n {c.F0:8.1f} N: ISO c' {c.c_prime:.2f}, c_gamma_alpha {c.c_gamma:.2f} "
                  f"N/(mm um), k = c_gamma_alpha b {c.k_iso / 1e6:6.1f} N/um, deflection {c.deflection_iso * 1e6:5.1f} "
                  f"um | IMPACT K {c.K_impact / 1e3 ** e:.3g} N/mm^{e:g}: secant {c.k_impact_secant / 1e6:6.1f} N/um, "
                  f"tangent {c.k_impact_tangent / 1e6:6.1f} N/um, penetration {c.deflection_impact * 1e6:5.1f} um "
                  f"| ISO / IMPACT secant {c.k_iso / c.k_impact_secant:.2f}, IMPACT K matching ISO "
                  f"{c.K_iso_equivalent / 1e3 ** e:.3g} N/mm^{e:g}")


if __name__ == "__main__":
    from harness.cli import fail
    from spurdiff.errors import ParameterError
    try:
        sys.exit(main())
    except ParameterError as e:
        sys.exit(fail("spurdiff design", str(e)))
