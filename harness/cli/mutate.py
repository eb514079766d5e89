"""``spurdiff mutate [--list FILE] [--only ID ...] [--no-baseline] [--keep]`` (also ``python -m
harness.cli.mutate``): plant each mutation of the list (default ``tests/mutations.toml`` of the
checkout) one at a time in a private clone of the checkout's HEAD, run the tests that must catch
it, restore it, and print a table (id, caught/survived, seconds) with the total time
(:mod:`harness.measure.mutate`, docs/testing.md). Exit 0 when every mutation was caught, 1 when one
survived (or timed out, or its tests could not run, or the baseline failed), 2 for a bad list or
option."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    from harness.cli import fail
    from harness.measure.mutate import DEFAULT_LIST, MutationError, run, table
    from harness.common.paths import checkout_root

    ap = argparse.ArgumentParser(prog="spurdiff mutate", description=__doc__.split("\n\n")[0])
    ap.add_argument("--list", type=Path, default=None,
                    help=f"the mutation list (default: {DEFAULT_LIST} of the checkout)")
    ap.add_argument("--only", nargs="+", metavar="ID", help="only these mutations")
    ap.add_argument("--repo", type=Path, default=None, help="the repository to clone (default: this checkout)")
    ap.add_argument("--no-baseline", action="store_true", help="skip the run of the unmutated tests")
    ap.add_argument("--keep", action="store_true", help="keep the clone (its folder is printed)")
    a = ap.parse_args(argv)
    repo = a.repo or checkout_root()
    if repo is None:
        return fail("spurdiff mutate", "not run from a source checkout: give --repo (a git repository)")
    if not (Path(repo) / ".git").exists():
        return fail("spurdiff mutate", f"--repo {repo}: not a git repository")
    list_file = a.list or Path(repo) / DEFAULT_LIST
    t0 = time.monotonic()
    try:
        outcomes, base = run(Path(repo), list_file, a.only, not a.no_baseline, report=lambda s: print(s, flush=True),
                             keep=a.keep)
    except MutationError as e:
        return fail("spurdiff mutate", str(e))
    if base is not None and base.verdict != "passed":
        print(base.detail)
        return fail("spurdiff mutate", f"the unmutated tests did not pass ({base.verdict}): fix them first", 1)
    print()
    print(table(outcomes))
    print(f"total (with clone{'' if a.no_baseline else ' and baseline'}): {time.monotonic() - t0:.0f} s")
    for o in outcomes:
        if o.verdict in ("timeout", "error"):
            print(f"\n{o.id} ({o.verdict}):\n{o.detail}")
    return 0 if all(o.verdict == "caught" for o in outcomes) else 1


if __name__ == "__main__":
    sys.exit(main())
