"""``spurdiff accuracy`` with its parsed options (parser: :mod:`harness.cli.accuracy`): measure
the grid's scenes, store their points and facts, render the docs."""
from __future__ import annotations

import csv
import json

from harness.measure.accuracy import data as _data
from harness.measure.accuracy.data import load_grid, read_csv, stored_files, write_csv
from harness.measure.accuracy.ivp import ivp_baseline
from harness.measure.accuracy.measure import measure_scene
from harness.measure.accuracy.render import _write_docs
from harness.common.outputs import atomic_file, probe, write_text
from harness.common.paths import docs_dir, results_dir
from harness.scene.spec import SceneError



def run(args) -> int:
    """``spurdiff accuracy`` with its parsed options (:mod:`harness.cli.accuracy`)."""
    data_file, facts_file = stored_files()
    args.out = args.out or docs_dir()
    if args.render:
        stored = json.loads((facts_file if facts_file.exists() else _data.FACTS_FILE).read_text())
        if not args.data.exists():
            args.data = _data.DATA_FILE
        data = read_csv(args.data)
        return _write_docs(data, stored["facts"], stored.get("ivp"), args.out, stored["command"], data,
                           stored.get("ivp_command"))
    for place in (args.data, facts_file, args.out / "accuracy.md", results_dir("accuracy", "ivp.csv")):
        probe(place)   # a place that cannot be written is said before minutes of measurements
    grid = load_grid()
    if args.only_ivp and (args.scenes or args.no_ivp or args.quick):
        raise SceneError("--only-ivp runs no scenes: give it no scene names, --no-ivp or --quick")
    names = [] if args.only_ivp else (args.scenes or list(grid))
    for n in names:
        if n not in grid:
            raise SceneError(f"no accuracy grid for scene {n!r}; allowed: {', '.join(grid)}")
    all_points, facts = [], {}
    cmd = ("spurdiff accuracy" + (" " + " ".join(args.scenes) if args.scenes else "") + (" --quick" if args.quick else "")
           + (" --no-ivp" if args.no_ivp else "") + (" --only-ivp" if args.only_ivp else ""))
    for n in names:
        pts, f = measure_scene(n, grid[n], args.quick)
        write_csv(pts, results_dir("accuracy", f"{n}.csv"))
        all_points += pts
        facts[n] = {**f, "command": cmd}
    # keep stored rows of scenes not rerun
    kept = [p for p in read_csv(args.data if args.data.exists() else _data.DATA_FILE) if p.scene not in names]
    write_csv(kept + all_points, args.data)
    ivp = None if args.no_ivp or args.quick else ivp_baseline()
    if ivp:
        path = results_dir("accuracy", "ivp.csv")
        with atomic_file(path, "w", newline="") as f:   # (--only-ivp in a fresh folder: the folder made here)
            w = csv.DictWriter(f, fieldnames=list(ivp[0]))
            w.writeheader()
            w.writerows(ivp)
    print(f"wrote {args.data}")
    if args.quick or args.data != data_file:
        return _write_docs(all_points, facts, ivp, args.out, cmd, kept + all_points)
    # the stored facts: those of the scenes rerun replace theirs, the others (and the solve_ivp
    # points, unless rerun) stay; the docs then show every stored scene, each with its command
    stored = json.loads(facts_file.read_text()) if facts_file.exists() else {"facts": {}, "ivp": None}
    merged = {n: (facts.get(n) or stored["facts"].get(n)) for n in grid if n in facts or n in stored["facts"]}
    if ivp is None:
        ivp, ivp_cmd = stored.get("ivp"), stored.get("ivp_command", "spurdiff accuracy")
    else:
        ivp_cmd = cmd
    write_text(facts_file, json.dumps({"command": "spurdiff accuracy", "facts": merged, "ivp": ivp,
                                       "ivp_command": ivp_cmd}, indent=1) + "\n")
    data = kept + all_points
    return _write_docs(data, merged, ivp, args.out, "spurdiff accuracy", data, ivp_cmd)
