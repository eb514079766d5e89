"""Building the hostile daemon FMU of issue 45 item 3: ChkC (tests/broken_fmus/chkc.c) linked with
tests/broken_fmus/chk_daemons.c, whose constructor starts daemons in every process that loads it."""
from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

BROKEN = Path(__file__).resolve().parents[2] / "broken_fmus"
sys.path.insert(0, str(BROKEN))
import chk_build  # noqa: E402


def daemon_fmu(dest: Path, pid_dir: Path, cases: str = "1234") -> Path:
    """``dest``/ChkCDaemons.fmu whose daemons write their pids into ``pid_dir`` (gcc needed)."""
    import fmpy
    include = Path(fmpy.__file__).parent / "c-code"
    work = dest / "build"
    binary = work / "binaries" / fmpy.platform / f"ChkC{fmpy.sharedLibraryExtension}"
    binary.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run(["gcc", "-shared", "-fPIC", "-O1", "-std=c99", "-Wall", f"-I{include}",
                    f'-DCHK_DAEMON_DIR="{pid_dir}"', f'-DCHK_DAEMON_CASES="{cases}"', "-o", str(binary),
                    str(BROKEN / "chkc.c"), str(BROKEN / "chk_daemons.c"), "-lm"], check=True, capture_output=True)
    out = dest / "ChkCDaemons.fmu"
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("modelDescription.xml", chk_build.CHKC_XML)
        z.write(binary, f"binaries/{fmpy.platform}/{binary.name}")
    shutil.rmtree(work)
    return out


def alive(pid_dir: Path) -> list[int]:
    """The processes named in ``pid_dir`` still running (zombies, dead already, not counted)."""
    out = []
    for f in pid_dir.iterdir():
        try:
            state = Path(f"/proc/{f.name}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except (OSError, IndexError):
            continue
        if state != "Z":
            out.append(int(f.name))
    return out
