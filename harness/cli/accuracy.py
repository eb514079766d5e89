"""``spurdiff accuracy``: accuracy versus wall time over fidelities, steps and tolerances (:mod:`harness.accuracy`)."""
from __future__ import annotations


def main(argv: list[str] | None = None) -> int:
    from harness.accuracy import main as _main
    return _main(argv)
