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


def daemon_fmu(dest: Path, pid_dir: Path, cases: str = "1234", tag: str = "000000") -> Path:
    """``dest``/ChkCDaemons.fmu whose daemons write their pids into ``pid_dir`` and carry ``tag``
    (six digits) in their name or command line (gcc needed)."""
    import fmpy
    include = Path(fmpy.__file__).parent / "c-code"
    work = dest / "build"
    binary = work / "binaries" / fmpy.platform / f"ChkC{fmpy.sharedLibraryExtension}"
    binary.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run(["gcc", "-shared", "-fPIC", "-O1", "-std=c99", "-Wall", f"-I{include}",
                    f'-DCHK_DAEMON_DIR="{pid_dir}"', f'-DCHK_DAEMON_CASES="{cases}"', f'-DCHK_DAEMON_TAG="{tag}"', "-o", str(binary),
                    str(BROKEN / "chkc.c"), str(BROKEN / "chk_daemons.c"), "-lm"], check=True, capture_output=True)
    out = dest / "ChkCDaemons.fmu"
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("modelDescription.xml", chk_build.CHKC_XML)
        z.write(binary, f"binaries/{fmpy.platform}/{binary.name}")
    shutil.rmtree(work)
    return out


def alive(tag: str) -> list[int]:
    """Processes of the daemons tagged ``tag`` still running (found by name: their own pids may be
    those of another PID namespace); zombies, dead already, are not counted."""
    out = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            comm = (d / "comm").read_text().strip()
            cmdline = (d / "cmdline").read_bytes()
            state = (d / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except (OSError, IndexError):
            continue
        if (comm == f"chkd{tag}" or cmdline == f"sleep\x00299.{tag}\x00".encode()) and state != "Z":
            out.append(int(d.name))
    return out
