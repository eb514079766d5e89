"""``python -m harness.cli.tools.import_graph``: write the package picture of ``spurdiff`` and
``harness`` (drawn from the code by :mod:`harness.common.import_graph`) into docs/architecture.md between
its markers; ``--check``: exit 1 if the page's picture is out of date. Also prints the import
cycles, the arrows against spurdiff's and the harness's layers and the library imports of the CLI
(none wanted)."""
from __future__ import annotations

import argparse
import sys


def main(argv: list[str] | None = None) -> int:
    from harness.common import import_graph as ig

    ap = argparse.ArgumentParser(prog="python -m harness.cli.tools.import_graph", description=__doc__)
    ap.add_argument("--check", action="store_true", help="do not write; exit 1 if the picture is out of date")
    a = ap.parse_args(argv)
    doc = ig.ROOT / "docs" / "architecture.md"
    g = ig.graph()
    problems = ([f"cycle: {' <-> '.join(c)}" for c in ig.cycles(g)] + ig.layer_violations(g)
                + ig.harness_layer_violations(g) + [f"package in no layer: {p}" for p in ig.harness_unplaced()]
                + [f"library imports the CLI: {x}" for x in ig.cli_imports(g)])
    for p in problems:
        print(p, file=sys.stderr)
    n = sum(len(t) for t in g.values())
    print(f"{len(g)} modules, {n} import arrows, {len(problems)} problems")
    if a.check:
        stale = ig.current_picture(doc) != ig.picture(g)
        if stale:
            print(f"{doc}: the picture is out of date (run python -m harness.cli.tools.import_graph)", file=sys.stderr)
        return 1 if stale or problems else 0
    changed = ig.write_picture(doc)
    print(f"{doc}: {'written' if changed else 'up to date'}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
