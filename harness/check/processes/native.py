"""The binary outside Python (rules of kind ``load``): does the FMU's shared library load and run in a
plain C process with a bare environment, and does it declare the libraries it uses?

The kit's own processes are Python: whatever Python has loaded (libm, libpthread, libpython) is there
for the FMU too, so an FMU can pass every call-sequence rule and still not load in a C importer
(fmuCheck, fmusim, a simulator). Two rules look at that:

* ``load.needed-libraries`` reads the ELF file (64-bit little-endian, Linux): every undefined global
  symbol of its dynamic symbol table must be defined by a library of its DT_NEEDED tree, each found
  the way the dynamic loader finds it (DT_RPATH / DT_RUNPATH with $ORIGIN, the ld.so cache, the
  default folders; no LD_LIBRARY_PATH, as in a bare environment);
* ``load.bare-process`` compiles :data:`HOST_SOURCE` with ``cc`` once per kit run (SKIP, with the
  reason, when there is no compiler) and runs it with an empty environment (``env -i``): dlopen with
  RTLD_NOW, fmi2Instantiate, fmi2SetupExperiment, initialization, 3 doSteps, fmi2Terminate,
  fmi2FreeInstance (model exchange only: through initialization). A crash or a hang names the call.

(Just over 400 lines: about 85 of them are the C host it compiles, kept as text beside the rule that
runs it.)
"""
from __future__ import annotations

import functools
import hashlib
import os
import shutil
import signal
import struct
import subprocess
import tempfile
import time
from pathlib import Path

from ..archive import ArchiveError, extract
from ..report import FAIL, PASS, SKIP, CheckResult
from ..rules import BY_ID

HOST_STEPS = 3

HOST_SOURCE = r"""
/* spurdiff check: load.bare-process. Opens an FMI 2.0 binary and runs the basic call sequence. */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef void *C;
typedef struct {
    void (*logger)(void *, const char *, int, const char *, const char *, ...);
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(void *, int);
    void *componentEnvironment;
} Callbacks;

static void logger(void *env, const char *name, int status, const char *cat, const char *msg, ...) {
    va_list ap;
    (void)env;
    fprintf(stderr, "[%s %d %s] ", name ? name : "", status, cat ? cat : "");
    va_start(ap, msg);
    vfprintf(stderr, msg, ap);
    va_end(ap);
    fputc('\n', stderr);
}

static void call(const char *what) { printf("CALL %s\n", what); fflush(stdout); }

static int ok(const char *what, int status) {
    if (status > 1) { printf("FAIL %s returned %d\n", what, status); fflush(stdout); return 0; }
    return 1;
}

#define SYM(T, n) T n = (T)dlsym(lib, #n); \
    if (!n) { printf("FAIL dlsym(%s): not exported\n", #n); return 3; }

int main(int argc, char **argv) {
    typedef C (*inst_t)(const char *, int, const char *, const char *, const Callbacks *, int, int);
    typedef int (*setup_t)(C, int, double, double, int, double);
    typedef int (*c_t)(C);
    typedef int (*step_t)(C, double, double, int);
    typedef void (*free_t)(C);
    Callbacks cb = {logger, calloc, free, NULL, NULL};
    void *lib;
    C c;
    int cs, i, n;
    double t, h;
    if (argc != 9) { fprintf(stderr, "usage: host binary cs|me guid resourceURI name t0 h steps\n"); return 2; }
    cs = strcmp(argv[2], "cs") == 0;
    t = atof(argv[6]); h = atof(argv[7]); n = atoi(argv[8]);
    call("dlopen(RTLD_NOW)");
    lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) { printf("FAIL dlopen: %s\n", dlerror()); return 3; }
    {
        SYM(inst_t, fmi2Instantiate) SYM(setup_t, fmi2SetupExperiment) SYM(c_t, fmi2EnterInitializationMode)
        SYM(c_t, fmi2ExitInitializationMode) SYM(c_t, fmi2Terminate) SYM(free_t, fmi2FreeInstance)
        call("fmi2Instantiate");
        c = fmi2Instantiate(argv[5], cs ? 1 : 0, argv[3], argv[4], &cb, 0, 0);
        if (!c) { printf("FAIL fmi2Instantiate returned NULL\n"); return 1; }
        call("fmi2SetupExperiment");
        if (!ok("fmi2SetupExperiment", fmi2SetupExperiment(c, 0, 0.0, t, 0, 0.0))) return 1;
        call("fmi2EnterInitializationMode");
        if (!ok("fmi2EnterInitializationMode", fmi2EnterInitializationMode(c))) return 1;
        call("fmi2ExitInitializationMode");
        if (!ok("fmi2ExitInitializationMode", fmi2ExitInitializationMode(c))) return 1;
        if (cs) {
            SYM(step_t, fmi2DoStep)
            for (i = 0; i < n; i++, t += h) {
                char what[96];
                snprintf(what, sizeof what, "fmi2DoStep(t=%g, h=%g)", t, h);
                call(what);
                if (!ok(what, fmi2DoStep(c, t, h, 1))) return 1;
            }
        }
        call("fmi2Terminate");
        if (!ok("fmi2Terminate", fmi2Terminate(c))) return 1;
        call("fmi2FreeInstance");
        fmi2FreeInstance(c);
    }
    call("done");
    printf("OK\n");
    return 0;
}
"""


# ----------------------------------------------------------------------------- the C host

@functools.lru_cache(maxsize=1)
def host_binary() -> tuple[Path | None, str]:
    """(the compiled host, "") or (None, why it could not be compiled or kept). Compiled once per
    source version into the user's private cache (:mod:`harness.common.private_dir`:
    ``<cache>/check-host-<digest>/host``, the folder 0700, owner and mode checked before use), and
    run only when its sha256 is the one recorded beside it when it was compiled."""
    from harness.common.private_dir import PrivatePlaceError, cache_dir, sha256_of, verified_file, write_private
    cc = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if cc is None:
        return None, "no C compiler (cc, gcc or clang) on PATH to build the bare C host"
    digest = hashlib.sha256(HOST_SOURCE.encode()).hexdigest()[:12]
    try:
        folder = cache_dir(f"check-host-{digest}")
    except PrivatePlaceError as e:
        return None, str(e)
    target, recorded = folder / "host", folder / "host.sha256"
    try:
        want = recorded.read_text().strip() if recorded.is_file() and not recorded.is_symlink() else ""
    except OSError:
        want = ""
    if want and verified_file(target, want):
        return target, ""
    src = folder / f"host-{os.getpid()}.c"
    write_private(src, HOST_SOURCE.encode())
    tmp = folder / f"host-{os.getpid()}"
    r = subprocess.run([cc, "-O1", "-o", str(tmp), str(src), "-ldl"], capture_output=True, text=True)
    src.unlink(missing_ok=True)
    if r.returncode != 0:
        return None, f"{cc} could not build the bare C host: {' '.join(r.stderr.split())[:200]}"
    write_private(recorded, sha256_of(tmp).encode())
    os.replace(tmp, target)
    return target, ""


def run_bare_host(binary: Path, kind: str, guid: str, resources: Path, t0: float, h: float,
                  timeout: float) -> tuple[str, str]:
    """(status, reason) of the C host on ``binary`` in an empty environment."""
    host, why = host_binary()
    if host is None:
        return SKIP, why
    work = Path(tempfile.mkdtemp(prefix="spurdiff-bare-"))
    out, err = work / "stdout.txt", work / "stderr.txt"
    from .isolation import end_reaped, reaped
    cmd, done = reaped([str(host), str(binary), kind, guid, resources.as_uri(), "bare", repr(t0), repr(h),
                        str(HOST_STEPS)], work)   # under the subreaper: nothing the FMU starts outlives it
    try:
        with open(out, "wb") as fo, open(err, "wb") as fe:
            proc = subprocess.Popen(cmd, env={}, cwd=work, stdin=subprocess.DEVNULL, stdout=fo, stderr=fe,
                                    start_new_session=True)
            try:
                rc = proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                rc = None
            finally:
                escaped = end_reaped(proc, done)
                try:
                    os.killpg(proc.pid, signal.SIGKILL)
                except OSError:
                    pass
        if escaped and rc is not None:
            return FAIL, f"in a C process with an empty environment: {escaped}"
        lines = out.read_text(errors="replace").splitlines()
        calls = [ln[5:] for ln in lines if ln.startswith("CALL ")]
        fails = [ln[5:] for ln in lines if ln.startswith("FAIL ")]
        last = calls[-1] if calls else "start"
        tail = " / ".join(ln.strip() for ln in err.read_text(errors="replace").splitlines()[-2:] if ln.strip())
        said = f"; stderr: {tail[:240]}" if tail else ""
        where = f"a C process with an empty environment (env -i {host.name} ...)"
        if rc is None:
            return FAIL, f"in {where}: timed out after {timeout:g} s in {last}{said}"
        if rc < 0:
            try:
                sig = signal.Signals(-rc).name
            except ValueError:
                sig = f"signal {-rc}"
            return FAIL, f"in {where}: crashed ({sig}) in {last}{said}"
        if fails or rc != 0:
            what = fails[0] if fails else f"exit status {rc} in {last}"
            return FAIL, f"in {where}: {what}{said}"
        steps = f", {HOST_STEPS} doSteps of {h:g} s" if kind == "cs" else ""
        return PASS, (f"dlopen (RTLD_NOW), fmi2Instantiate ({'co-simulation' if kind == 'cs' else 'model exchange'}), "
                      f"initialization{steps}, fmi2Terminate, fmi2FreeInstance in {where}")
    finally:
        shutil.rmtree(work, ignore_errors=True)


# ----------------------------------------------------------------------------- ELF

class ElfError(ValueError):
    pass


SHT_DYNAMIC, SHT_DYNSYM = 6, 11
DT_NEEDED, DT_RPATH, DT_RUNPATH = 1, 15, 29
STB_GLOBAL, STB_WEAK, STB_GNU_UNIQUE = 1, 2, 10


def read_elf(path: str | Path) -> dict:
    """{"needed", "rpath", "runpath", "undefined", "defined"} of a 64-bit little-endian ELF file."""
    data = Path(path).read_bytes()
    if data[:4] != b"\x7fELF":
        raise ElfError("not an ELF file")
    if data[4] != 2 or data[5] != 1:
        raise ElfError("not a 64-bit little-endian ELF file (only those are read)")
    e_shoff, = struct.unpack_from("<Q", data, 0x28)
    e_shentsize, e_shnum, e_shstrndx = struct.unpack_from("<HHH", data, 0x3A)
    sections = [struct.unpack_from("<IIQQQQIIQQ", data, e_shoff + i * e_shentsize) for i in range(e_shnum)]

    def strings(idx: int):
        off, size = sections[idx][4], sections[idx][5]
        blob = data[off:off + size]
        return lambda o: blob[o:blob.index(b"\0", o)].decode("utf-8", "replace")

    out = {"needed": [], "rpath": [], "runpath": [], "undefined": set(), "defined": set()}
    for name, typ, flags, addr, off, size, link, info, align, entsize in sections:
        if typ == SHT_DYNAMIC:
            s = strings(link)
            for k in range(size // 16):
                tag, val = struct.unpack_from("<qQ", data, off + 16 * k)
                if tag == DT_NEEDED:
                    out["needed"].append(s(val))
                elif tag == DT_RPATH:
                    out["rpath"] += s(val).split(":")
                elif tag == DT_RUNPATH:
                    out["runpath"] += s(val).split(":")
        elif typ == SHT_DYNSYM:
            s = strings(link)
            for k in range(1, size // 24):
                st_name, st_info, st_other, st_shndx, value, sz = struct.unpack_from("<IBBHQQ", data, off + 24 * k)
                bind = st_info >> 4
                if not st_name:
                    continue
                if st_shndx == 0:
                    if bind == STB_GLOBAL:
                        out["undefined"].add(s(st_name))
                elif bind in (STB_GLOBAL, STB_WEAK, STB_GNU_UNIQUE):
                    out["defined"].add(s(st_name))
    return out


@functools.lru_cache(maxsize=1)
def _ld_cache() -> dict[str, str]:
    """soname -> path from ``ldconfig -p`` (64-bit x86 entries), {} without ldconfig."""
    exe = shutil.which("ldconfig") or ("/sbin/ldconfig" if Path("/sbin/ldconfig").exists() else None)
    if exe is None:
        return {}
    try:
        text = subprocess.run([exe, "-p"], capture_output=True, text=True, timeout=20).stdout
    except (OSError, subprocess.SubprocessError):
        return {}
    cache: dict[str, str] = {}
    for line in text.splitlines()[1:]:
        if "=>" not in line or "x86-64" not in line:
            continue
        name = line.strip().split(" ", 1)[0]
        cache.setdefault(name, line.rsplit("=>", 1)[1].strip())
    return cache


DEFAULT_DIRS = ("/lib/x86_64-linux-gnu", "/usr/lib/x86_64-linux-gnu", "/lib64", "/usr/lib64", "/lib", "/usr/lib")


def _find_library(name: str, origin: Path, rpath: list[str], runpath: list[str]) -> Path | None:
    if "/" in name:
        p = Path(name)
        return p if p.is_file() else None
    dirs = ([] if runpath else rpath) + runpath
    for d in dirs:
        p = Path(d.replace("$ORIGIN", str(origin)).replace("${ORIGIN}", str(origin))) / name
        if p.is_file():
            return p
    if name in _ld_cache():
        return Path(_ld_cache()[name])
    for d in DEFAULT_DIRS:
        p = Path(d) / name
        if p.is_file():
            return p
    return None


SUSPECTS = ("libm.so.6", "libpthread.so.0", "libdl.so.2", "librt.so.1", "libstdc++.so.6", "libgcc_s.so.1", "libz.so.1")


def unresolved_symbols(binary: Path) -> tuple[list[str], list[str], list[str]]:
    """(undefined symbols no library of the NEEDED tree defines, NEEDED libraries not found, the
    libraries searched)."""
    elf = read_elf(binary)
    defined: set[str] = set()
    missing_libs: list[str] = []
    seen: dict[str, Path] = {}
    queue = [(n, binary.parent, elf["rpath"], elf["runpath"]) for n in elf["needed"]]
    while queue:
        name, origin, rpath, runpath = queue.pop(0)
        if name in seen:
            continue
        path = _find_library(name, origin, rpath, runpath)
        if path is None:
            missing_libs.append(name)
            seen[name] = Path("?")
            continue
        seen[name] = path
        try:
            sub = read_elf(path)
        except (ElfError, OSError, struct.error):
            continue
        defined |= sub["defined"]
        queue += [(n, path.parent, sub["rpath"] or rpath, sub["runpath"]) for n in sub["needed"]]
    undefined = sorted(elf["undefined"] - defined - elf["defined"])
    return undefined, missing_libs, list(seen)


def _who_defines(symbols: list[str]) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for lib in SUSPECTS:
        path = _ld_cache().get(lib) or next((str(Path(d) / lib) for d in DEFAULT_DIRS if (Path(d) / lib).is_file()), None)
        if not path:
            continue
        try:
            d = read_elf(path)["defined"]
        except (ElfError, OSError, struct.error):
            continue
        for sym in symbols:
            if sym in d:
                out.setdefault(lib, []).append(sym)
    return out


def check_needed_libraries(binary: Path) -> tuple[str, str]:
    try:
        undefined, missing_libs, searched = unresolved_symbols(binary)
    except ElfError as e:
        return SKIP, f"{binary.name}: {e}"
    needed = ", ".join(searched) or "none"
    if not undefined and not missing_libs:
        return PASS, f"every undefined symbol of {binary.name} is defined by its declared libraries (NEEDED: {needed})"
    parts = []
    if missing_libs:
        parts.append(f"NEEDED librar{'y' if len(missing_libs) == 1 else 'ies'} not found: {', '.join(missing_libs)}")
    if undefined:
        owners = _who_defines(undefined)
        named = "; ".join(f"{', '.join(syms[:6])}{' ...' if len(syms) > 6 else ''} from {lib}, which it does not "
                          f"declare" for lib, syms in owners.items())
        rest = [u for u in undefined if not any(u in syms for syms in owners.values())]
        parts.append(f"{len(undefined)} undefined symbol(s) no declared library defines"
                     + (f": {named}" if named else "")
                     + (f"{'; ' if named else ': '}{', '.join(rest[:8])}{' ...' if len(rest) > 8 else ''}" if rest else ""))
    return FAIL, (f"{binary.name} (NEEDED: {needed}): " + "; ".join(parts)
                  + ": it loads only into a process that already has them")


def check_libraries_found(binary: Path) -> tuple[str, str]:
    """``load.libraries``: every DT_NEEDED library (and theirs) found, in the FMU or on this machine."""
    try:
        _, missing_libs, searched = unresolved_symbols(binary)
    except (ElfError, OSError, struct.error) as e:
        return SKIP, f"{binary.name}: {e}"
    if missing_libs:
        return FAIL, (f"{binary.name} needs {', '.join(missing_libs)}, found neither in the FMU (RPATH/RUNPATH) nor "
                      f"on this machine: the binary cannot be loaded here, no FMI call was made")
    return PASS, f"every library {binary.name} needs is found ({', '.join(searched) or 'none declared'})"


# ----------------------------------------------------------------------------- the rules

LOAD3 = {"load3.libraries": "load.libraries", "load3.needed-libraries": "load.needed-libraries"}


def run_load_checks(fmu_path: str | Path, subject: str, rule_ids, timeout: float,
                    profiles: tuple[str, ...] = ()) -> list[CheckResult]:
    """The ``load`` rules in ``rule_ids`` for one FMU (parent side; the C host is its own process)."""
    from fmpy import read_model_description
    from ..static import host_platform
    results = []
    ids = [r for r in ("load.libraries", "load.needed-libraries", "load.bare-process", *LOAD3) if r in rule_ids]
    if not ids:
        return results

    def res(rid, status, reason, t0):
        return CheckResult(subject, rid, status, reason, time.perf_counter() - t0, BY_ID[rid].effective_severity(profiles))

    t0 = time.perf_counter()
    try:
        unzipdir = extract(fmu_path)
    except ArchiveError as e:
        return [res(r, FAIL, f"the FMU could not be unpacked: {e}", t0) for r in ids]
    try:
        md = read_model_description(str(unzipdir), validate=False)
        plat, ext = host_platform()
        if str(md.fmiVersion).startswith("3"):   # FMI 3.0: binaries/<platform tuple>/ (2.5.1.4)
            from fmpy import platform_tuple as plat
        kind = "cs" if md.coSimulation is not None else "me"
        iface = md.coSimulation if kind == "cs" else md.modelExchange
        binary = unzipdir / "binaries" / plat / f"{iface.modelIdentifier}{ext}"
        de = md.defaultExperiment
        t_start = float(de.startTime) if de is not None and de.startTime is not None else 0.0
        h = float(de.stepSize) if de is not None and de.stepSize is not None and float(de.stepSize) > 0 else 1e-3
        for rid in ids:
            t1 = time.perf_counter()
            what = LOAD3.get(rid, rid)   # an FMI 3.0 load rule checks what its FMI 2.0 twin checks
            if not binary.is_file():
                results.append(res(rid, SKIP, f"no {binary.relative_to(unzipdir)}", t1))
            elif what == "load.needed-libraries":
                results.append(res(rid, *check_needed_libraries(binary), t1))
            elif what == "load.libraries":
                results.append(res(rid, *check_libraries_found(binary), t1))
            else:
                results.append(res(rid, *run_bare_host(binary, kind, md.guid, unzipdir / "resources", t_start, h,
                                                       timeout), t1))
    finally:
        shutil.rmtree(unzipdir, ignore_errors=True)
    return results
