"""Helpers of the harness's hostile-input tests (issue 14): scene and sweep files written into the
test's temporary folder, the command line run in this process or as a subprocess, and a check that
nothing outside the temporary folder changed."""
from __future__ import annotations

import re

import os
import signal
import subprocess
import sys
import uuid
from pathlib import Path
from types import SimpleNamespace

import pytest

ROOT = Path(__file__).resolve().parents[3]
BASE_SCENE = ROOT / "harness" / "scenes" / "paper-cornering.toml"
SPURDIFF = [sys.executable, "-m", "harness"]

# The escape through the emptied __builtins__ of eval: find a class whose module globals hold
# the real builtins, import os from there and run a shell command that leaves a marker file.
ESCAPE = ("[c for c in ().__class__.__base__.__subclasses__() if c.__name__ == 'catch_warnings'][0]()"
          "._module.__builtins__['__import__']('os').system('touch {marker}')")


# what the path cases try to write outside their folder (test_hostile_paths.BAD_NAMES and the
# scenes' default results/<name>/)
ESCAPE_NAMES = {"escaped", "a", "b", "abs", "hidden", ".hidden", "results", "hostile", "named"}


def _listing(folder: Path, deep: bool) -> list:
    if not folder.exists():
        return []
    items = folder.rglob("*") if deep else folder.iterdir()
    out = []
    for p in items:
        try:
            out.append((str(p.relative_to(folder)), p.is_dir() or p.stat().st_mtime_ns))
        except FileNotFoundError:   # vanished while listed
            pass
    return sorted(out)


@pytest.fixture
def sandbox(tmp_path):
    """The test's folder; after the test: no marker file written by an escape; next to the
    temporary folder, in the repository's results/ and beside the repository no new entry with a
    name the hostile cases write (``ESCAPE_NAMES``: those folders are shared with other processes,
    a CI log or a host's temporary folder beside the checkout, so only the cases' own names count);
    and the bundled scenes and sweeps untouched (not a file added, removed or modified)."""
    marker = tmp_path.parent / f"escaped-{uuid.uuid4().hex}"
    watched = {tmp_path.parent: False, ROOT / "results": False, ROOT.parent: False,
               ROOT / "harness" / "scenes": True, ROOT / "harness" / "sweeps": True}

    def state(w, deep):
        items = [x for x in _listing(w, deep) if x[0] != tmp_path.name]
        return items if deep else {name for name, _ in items}

    before = {w: state(w, deep) for w, deep in watched.items()}
    yield SimpleNamespace(dir=tmp_path, marker=marker)
    assert not marker.exists(), "an expression ran a shell command"
    for w, deep in watched.items():
        after = state(w, deep)
        if deep:
            assert after == before[w], f"{w} changed: {sorted(set(after) ^ set(before[w]))}"
        else:
            new = {n for n in after - before[w] if n in ESCAPE_NAMES or n.startswith("escaped")}
            assert not new, f"new in {w}: {sorted(new)}"


def scene(folder: Path, body: str, name: str = "hostile", filename: str | None = None) -> Path:
    """A scene file extending paper-cornering (absolute path) with ``body`` on top."""
    p = Path(folder) / (filename or f"{name}.toml")
    p.write_text(f'extends = "{BASE_SCENE}"\nname = "{name}"\n{body}\n')
    return p


def sweep(folder: Path, body: str, name: str = "hsweep", values: str = "[0.1]", duration: float = 0.01) -> Path:
    p = Path(folder) / f"{name}.toml"
    p.write_text(f'name = "{name}"\nscene = "paper-cornering"\nduration = {duration}\n'
                 f'[[parameters]]\nname = "diff.mu_pin"\nvalues = {values}\n{body}\n')
    return p


def cli(capsys, *argv: str) -> SimpleNamespace:
    """``spurdiff ARGV`` in this process: exit code, stdout, stderr."""
    from harness.cli import main

    rc = main([str(a) for a in argv])
    c = capsys.readouterr()
    return SimpleNamespace(rc=rc, out=c.out, err=c.err)


_PROGRESS = re.compile(r"spurdiff: .*(\.\.\.|: (done|stopped) in [0-9.]+ s|: [0-9]+ s so far)$")


def one_line_error(r: SimpleNamespace, *words: str, rc: int = 2) -> str:
    """The run ended with exit code ``rc`` and one line on stderr holding every word."""
    assert r.rc == rc, (r.rc, r.err)
    # the progress lines of long work (harness/common/progress.py: "spurdiff: building X...",
    # "spurdiff: X: done in 1.2 s") are not the error; everything else is
    lines = [x for x in r.err.splitlines() if x.strip() and not _PROGRESS.match(x.strip())]
    assert len(lines) == 1 and "Traceback" not in r.err, r.err
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def start(*argv: str, cwd: Path | None = None) -> subprocess.Popen:
    """``spurdiff ARGV`` as a subprocess that takes Ctrl-C like an interactive one (SIGINT at its
    default, even when this test process was started with SIGINT ignored)."""
    return subprocess.Popen(SPURDIFF + [str(a) for a in argv], cwd=cwd or ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
                            env={**os.environ, "PYTHONUNBUFFERED": "1"})
