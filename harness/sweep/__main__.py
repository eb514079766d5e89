"""``python -m harness.sweep``: the same as ``spurdiff sweep`` (:mod:`harness.cli.sweep`)."""
import sys

from harness.cli.sweep import main

sys.exit(main())
