"""``spurdiff scenes``: the scenes (``harness/scenes/*.toml``), each with the first line of its description."""
from __future__ import annotations

import argparse


def main(argv: list[str] | None = None) -> int:
    argparse.ArgumentParser(prog="spurdiff scenes", description="list the scenes").parse_args(argv)
    from harness.scene.spec import describe_all
    for name, desc in describe_all():
        print(f"{name:22s} {desc}")
    return 0
