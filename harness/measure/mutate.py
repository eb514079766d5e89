"""Planted bugs and the tests that must catch them: a list of mutations kept as data
(``tests/mutations.toml``), planted one at a time in a private clone of the repository, each with
its targeted tests run there (``spurdiff mutate``, docs/testing.md).

The list: ``[settings]`` (``pythonpath``: the clone's folders put first on ``PYTHONPATH``;
``packages``: package names that are folders of another name, ``{spurdiff_fmus = "fmu_src"}``, made
importable from the clone through links in a private folder; ``probe``: packages that must import
from the clone) and one ``[[mutation]]`` table per
bug: ``id``, ``file`` (relative to the repository), ``original`` (an exact snippet that occurs once
in the file), ``replacement``, ``tests`` (pytest paths or node ids, relative to the repository),
``reason`` (one line), optionally ``timeout`` (s).

The clone: ``git clone`` of the repository's HEAD (committed work only) into a fresh temporary
folder of mode 0700, removed afterwards. The tests run with the current interpreter and the
clone's sources first on ``PYTHONPATH`` (so an editable install of another checkout is not what
they import, and the FMUs and kernels they build are compiled from the clone's own C sources into
the clone's ``build/fmus``: :func:`probe` checks where ``spurdiff``, ``spurdiff_fmus`` and the FMU
folder resolve before anything runs), no byte code written (a mutation of the same length in the
same second would otherwise be hidden by a cached ``.pyc``).

A mutation is *caught* when its tests fail (pytest exit code 1), *survived* when they pass (0, at
least one test passed), *skipped* when every test was skipped (0, nothing passed: the machine lacks
what they need), *timeout* past its time limit and *error* for any other exit (no tests collected, a
usage error).
With ``baseline`` the unmutated clone runs every listed test first: the list is meaningful only if
they pass there.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

DEFAULT_LIST = Path("tests") / "mutations.toml"
DEFAULT_TIMEOUT = 900.0
PYTEST = ["-m", "pytest", "-n", "0", "-q", "-x", "-p", "no:cacheprovider", "-o", "addopts="]


class MutationError(ValueError):
    """A list that cannot be used (a field missing, a snippet not found exactly once); the message
    names the entry and the field."""


@dataclass(frozen=True)
class Mutation:
    id: str
    file: str
    original: str
    replacement: str
    tests: tuple[str, ...]
    reason: str
    timeout: float = DEFAULT_TIMEOUT


@dataclass
class Settings:
    pythonpath: list[str] = field(default_factory=lambda: ["."])
    packages: dict[str, str] = field(default_factory=dict)
    probe: list[str] = field(default_factory=list)


@dataclass
class Outcome:
    id: str
    verdict: str          # caught | survived | timeout | error
    seconds: float
    detail: str = ""      # the last lines of the test output (failures, errors)


def load(path: Path) -> tuple[Settings, list[Mutation]]:
    """The settings and mutations of the list file ``path``; MutationError naming what is wrong."""
    try:
        data = tomllib.loads(Path(path).read_text())
    except (OSError, tomllib.TOMLDecodeError) as e:
        raise MutationError(f"{path}: {e}") from None
    s = data.get("settings", {})
    settings = Settings(list(s.get("pythonpath", ["."])), dict(s.get("packages", {})), list(s.get("probe", [])))
    out, seen = [], set()
    for k, m in enumerate(data.get("mutation", [])):
        where = f"{path}: mutation {k + 1} ({m.get('id', 'no id')})"
        for f in ("id", "file", "original", "replacement", "tests", "reason"):
            if not m.get(f):
                raise MutationError(f"{where}: '{f}' is missing or empty")
        if m["id"] in seen:
            raise MutationError(f"{where}: id '{m['id']}' is used twice")
        if m["original"] == m["replacement"]:
            raise MutationError(f"{where}: 'replacement' is the same as 'original'")
        seen.add(m["id"])
        timeout = float(m.get("timeout", DEFAULT_TIMEOUT))
        if not timeout > 0.0:
            raise MutationError(f"{where}: 'timeout' = {timeout!r}, allowed > 0 s")
        out.append(Mutation(m["id"], m["file"], m["original"], m["replacement"], tuple(m["tests"]), m["reason"],
                            timeout))
    if not out:
        raise MutationError(f"{path}: no [[mutation]] entries")
    return settings, out


def check_snippets(root: Path, mutations: list[Mutation]) -> None:
    """Each original snippet occurs exactly once in its file under ``root`` (else MutationError)."""
    for m in mutations:
        p = root / m.file
        if not p.is_file():
            raise MutationError(f"{m.id}: file {m.file} not found")
        n = p.read_text().count(m.original)
        if n != 1:
            raise MutationError(f"{m.id}: the original snippet occurs {n} times in {m.file} (needs exactly 1)")


def clone(repo: Path) -> Path:
    """A clone of ``repo``'s HEAD in a new private temporary folder (0700); returns the folder that
    holds it (the clone is ``<folder>/repo``; remove the folder when done)."""
    base = Path(tempfile.mkdtemp(prefix="spurdiff_mutate_"))
    os.chmod(base, 0o700)
    subprocess.run(["git", "clone", "-q", "--no-hardlinks", str(repo), str(base / "repo")], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    return base


def environment(base: Path, settings: Settings) -> dict[str, str]:
    """The tests' environment: the clone's folders first on PYTHONPATH, the renamed packages linked
    from ``<base>/links``, no byte code, no FMU or kernel folder of another checkout."""
    root = base / "repo"
    links = base / "links"
    links.mkdir(exist_ok=True)
    for name, folder in settings.packages.items():
        target = links / name
        if not target.exists():
            target.symlink_to(root / folder, target_is_directory=True)
    env = {k: v for k, v in os.environ.items()
           if k not in ("SPURDIFF_FMU_DIR", "SPURDIFF_KERNEL_DIR", "PYTHONPATH", "PYTHONHOME")}
    env["PYTHONPATH"] = os.pathsep.join([str(links)] + [str((root / p).resolve()) for p in settings.pythonpath])
    env["PYTHONDONTWRITEBYTECODE"] = "1"
    return env


PROBE = """
import importlib, json, sys
out = {}
for name in sys.argv[1:]:
    m = importlib.import_module(name)
    out[name] = getattr(m, '__file__', None) or list(m.__path__)[0]
if 'harness' in sys.argv[1:]:    # this project: where the FMUs' C sources and built FMUs are
    from harness.common import paths
    out['fmu_sources'], out['fmu_dir'] = str(paths.fmu_sources()), str(paths.fmu_cache_dir())
print(json.dumps(out))
"""


def probe(base: Path, env: dict, names: list[str]) -> dict[str, str]:
    """Where the clone's tests import ``names`` from (and, in this project, where the FMUs' C
    sources and built FMUs are): MutationError if any of it lies outside the clone."""
    import json

    root = (base / "repo").resolve()
    r = subprocess.run([sys.executable, "-c", PROBE, *names], cwd=root, env=env, capture_output=True, text=True)
    if r.returncode != 0:
        raise MutationError(f"the clone's packages do not import: {r.stderr.strip().splitlines()[-1:]}")
    where = json.loads(r.stdout)
    for k, v in where.items():
        if not Path(v).resolve().is_relative_to(root):
            raise MutationError(f"in the clone, {k} resolves to {v}, outside the clone {root}")
    return where


def run_tests(root: Path, env: dict, tests: tuple[str, ...], timeout: float,
              first_failure: bool = True) -> tuple[int | None, str, float]:
    """(pytest exit code or None on timeout, the output's last lines, seconds); ``first_failure``:
    stop at the first failing test (-x)."""
    t0 = time.monotonic()
    args = PYTEST if first_failure else [a for a in PYTEST if a != "-x"]
    try:
        r = subprocess.run([sys.executable, *args, *tests], cwd=root, env=env, capture_output=True, text=True,
                           timeout=timeout)
    except subprocess.TimeoutExpired as e:
        tail = (e.stdout or b"")[-2000:]
        return None, tail.decode("utf-8", "replace") if isinstance(tail, bytes) else tail, time.monotonic() - t0
    lines = (r.stdout + r.stderr).strip().splitlines()
    return r.returncode, "\n".join(lines[-15:]), time.monotonic() - t0


def verdict(code: int | None, tail: str = "") -> str:
    """caught (exit 1), survived (0 with a test passed), skipped (0 with none passed: every test
    skipped, which says nothing about the mutation), timeout (None), error (any other exit)."""
    if code == 0:
        return "survived" if re.search(r"\b\d+ passed\b", tail) else "skipped"
    return "timeout" if code is None else {1: "caught"}.get(code, "error")


def plant_and_run(root: Path, env: dict, m: Mutation) -> Outcome:
    """Plant ``m`` in the clone at ``root``, run its tests, restore the file (also on failure)."""
    p = root / m.file
    text = p.read_text()
    if text.count(m.original) != 1:
        return Outcome(m.id, "error", 0.0, f"the original snippet occurs {text.count(m.original)} times in {m.file}")
    try:
        p.write_text(text.replace(m.original, m.replacement))
        code, tail, sec = run_tests(root, env, m.tests, m.timeout)
    finally:
        p.write_text(text)
    return Outcome(m.id, verdict(code, tail), sec, tail)


def run(repo: Path, list_file: Path, only: list[str] | None = None, baseline: bool = True,
        report=print, keep: bool = False) -> tuple[list[Outcome], Outcome | None]:
    """Clone ``repo``, check the list against the clone, optionally run the unmutated baseline, then
    each mutation (``only``: these ids). Returns (outcomes, baseline outcome or None). ``report``
    gets a line per finished run."""
    settings, mutations = load(list_file)
    if only:
        unknown = sorted(set(only) - {m.id for m in mutations})
        if unknown:
            raise MutationError(f"--only: no mutation {', '.join(unknown)} in {list_file} "
                                f"(ids: {', '.join(m.id for m in mutations)})")
        mutations = [m for m in mutations if m.id in only]
    base = clone(repo)
    try:
        root = base / "repo"
        check_snippets(root, mutations)
        env = environment(base, settings)
        probe(base, env, list(dict.fromkeys(list(settings.packages) + settings.probe)))
        base_out = None
        if baseline:
            tests = tuple(dict.fromkeys(t for m in mutations for t in m.tests))
            code, tail, sec = run_tests(root, env, tests, sum(m.timeout for m in mutations), first_failure=False)
            base_out = Outcome("(baseline)", "passed" if code == 0 else verdict(code, tail) if code != 1 else "failed",
                               sec, tail)
            report(f"baseline: {base_out.verdict} in {sec:.0f} s")
            if code != 0:
                return [], base_out
        outcomes = []
        for m in mutations:
            o = plant_and_run(root, env, m)
            outcomes.append(o)
            report(f"{m.id}: {o.verdict} in {o.seconds:.0f} s")
        return outcomes, base_out
    finally:
        if keep:
            report(f"clone kept: {base}")
        else:
            shutil.rmtree(base, ignore_errors=True)


def summary(tail: str) -> str:
    """pytest's closing counts (``1 failed, 3 passed``) from the last lines of its output, or ''."""
    for line in reversed(tail.splitlines()):
        if re.search(r"\b\d+ (passed|failed|skipped|error)", line):
            return re.sub(r"\s+in [\d.]+s.*$", "", line.strip("= ").strip())
    return ""


def table(outcomes: list[Outcome]) -> str:
    """The result as a text table: id, verdict, seconds; the counts and the total time last."""
    w = max([len(o.id) for o in outcomes] + [2])
    lines = [f"{'id':<{w}}  {'verdict':<8}  {'seconds':>7}  pytest", f"{'-' * w}  {'-' * 8}  {'-' * 7}  {'-' * 6}"]
    lines += [f"{o.id:<{w}}  {o.verdict:<8}  {o.seconds:7.1f}  {summary(o.detail)}" for o in outcomes]
    counts = {v: sum(o.verdict == v for o in outcomes)
              for v in ("caught", "survived", "skipped", "timeout", "error")}
    lines.append(", ".join(f"{n} {v}" for v, n in counts.items() if n) + f"; {sum(o.seconds for o in outcomes):.0f} s")
    return "\n".join(lines)


__all__ = ["Mutation", "MutationError", "Outcome", "load", "run", "table", "DEFAULT_LIST"]
