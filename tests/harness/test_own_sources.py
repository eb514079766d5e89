"""A checkout builds its own C sources (issue 42 item 5): a second clone of the repository, run
with this checkout's environment (whose editable install points here), finds and compiles the C
files of the clone, not these. Only the source path, the digest and one kernel (rigid_kernel.c,
about a second) are made, no FMU."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from harness.common.paths import checkout_root

ROOT = checkout_root()
PROBE = """
import json, sys
from pathlib import Path
from harness.common.paths import fmu_sources, sources_digest
from harness.build import fmu
out = Path(sys.argv[1])
fmu.compile_kernel(out, fmu.RIGID_KERNEL_SOURCES)
print(json.dumps({"harness": fmu.__file__, "sources": str(fmu_sources()), "native": str(fmu.NATIVE_KERNELS),
                  "digest": sources_digest()}))
"""


def _probe(where: Path, out: Path) -> dict:
    """The build's view from the checkout ``where``: this interpreter, started in that folder (so its
    ``harness`` is that checkout's, as ``python -m pytest`` or ``python -m harness`` there)."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "SPURDIFF_FMU_DIR")}
    r = subprocess.run([sys.executable, "-c", PROBE, str(out)], cwd=where, env=env, capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(ROOT is None or shutil.which("git") is None, reason="needs a git checkout and git")
def test_a_second_clone_compiles_its_own_c_sources(tmp_path):
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", "--shared", str(ROOT), str(clone)], check=True, timeout=120)
    # the clone at HEAD runs this checkout's harness code (the code under test, committed or not)
    shutil.copytree(ROOT / "harness", clone / "harness", dirs_exist_ok=True,
                    ignore=shutil.ignore_patterns("__pycache__"))
    marker = f"spurdiff-clone-{os.getpid()}"
    kernel = clone / "fmu_src" / "native" / "kernels" / "rigid_kernel.c"
    kernel.write_text(kernel.read_text() + f'\nconst char spurdiff_checkout_marker[] = "{marker}";\n')

    here, there = _probe(ROOT, tmp_path / "here.so"), _probe(clone, tmp_path / "there.so")
    assert Path(there["harness"]).is_relative_to(clone)       # the clone's harness ran
    assert Path(there["sources"]) == clone / "fmu_src" and Path(there["native"]).is_relative_to(clone)
    assert Path(here["sources"]) == ROOT / "fmu_src"
    assert there["digest"] != here["digest"]                   # its FMUs are not this checkout's
    assert marker.encode() in (tmp_path / "there.so").read_bytes()
    assert marker.encode() not in (tmp_path / "here.so").read_bytes()
