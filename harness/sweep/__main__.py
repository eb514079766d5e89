"""``python -m harness.sweep``: the same as ``spurdiff sweep``."""
import sys

from harness.sweep import main

sys.exit(main())
