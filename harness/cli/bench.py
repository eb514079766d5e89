"""``spurdiff bench``: measured cost ratios, printed (:mod:`harness.bench`)."""
from __future__ import annotations


def main(argv: list[str] | None = None) -> int:
    from harness.bench import main as _main
    return _main(argv)
