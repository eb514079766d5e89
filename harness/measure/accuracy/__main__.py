"""``python -m harness.measure.accuracy`` = ``spurdiff accuracy`` (:mod:`harness.cli.accuracy`)."""
import sys

from harness.cli.accuracy import main

sys.exit(main())
