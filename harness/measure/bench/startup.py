"""What an FMU costs beside a plain C FMU of ours (issue 44): start-up and the step with the defaults.

The C FMU is the compliance kit's test FMU (``tests/broken_fmus/chkc.c``: x' = k u, y = k u, built
plainly by ``tests/broken_fmus/chk_build.py``; a checkout without ``tests/`` skips this section).
Each measure runs both FMUs interleaved in the same command, so machine noise hits both sides:

* whole run: a fresh extraction (``unzip -q``) and our C host (:file:`startup_host.c`, compiled
  here: dlopen, instantiate, initialize, one 5 ms step, terminate, free) as one process, wall time,
  median of the runs: what a CI job or a sweep of short runs pays per run (fmusim is not available);
  with the Python started, once more with the runtime's archives unpacked afresh (``SPURDIFF_FMU_RUNTIME_DIR``
  a new folder each run: what the first run of a user on a machine pays once, fmu_src/native/fmi/runtime_unpack.h);
* instantiate + initialize in a fresh Python process with fmpy (the FMU extracted beforehand; fmpy
  imported; timed from before ``fmi2Instantiate`` to after ``fmi2ExitInitializationMode``),
  median: with the model in the host's process, and in its own process (``SPURDIFF_FMU_PROCESS=out``:
  the loader's choice in a host whose Python is not the runtime's version, fmu_src/native/fmi/fmi2_loader.c);
* the own process's memory: PSS (``/proc/<pid>/smaps_rollup``, shared pages split among the
  processes that map them) of every model process of :data:`PSS_INSTANCES` instances in one host,
  summed and divided by the instances: the first instance's process started directly, the others
  forked by the FMU folder's zygote (fmu_src/native/fmi/fmi2_server.c --zygote, its own PSS
  included); and, in the same run, every process started directly (``SPURDIFF_FMU_ZYGOTE=0``);
* per step in fmpy with the FMU's defaults: ``setReal`` of every Real input, ``doStep`` (5 ms),
  ``getReal`` of every Real output (fmpy's Python API, as a script would call it), fastest of the
  rounds; and the same with the C FMU's one input and two outputs;
* a long native run (:data:`LONG_STEPS`, up to 3 interleaved runs each): how much the host's resident
  memory grew over the steps, the most of the runs (nothing is kept per step: flat), and the FMU state
  call after them, median, which starts the model's Python and hands it the native step's state (as
  long after a long run as after a short one).

SpurDifferential is measured twice, as its host meets it: with the native start (the defaults kept: no
Python starts, fmu_src/native/fmi/native_start.c) and with its Python started
(``SPURDIFF_FMU_START=python``: what a run pays that sets a parameter to another value, at that set).

``python -m harness.cli.tools.startup_bench [RUNS] [--against EARLIER.fmu]`` prints the section (section 8 of
``spurdiff bench``) with the load average; ``--against`` measures an earlier build of SpurDifferential
in the same interleaved runs (a change's before and after).
"""
from __future__ import annotations

import importlib.util
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from harness.measure.bench.process import environment

HOST_SOURCE = Path(__file__).with_name("startup_host.c")
ROOT = Path(__file__).resolve().parents[3]   # the checkout: harness/measure/bench/ -> .
CHK_BUILD = ROOT / "tests" / "broken_fmus" / "chk_build.py"
STEP = 0.005
PSS_INSTANCES = 20     # the count: own-process instances in one host for the memory measure


def c_fmu() -> Path | None:
    """The plain C FMU (ChkC), built by the kit's test helper; None without it (or without gcc)."""
    if not CHK_BUILD.is_file() or shutil.which("gcc") is None:
        return None
    spec = importlib.util.spec_from_file_location("_spurdiff_chk_build", CHK_BUILD)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.chkc_fmu("ChkC")


def _host(tmp: Path) -> Path:
    from harness.build.fmu import _fmi2_headers
    exe = tmp / "startup_host"
    subprocess.run(["gcc", "-O2", f"-I{_fmi2_headers()}", "-o", str(exe), str(HOST_SOURCE), "-ldl"], check=True,
                   capture_output=True)
    return exe


def _identity(fmu: Path) -> tuple[str, str]:
    from fmpy import read_model_description
    md = read_model_description(str(fmu))   # (read with the archive it runs)
    return md.coSimulation.modelIdentifier, md.guid


def whole_run(fmu: Path, host: Path, tmp: Path, env: dict | None = None) -> tuple[float, float]:
    """Seconds of one whole run: unzip into a fresh folder, the C host's run (``env`` added to the
    environment); the folder removed after. And the seconds of the unzip alone."""
    ident, guid = _identity(fmu)
    d = Path(tempfile.mkdtemp(dir=tmp))
    try:
        t0 = time.perf_counter()
        subprocess.run(["unzip", "-q", str(fmu), "-d", str(d)], check=True)
        unzipped = time.perf_counter() - t0
        r = subprocess.run([str(host), str(d / "binaries" / "linux64" / f"{ident}.so"), guid,
                            (d / "resources").as_uri(), str(STEP)], capture_output=True, text=True,
                           env={**os.environ, **(env or {})})
        dt = time.perf_counter() - t0
        if r.returncode != 0:
            raise RuntimeError(f"{fmu.name}: the C host failed ({r.returncode}): {r.stderr.strip()[-300:]}")
        return dt, unzipped
    finally:
        shutil.rmtree(d, ignore_errors=True)


_INIT = r"""
import sys, time
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave
md = read_model_description(sys.argv[1])
s = FMU2Slave(guid=md.guid, unzipDirectory=sys.argv[2], modelIdentifier=md.coSimulation.modelIdentifier,
              instanceName='b')
t0 = time.perf_counter()
s.instantiate()
if len(sys.argv) > 3:   # a Real parameter set to another value: NAME=VALUE
    name, value = sys.argv[3].split('=')
    s.setReal([next(v.valueReference for v in md.modelVariables if v.name == name)], [float(value)])
s.setupExperiment(startTime=0.0)
s.enterInitializationMode()
s.exitInitializationMode()
t1 = time.perf_counter()
s.terminate()
s.freeInstance()
print('INIT', t1 - t0)
"""


def init_time(fmu: Path, unzipped: Path, own_process: bool, env: dict | None = None, setting: str = "") -> float:
    """Seconds of instantiate + initialize in a fresh fmpy process (the FMU extracted before); ``setting``
    "NAME=VALUE": that Real parameter set after fmi2Instantiate."""
    env = {**os.environ, **(env or {}), "SPURDIFF_FMU_PROCESS": "out" if own_process else "in"}
    r = subprocess.run([sys.executable, "-c", _INIT, str(unzipped / "modelDescription.xml"), str(unzipped),
                        *([setting] if setting else [])],
                       capture_output=True, text=True,
                       env=env, timeout=120)
    if r.returncode != 0:
        raise RuntimeError(f"{fmu.name}: instantiate + initialize failed: {r.stderr.strip()[-300:]}")
    return float(next(ln for ln in r.stdout.splitlines() if ln.startswith('INIT ')).split()[1])


_PSS = r"""
import os, sys
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave
md = read_model_description(sys.argv[1])
n = int(sys.argv[3])
slaves = []
for i in range(n):
    s = FMU2Slave(guid=md.guid, unzipDirectory=sys.argv[2], modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName=f'i{i}')
    s.instantiate(); s.setupExperiment(startTime=0.0); s.enterInitializationMode(); s.exitInitializationMode()
    s.doStep(0.0, 0.005)
    slaves.append(s)
def pss(pid):
    for line in open(f'/proc/{pid}/smaps_rollup'):
        if line.startswith('Pss:'):
            return int(line.split()[1])
def children(pid):
    out = []
    for t in os.listdir(f'/proc/{pid}/task'):
        out += [int(x) for x in open(f'/proc/{pid}/task/{t}/children').read().split()]
    return out
kids, todo = [], children(os.getpid())   # every model process: the zygote's too (its children)
while todo:
    k = todo.pop()
    kids.append(k)
    todo += children(k)
print('PSS', pss(os.getpid()), *[pss(k) for k in kids])
for s in slaves:
    s.terminate(); s.freeInstance()
"""


def own_process_pss(fmu: Path, unzipped: Path, n: int, env: dict | None = None) -> tuple[float, list[float]]:
    """(the host's PSS, each model process's PSS), MB, with ``n`` own-process instances (none with
    the native start: no model process then)."""
    r = subprocess.run([sys.executable, "-c", _PSS, str(unzipped / "modelDescription.xml"), str(unzipped), str(n)],
                       capture_output=True,
                       text=True, env={**os.environ, **(env or {}), "SPURDIFF_FMU_PROCESS": "out"}, timeout=300)
    if r.returncode != 0:
        raise RuntimeError(f"{fmu.name}: own-process instances failed: {r.stderr.strip()[-300:]}")
    line = next(ln for ln in r.stdout.splitlines() if ln.startswith('PSS '))   # the FMU's log lines too
    kb = [int(x) for x in line.split()[1:]]
    return kb[0] / 1024, [k / 1024 for k in kb[1:]]


def per_step(fmu: Path, unzipped: Path, n: int = 2000, rounds: int = 5,
             env: dict | None = None, width: tuple[int, int] | None = None) -> tuple[float, float]:
    """Microseconds per setReal(all inputs) + doStep + getReal(all outputs), the FMU's defaults, fastest
    of ``rounds`` (``env`` set while the instance is made): through fmpy's Python API (its lists
    converted to C arrays at each call), and through ctypes with the arrays made once (as a master's
    loop or a C host calls: what the FMU itself costs). With ``width`` (inputs, outputs), the FMU's
    inputs and outputs repeated to that many value references per call (FMI lets a vector name a
    variable again): the C FMU asked for as many values as ours, so that fmpy converts as many."""
    with environment(env):
        return _per_step(fmu, unzipped, n, rounds, width)


def _widened(vrs: list[int], count: int) -> list[int]:
    """``vrs`` repeated to ``count`` value references."""
    return [vrs[i % len(vrs)] for i in range(count)]


def _per_step(fmu: Path, unzipped: Path, n: int, rounds: int,
              width: tuple[int, int] | None = None) -> tuple[float, float]:
    from ctypes import c_double, c_uint

    from fmpy import calloc, free, read_model_description
    from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                           fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
    md = read_model_description(str(unzipped / "modelDescription.xml"))
    s = FMU2Slave(guid=md.guid, unzipDirectory=str(unzipped), modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="step")
    cb = fmi2CallbackFunctions()     # the FMU's messages (the defaults' load-capacity warning) not printed
    cb.logger = fmi2CallbackLoggerTYPE(lambda *args: None)
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    s.instantiate(callbacks=cb)
    try:
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()
        reals = [v for v in md.modelVariables if v.type == "Real"]
        ins = [v.valueReference for v in reals if v.causality == "input"]
        outs = [v.valueReference for v in reals if v.causality == "output"]
        if width is not None:
            ins, outs = _widened(ins, width[0]), _widened(outs, width[1])
        values = s.getReal(ins)
        t, best = 0.0, []
        for _ in range(rounds):
            t0 = time.perf_counter()
            for _ in range(n):
                s.setReal(ins, values)
                s.doStep(t, STEP)
                s.getReal(outs)
                t += STEP
            best.append((time.perf_counter() - t0) / n * 1e6)
        vi, xi = (c_uint * len(ins))(*ins), (c_double * len(ins))(*values)
        vo, xo = (c_uint * len(outs))(*outs), (c_double * len(outs))()
        set_real, do_step, get_real, c = s.dll.fmi2SetReal, s.dll.fmi2DoStep, s.dll.fmi2GetReal, s.component
        h, direct = c_double(STEP), []
        for _ in range(rounds):
            t0 = time.perf_counter()
            for _ in range(n):
                set_real(c, vi, len(ins), xi)
                if do_step(c, c_double(t), h, 1) != 0:
                    raise RuntimeError(f"{fmu.name}: fmi2DoStep failed at t = {t}")
                get_real(c, vo, len(outs), xo)
                t += STEP
            direct.append((time.perf_counter() - t0) / n * 1e6)
        s.terminate()
        return min(best), min(direct)
    finally:
        s.freeInstance()


_LONG = r"""
import os, sys, time
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave
md = read_model_description(sys.argv[1])
n = int(sys.argv[3])
s = FMU2Slave(guid=md.guid, unzipDirectory=sys.argv[2], modelIdentifier=md.coSimulation.modelIdentifier,
              instanceName='long')
s.instantiate(); s.setupExperiment(startTime=0.0); s.enterInitializationMode(); s.exitInitializationMode()
ins = [v.valueReference for v in md.modelVariables if v.type == 'Real' and v.causality == 'input']
values = s.getReal(ins)
def pages():
    return int(open('/proc/self/statm').read().split()[1])
p0, t = pages(), 0.0
for _ in range(n):
    s.setReal(ins, values); s.doStep(t, 0.005); t += 0.005
p1 = pages()
t0 = time.perf_counter()
state = s.getFMUstate()
t1 = time.perf_counter()
s.freeFMUstate(state); s.terminate(); s.freeInstance()
print('LONG', (p1 - p0) * os.sysconf('SC_PAGE_SIZE'), t1 - t0)
"""
LONG_STEPS = (1_000, 100_000)    # a short and a long native run before the call that starts the Python


def long_run(fmu: Path, unzipped: Path, steps: int) -> tuple[float, float]:
    """A native start's run of ``steps`` steps at its defaults (every Real input set each step) in a
    fresh fmpy process, the model in the host's: (bytes the host's resident memory grew by over them,
    seconds of the FMU state call after them, which starts the model's Python and hands it the run)."""
    r = subprocess.run([sys.executable, "-c", _LONG, str(unzipped / "modelDescription.xml"), str(unzipped), str(steps)],
                       capture_output=True, text=True, env={**os.environ, "SPURDIFF_FMU_PROCESS": "in"}, timeout=600)
    if r.returncode != 0:
        raise RuntimeError(f"{fmu.name}: a run of {steps} steps failed: {r.stderr.strip()[-300:]}")
    _, grown, took = next(ln for ln in r.stdout.splitlines() if ln.startswith("LONG ")).split()
    return float(grown), float(took)


PYTHON_START = {"SPURDIFF_FMU_START": "python"}
RUNTIME_DIR = "SPURDIFF_FMU_RUNTIME_DIR"   # where the runtime's archives are unpacked (runtime_unpack.h)
# a parameter set to another value: its third start on comes from the start cache (fmu_src/native/fmi/
# native_start.c; the first marks the values seen, the second keeps the model's native start of them)
SETTING = "differential.w_start=4.0"


def measure(ours: Path, theirs: Path, runs: int = 5, before: Path | None = None) -> dict:
    """Every measure for both FMUs, ours with the native start ("ours") and its Python started
    ("python"), and ``before`` (an earlier build of ours, when given), interleaved."""
    tmp = Path(tempfile.mkdtemp(prefix="spurdiff-startup-"))
    try:
        host = _host(tmp)
        fmus = {"ours": ours, "python": ours, "c": theirs,
                **({"before": before, "before_python": before} if before is not None else {})}
        envs = {k: PYTHON_START if k.endswith("python") else {} for k in fmus}
        ourside = [k for k in fmus if k != "c"]
        unz = {}
        for name, f in fmus.items():   # a Python start's column runs on its build's extraction
            if name.endswith("python"):
                unz[name] = unz["ours" if name == "python" else name.removesuffix("_python")]
                continue
            unz[name] = tmp / f"unzipped-{name}"
            subprocess.run(["unzip", "-q", str(f), "-d", str(unz[name])], check=True)
        whole = {k: [] for k in fmus}
        init = {**{k: [] for k in fmus}, **{f"{k}_out": [] for k in ourside}}
        for name in fmus:    # warm the page cache once
            whole_run(fmus[name], host, tmp, envs[name])
        first = []   # a Python start on a machine where the runtime is not unpacked yet: a fresh folder each run
        cached = {"SPURDIFF_FMU_START_CACHE_DIR": str(tmp / "starts")}   # this bench's own cache folder
        for own in (False, False):   # seen, kept
            init_time(ours, unz["ours"], own, cached, SETTING)
        init["cached"], init["cached_out"] = [], []
        for _ in range(runs):
            for name in fmus:
                whole[name].append(whole_run(fmus[name], host, tmp, envs[name]))
                init[name].append(init_time(fmus[name], unz[name], False, envs[name]))
            for name in ourside:
                init[f"{name}_out"].append(init_time(fmus[name], unz[name], True, envs[name]))
            fresh = {**PYTHON_START, RUNTIME_DIR: str(tmp / f"runtime-{len(first)}")}
            first.append(whole_run(ours, host, tmp, fresh))
            shutil.rmtree(fresh[RUNTIME_DIR], ignore_errors=True)
            init["cached"].append(init_time(ours, unz["ours"], False, cached, SETTING))
            init["cached_out"].append(init_time(ours, unz["ours"], True, cached, SETTING))
        from fmpy import read_model_description
        reals = [v for v in read_model_description(str(unz["ours"] / "modelDescription.xml")).modelVariables
                 if v.type == "Real"]
        width = (sum(v.causality == "input" for v in reals), sum(v.causality == "output" for v in reals))
        step = {k: [] for k in (*fmus, "c_wide")}
        for _ in range(2):
            for name in fmus:
                step[name].append(per_step(fmus[name], unz[name], env=envs[name]))
            step["c_wide"].append(per_step(theirs, unz["c"], width=width))
        pss = {k: own_process_pss(fmus[k], unz[k], PSS_INSTANCES, envs[k]) for k in ourside}
        pss["direct"] = own_process_pss(ours, unz["ours"], PSS_INSTANCES, {**PYTHON_START, "SPURDIFF_FMU_ZYGOTE": "0"})
        long = {k: {n: [] for n in LONG_STEPS} for k in ("ours", "before") if k in fmus}
        for _ in range(min(runs, 3)):
            for k, by_steps in long.items():
                for n, seen in by_steps.items():
                    seen.append(long_run(fmus[k], unz[k], n))
        long = {k: {n: (max(x[0] for x in seen), statistics.median(x[1] for x in seen)) for n, seen in by_steps.items()}
                for k, by_steps in long.items()}
        return {"whole": {k: statistics.median(x[0] for x in v) for k, v in whole.items()},
                "first": statistics.median(x[0] for x in first),
                "unzip": {k: statistics.median(x[1] for x in v) for k, v in whole.items()},
                "init": {k: statistics.median(v) for k, v in init.items()},
                "step": {k: min(x[0] for x in v) for k, v in step.items()},
                "direct": {k: min(x[1] for x in v) for k, v in step.items()},
                "pss_host": {k: v[0] for k, v in pss.items()}, "pss": {k: v[1] for k, v in pss.items()},
                "n_in": width[0], "n_out": width[1], "long": long,
                "size": {k: f.stat().st_size for k, f in fmus.items()},
                "files": {k: sum(1 for p in unz[k].rglob("*") if p.is_file()) for k in unz},
                "unpacked": {k: sum(p.stat().st_size for p in unz[k].rglob("*") if p.is_file()) for k in unz}}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _row(label: str, ours: str, python: str, c: str, ratio: str, target: str) -> str:
    return f"   {label:52s}{ours:>12s}{python:>12s}{c:>10s}{ratio:>8s}{target:>10s}"


def _pss(m: dict, k: str) -> str:
    kids = m["pss"][k]
    if not kids:
        return "no model process"
    return (f"{sum(kids) / PSS_INSTANCES:.1f} MB per instance ({len(kids)} processes, {sum(kids):.0f} MB, "
            f"the largest {max(kids):.1f} MB)")


def _lines(m: dict, k: str, fmu: Path, runs: int) -> list[str]:
    """The section's lines for ``k`` ("ours" or "before") of the measures ``m``; for "ours" its Python
    start ("python") beside it."""
    w, i, s, d = m["whole"], m["init"], m["step"], m["direct"]
    p = "python" if k == "ours" else f"{k}_python"
    mb = 1024 * 1024
    ms = "{:.1f} ms".format
    return [f"   {fmu.name} {m['size'][k] / mb:.1f} MiB ({m['files'][k]} files, "
            f"{m['unpacked'][k] / mb:.1f} MiB unpacked) against the C FMU ChkC.fmu "
            f"{m['size']['c'] / 1024:.0f} kB; medians of {runs} interleaved runs (per step: fastest);",
            "   'native': the defaults kept (no Python starts); 'Python': started (SPURDIFF_FMU_START=python), as a run "
            "that sets a parameter to another value starts it at that set the first two times (the third time on, "
            f"'a parameter set, 3rd start on': from the start cache, no Python; {SETTING}); ratio: native / C FMU; per step: every Real "
            f"input set and every Real output read ({m['n_in']} and {m['n_out']}; the C FMU's 1 and 2)",
            _row("", "native", "Python", "C FMU", "ratio", "target"),
            _row("whole run: unzip + C host (load, init, 5 ms step)", ms(w[k] * 1e3), ms(w[p] * 1e3),
                 ms(w["c"] * 1e3), f"{w[k] / w['c']:.1f}", "<= 20x"),
            _row("  of it the unzip", ms(m["unzip"][k] * 1e3), ms(m["unzip"][p] * 1e3), ms(m["unzip"]["c"] * 1e3),
                 f"{m['unzip'][k] / m['unzip']['c']:.1f}", ""),
            *([_row("  the first Python run of a user: runtime unpacked", "", ms(m["first"] * 1e3), "", "", "once")]
              if k == "ours" else []),
            _row("fmpy 3.11, instantiate + initialize, host process", ms(i[k] * 1e3), ms(i[p] * 1e3),
                 ms(i["c"] * 1e3), "", "<= 60 ms"),
            _row("the same, the model in its own process", ms(i[k + "_out"] * 1e3), ms(i[p + "_out"] * 1e3),
                 "", "", "<= 150 ms"),
            *([_row("  a parameter set, 3rd start on, host process", ms(i["cached"] * 1e3), "",
                    "", "", ""),
               _row("  the same, the model in its own process", ms(i["cached_out"] * 1e3), "", "", "", "")]
              if k == "ours" else []),
            _row("per step in fmpy (setReal, doStep, getReal), us", f"{s[k]:.1f}", f"{s[p]:.1f}", f"{s['c']:.1f}",
                 f"{s[k] / s['c']:.1f}", "<= 3x"),
            _row("  the same through ctypes, arrays made once, us", f"{d[k]:.1f}", f"{d[p]:.1f}", f"{d['c']:.1f}",
                 f"{d[k] / d['c']:.1f}", ""),
            _row(f"  the C FMU asked for as many ({m['n_in']} set, {m['n_out']} read), us", f"{s[k]:.1f}", f"{s[p]:.1f}",
                 f"{s['c_wide']:.1f}", f"{s[k] / s['c_wide']:.1f}", ""),
            _row("    the same through ctypes, us", f"{d[k]:.1f}", f"{d[p]:.1f}", f"{d['c_wide']:.1f}",
                 f"{d[k] / d['c_wide']:.1f}", ""),
            *(_row(f"native run of {n:,} steps: host memory grown, MB", f"{m['long'][k][n][0] / 1e6:.1f}", "", "",
                   "", "flat" if n == LONG_STEPS[-1] else "") for n in LONG_STEPS),
            *(_row(f"  then an FMU state call (the Python starts), {n:,}", ms(m["long"][k][n][1] * 1e3), "", "", "",
                   "") for n in LONG_STEPS),
            f"   own-process memory, PSS of every model process / {PSS_INSTANCES} instances in one fmpy host "
            f"(SPURDIFF_FMU_PROCESS=out; target <= 8 MB each): native: {_pss(m, k)}; Python: {_pss(m, p)} "
            f"(host {m['pss_host'][p]:.1f} MB)"
            + (f"; Python, every process started directly (SPURDIFF_FMU_ZYGOTE=0, no zygote): {_pss(m, 'direct')}"
               if k == "ours" else "")]


def report(runs: int = 5, before: Path | None = None) -> list[str]:
    """The section's lines for SpurDifferential as built here; with ``before`` (an earlier build's
    FMU file), its lines after them, measured in the same interleaved runs."""
    from harness.build.fmu import build

    theirs = c_fmu()
    if theirs is None:
        return ["   not measured: the plain C FMU (tests/broken_fmus/chkc.c) or gcc is not here"]
    ours = build(["SpurDifferential"], quiet=True)[0]
    try:
        m = measure(ours, theirs, runs, before)
    except (RuntimeError, OSError, subprocess.SubprocessError) as e:   # said in the report, not fatal to the bench
        return [f"   not measured: {type(e).__name__}: {str(e)[-300:]}"]
    lines = _lines(m, "ours", ours, runs)
    if before is not None:
        lines += [f"   the same runs, interleaved, of the earlier build {before}:", *_lines(m, "before", before, runs)]
    return lines
