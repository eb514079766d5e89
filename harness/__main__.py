"""`python -m harness ...` is the same as the `spurdiff` command."""
import sys

from harness.cli import main

sys.exit(main())
