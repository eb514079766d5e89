"""The ``spurdiff`` command line, one module per command; the only place with argparse.

``spurdiff COMMAND ...`` hands the arguments after the command to ``harness.cli.<command>.main``
(each command parses its own options, ``spurdiff COMMAND -h`` shows them). The library modules
never import this package: the ``python -m`` entries live here (``python -m harness.cli.info``,
``python -m harness.cli.tools.mesh_bench``...) or in a package's ``__main__`` that calls one of these
(``python -m harness.sweep``, ``python -m harness.measure.accuracy``).

May import: every harness package and :mod:`spurdiff`; nothing imports it but the ``__main__`` modules.
"""
from __future__ import annotations

import argparse
import importlib
import sys

# command -> (module in this package, one line of help)
COMMANDS = {
    "build": ("build", "build the FMUs (build/fmus in a checkout, else the per-user cache; --out DIR, --force); "
                       "prints where"),
    "fmu": ("fmu", "print the path of a built FMU, building it if needed"),
    "info": ("info", "derived geometry, design checks and the paper's theory table beside ours"),
    "design": ("design", "propose profile shifts and tip diameters for given tooth counts and centre distances (docs/capacity.md)"),
    "scenes": ("scenes", "list the scenes"),
    "run": ("run", "run a scene: results table, checks, CSV and plots"),
    "bench": ("bench", "measured cost ratios: FMI vs direct, each fidelity vs rigid, real-time factors"),
    "check": ("check", "FMI 2.0 compliance checks of any co-simulation FMU, JUnit report (docs/compliance.md)"),
    "export-ssp": ("export_ssp", "write a scene as an SSP file other masters run (docs/interoperability.md)"),
    "export-container": ("export_container", "write a scene as one container FMU that steps its FMUs "
                                             "(fmu-manipulation-toolbox; --compare: beside our master)"),
    "accuracy": ("accuracy", "accuracy versus wall time over fidelities, steps and tolerances (docs/accuracy.md)"),
    "sweep": ("sweep", "design sweep of a scene on a local or remote Dask cluster, resumable (docs/sweeps.md)"),
    "mutate": ("mutate", "plant the listed bugs one at a time in a clone and run the tests that must catch them "
                         "(docs/testing.md)"),
    "starter": ("starter", "write a ready-to-run starter for the FMU in your own tool: fmpy script, C host or SSP "
                           "(docs/use-the-fmu.md)"),
}


def fail(prog: str, msg: str, code: int = 2) -> int:
    """One line on stderr, ``prog: msg`` (control characters escaped, at most
    :data:`harness.common.messages.LINE` characters); returns ``code`` (the exit code)."""
    from harness.common.messages import one_line

    print(one_line(f"{prog}: {msg}"), file=sys.stderr)
    return code


def add_scene_export_arguments(ap: argparse.ArgumentParser, what: str, into: str) -> None:
    """The arguments every scene export shares (``spurdiff export-ssp``, ``export-container``): the
    scene, ``-o`` (``what``: the file written, default ``results/<scene>/<scene>.<ext>``), the step and
    stop time (``into``: where they are written), the mesh model and ``--set`` overrides."""
    ap.add_argument("scene", help="scene name (see `spurdiff scenes`) or path to a .toml file")
    ap.add_argument("-o", "--output", help=what)
    ap.add_argument("--step", type=float, help=f"communication step {into}, s (default: the scene's)")
    ap.add_argument("--duration", type=float, help=f"stop time {into}, s (default: the scene's)")
    ap.add_argument("--mesh", help="differential mesh model (overrides the scene's effects.meshModel)")
    ap.add_argument("--set", action="append", default=[], metavar="INST.PARAM=VALUE",
                    help="override a parameter, e.g. --set diff.mu_pin=0.1")


def build_parser() -> argparse.ArgumentParser:
    from harness.common.paths import package_version

    ap = argparse.ArgumentParser(prog="spurdiff", description="Spur-gear planetary differential FMUs and "
                                                              "co-simulation harness")
    ap.add_argument("--version", action="version", version=f"spurdiff {package_version()}")
    sub = ap.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, (_, text) in COMMANDS.items():
        sub.add_parser(name, help=text, add_help=False)
    return ap


def main(argv: list[str] | None = None) -> int:
    from harness.run.master import RunFailure
    from harness.common.outputs import OutputError
    from harness.scene.schema import SceneError
    from spurdiff.errors import ParameterError

    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in COMMANDS:
        build_parser().parse_args(argv)   # --version, -h, or a usage error (exit 2)
        return 2
    module = importlib.import_module(f"harness.cli.{COMMANDS[argv[0]][0]}")
    try:
        return module.main(argv[1:])
    except (SceneError, ParameterError, RunFailure) as e:
        return fail("spurdiff", str(e))
    except OutputError as e:   # a result that could not be written: the place and the errno
        return fail("spurdiff", str(e), 1)
    except KeyboardInterrupt:
        return fail("spurdiff", "interrupted", 130)
