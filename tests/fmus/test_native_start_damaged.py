"""The native start with a damaged resources/native_start.bin (fmu_src/native/fmi/native_start.c: the
digest, then the layout's own checks): truncated, extended, one byte changed anywhere, counts, lengths,
references, slots and kinds made impossible behind a matching digest. Each time: the warning, then the
Python start giving exactly the numbers and messages of SPURDIFF_FMU_START=python; never a crash, an
endless loop or a silent other answer. Each host runs in a process of its own (a crash is a failure
here, not the end of the test run). (The calls at the edges: test_native_start_edges.py.)"""
from __future__ import annotations

import os
import struct
import subprocess
import sys
import textwrap

import pytest

_RUN = textwrap.dedent("""
    import json, os, struct, sys
    from fmpy import read_model_description
    from harness.fmi.instance import Instance
    d = sys.argv[1]
    md = read_model_description(d)
    inst = Instance("ns", None, unzipdir=d, md=md)
    outs = [v.valueReference for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    inst.slave.exitInitializationMode()
    res = []
    for k in range(5):
        inst.slave.doStep(k * 1e-3, 1e-3)
        res.append([struct.pack("<d", x).hex() for x in inst.slave.getReal(outs)])
    after = []
    if sys.argv[2:] == ["state"]:   # a call that starts the Python, then one more of each kind
        f = lambda name, *a: int(inst.c_function(name)(inst.component, *a))
        from ctypes import byref, c_double, c_size_t, c_uint, c_void_p
        st, vals = c_void_p(), (c_double * 1)()
        after = [f("fmi2GetFMUstate", byref(st)), f("fmi2DoStep", c_double(5e-3), c_double(1e-3), 1),
                 f("fmi2GetReal", (c_uint * 1)(outs[0]), c_size_t(1), vals), f("fmi2Terminate")]
    inst.close()
    print(json.dumps({"values": res, "messages": inst.messages, "after": after}))
""")


def _damaged_run(unzipdir, mode, *more):
    import json

    env = {**os.environ, "SPURDIFF_FMU_START": mode}
    r = subprocess.run([sys.executable, "-c", _RUN, unzipdir, *more], capture_output=True, text=True, env=env,
                       timeout=120)
    assert r.returncode == 0, f"the host died ({r.returncode}): {r.stderr[-2000:]}"
    return json.loads(r.stdout.strip().splitlines()[-1])


def _corruptions(data: bytes) -> dict:
    n = len(data)
    u32 = lambda x: struct.pack("<I", x)  # noqa: E731
    cuts = {"0": 0, "3": 3, "4": 4, "8": 8, "12": 12, "16": 16, "20": 20, "quarter": n // 4, "half": n // 2,
            "end-8": n - 8, "end-1": n - 1}
    out = {f"truncated-{k}": data[:at] for k, at in cuts.items()}
    out["appended"] = data + b"\0"
    out["libs-huge"] = data[:12] + u32(0xFFFFFFFF) + data[16:]
    out["libs-zero"] = data[:12] + u32(0) + data[16:]
    out["lib-name-length-huge"] = data[:16] + u32(0xFFFFFFFF) + data[20:]
    out["lib-name-length-1"] = data[:16] + u32(1) + data[20:]
    out["format"] = data[:4] + u32(99) + data[8:]
    for k in range(1, 12):      # one byte changed anywhere: a value, a count, a reference, a message
        at = k * n // 12
        out[f"byte-{k}-of-12"] = data[:at] + bytes([data[at] ^ 0x5A]) + data[at + 1:]
    return out


@pytest.fixture(scope="module")
def pristine(differential_fmu, tmp_path_factory):
    from fmpy import extract

    d = extract(str(differential_fmu), str(tmp_path_factory.mktemp("pristine")))
    with open(os.path.join(d, "resources", "native_start.bin"), "rb") as f:
        data = f.read()
    return d, data, _damaged_run(d, "python")


def test_the_file_as_built_runs_without_a_warning(pristine):
    """The control: the same host on the file as built starts natively, no warning, the same numbers."""
    d, _, python = pristine
    got = _damaged_run(d, "auto")
    assert not [t for _, t in got["messages"] if "native start" in t]
    assert got == python


@pytest.mark.parametrize("case", list(_corruptions(b"\0" * 1200)))
def test_a_damaged_native_start_warns_and_starts_the_python(pristine, tmp_path, case):
    """Truncated, extended, a count or a length made huge, one byte changed anywhere: the warning and the
    Python start, never a crash, never a silent other answer."""
    import shutil

    d, data, python = pristine
    mine = str(tmp_path / "fmu")
    shutil.copytree(d, mine)
    with open(os.path.join(mine, "resources", "native_start.bin"), "wb") as f:
        f.write(_corruptions(data)[case])
    got = _damaged_run(mine, "auto")
    warned = [t for s, t in got["messages"] if "the native start is not used" in t]
    assert len(warned) == 1, got["messages"][:3]
    assert got["values"] == python["values"]
    assert [m for m in got["messages"] if "the native start is not used" not in m[1]] == python["messages"]


def _layout(data: bytes) -> dict:
    """Where the counts and the first variable's fields are in a native_start.bin (native_start.py's order)."""
    at = [8]

    def u32():
        at[0] += 4
        return struct.unpack_from("<I", data, at[0] - 4)[0]

    def skip(n):
        at[0] += n

    def text():
        skip(u32())

    u32()                                   # early
    for _ in range(u32()):                  # libraries
        text()
    for _ in range(u32()):                  # checks
        u32(), text(), skip(8)
    u32(), text(), u32()                    # the function, direct
    out = {"n_fields": at[0]}
    for _ in range(u32()):
        kind = u32()
        if kind == 1:
            skip(8 * u32())
        elif kind == 2:
            u32(), text()
    out["nv"] = at[0]
    nv = u32()
    skip(8 * nv)
    u32()                                   # n_in
    out["n_vars"] = at[0]
    u32()
    out["kind"], out["vr"], out["slot"] = at[0], at[0] + 4, at[0] + 12
    out["nv_value"] = nv
    # the messages' count: after every variable
    for _ in range(struct.unpack_from("<I", data, out["n_vars"])[0]):
        kind = u32()
        skip(12 + 16)
        for _ in range(3):
            text() if kind == 3 else skip(8)
    out["n_msgs"] = at[0]
    u32()
    out["msg_phase"], out["msg_status"] = at[0], at[0] + 4
    return out


def _redigested(data: bytes, changes: dict) -> bytes:
    from spurdiff.fmi.native_start import digest

    body = bytearray(data[:-8])
    for at, x in changes.items():
        struct.pack_into("<I", body, at, x & 0xFFFFFFFF)
    return bytes(body) + struct.pack("<Q", digest(bytes(body)))


LAYOUT_DAMAGE = {
    "vr-max": lambda L: {L["vr"]: 0xFFFFFFFF},
    "vr-past-the-bound": lambda L: {L["vr"]: 1 << 20},
    "kind-7": lambda L: {L["kind"]: 7},
    "kind-negative": lambda L: {L["kind"]: 0xFFFFFFFF},
    "slot-past-v": lambda L: {L["slot"]: L["nv_value"]},
    "slot-huge": lambda L: {L["slot"]: 0x7FFFFFFF},
    "input-without-slot": lambda L: {L["slot"]: 0xFFFFFFFF},
    "n-vars-huge": lambda L: {L["n_vars"]: 0xFFFFFFFF},
    "n-vars-zero": lambda L: {L["n_vars"]: 0},
    "nv-huge": lambda L: {L["nv"]: 0xFFFFFFFF},
    "n-fields-33": lambda L: {L["n_fields"]: 33},
    "n-msgs-huge": lambda L: {L["n_msgs"]: 0xFFFFFFFF},
    "msg-phase-huge": lambda L: {L["msg_phase"]: 0xFFFFFFFF},
    "msg-status-huge": lambda L: {L["msg_status"]: 0xFFFFFFFF},
}


@pytest.mark.parametrize("case", list(LAYOUT_DAMAGE))
def test_a_bad_layout_behind_a_good_digest_warns_and_starts_the_python(pristine, tmp_path, case):
    """A file whose digest matches but whose numbers do not hold together (as a faulty writer would make
    it): refused by the reader's own checks, never a crash, an endless loop or a huge allocation."""
    import shutil

    d, data, python = pristine
    assert _layout(data)["nv_value"] > 0
    mine = str(tmp_path / "fmu")
    shutil.copytree(d, mine)
    with open(os.path.join(mine, "resources", "native_start.bin"), "wb") as f:
        f.write(_redigested(data, LAYOUT_DAMAGE[case](_layout(data))))
    got = _damaged_run(mine, "auto")
    warned = [t for s, t in got["messages"] if "the native start is not used" in t]
    assert len(warned) == 1 and "native_start.bin is damaged (bad layout)" in warned[0], got["messages"][:3]
    assert got["values"] == python["values"]


def test_a_start_that_disagrees_with_its_python_is_an_error_at_the_promotion(pristine, tmp_path):
    """A file whose state values do not belong to its model (a faulty writer, the digest matching): the
    native steps differ from the Python's (undetectable then); the first call that starts the Python
    replays them, finds an output that differs, and fails with the reason; every later call fails (an
    error, never a crash, never the Python's numbers mixed with the native ones)."""
    import shutil

    d, data, python = pristine
    L = _layout(data)
    body = bytearray(data[:-8])
    at = L["nv"] + 4
    v = struct.unpack_from(f"<{L['nv_value']}d", body, at)
    struct.pack_into(f"<{L['nv_value']}d", body, at, *[x * 1.5 + 0.25 for x in v])
    from spurdiff.fmi.native_start import digest
    mine = str(tmp_path / "fmu")
    shutil.copytree(d, mine)
    with open(os.path.join(mine, "resources", "native_start.bin"), "wb") as f:
        f.write(bytes(body) + struct.pack("<Q", digest(bytes(body))))
    got = _damaged_run(mine, "auto", "state")
    assert got["values"] != python["values"], "the changed state shows in the native steps"
    assert got["after"] == [3, 3, 3, 3]
    errors = [t for s, t in got["messages"] if s == 3]
    assert len(errors) == 1 and "starting the model's Python after the native start (5 steps)" in errors[0]
    assert "natively" in errors[0], errors[0]



_PROBE = r"""
#include <stdio.h>
#include "native_start.h"
static void lg(fmi2ComponentEnvironment e, fmi2String n, fmi2Status s, fmi2String c, fmi2String m, ...)
{ (void)e; (void)n; (void)s; (void)c; (void)m; }
/* argv[1]: a resources folder; argv[2..]: files each copied there as native_start.bin, opened, used, freed */
int main(int argc, char **argv)
{
    fmi2CallbackFunctions cb = {lg, 0, 0, 0, 0};
    char err[2048], path[4096], buf[1 << 16];
    fmi2ValueReference vr[256];
    double v[1];
    int iv[1], opened = 0;
    fmi2String sv[1];
    for (int i = 0; i < 256; i++) vr[i] = (fmi2ValueReference)i;
    snprintf(path, sizeof path, "%s/native_start.bin", argv[1]);
    for (int f = 2; f < argc; f++) {
        FILE *in = fopen(argv[f], "rb"), *out = fopen(path, "wb");
        size_t n;
        while ((n = fread(buf, 1, sizeof buf, in)) > 0) fwrite(buf, 1, n, out);
        fclose(in);
        fclose(out);
        NsInst *I = NULL;
        if (ns_open(argv[1], "probe", &cb, 1, &I, err, sizeof err) != 1) continue;
        opened++;
        ns_setup_experiment(I, 0, 0.0, 0.0, 0, 0.0);
        ns_enter_initialization_mode(I);
        ns_get_real(I, vr, 1, v);
        ns_exit_initialization_mode(I);
        for (int k = 0; k < 3; k++) ns_do_step(I, k * 1e-3, 1e-3, 1, 0, NULL);
        for (int i = 0; i < 256; i++) {
            ns_get_real(I, vr + i, 1, v);
            ns_get_integer(I, vr + i, 1, iv);
            ns_get_boolean(I, vr + i, 1, iv);
            ns_get_string(I, vr + i, 1, sv);
        }
        ns_free(I);
    }
    printf("%d\n", opened);
    return 0;
}
"""


def test_the_reader_under_address_sanitizer(pristine, tmp_path):
    """native_start.c built with AddressSanitizer and UBSan reads 300 files changed at random behind a
    matching digest (bytes, counts set to 0, 2^31, 2^32 - 1, ..., cuts) and 9 with a count made huge (the
    variables, the messages, the array v): no invalid access, no undefined
    behaviour, no allocation the file's size does not justify (ASan aborts past its limit)."""
    import random
    import shutil

    from harness.build.fmu import NATIVE_FMI, _fmi2_headers
    from spurdiff.fmi.native_start import digest

    d, data, _ = pristine
    exe = tmp_path / "probe"
    (tmp_path / "probe.c").write_text(_PROBE)
    r = subprocess.run(["gcc", "-g", "-O1", "-fsanitize=address,undefined", "-fno-sanitize-recover=all",
                        f"-I{_fmi2_headers()}", f"-I{NATIVE_FMI}", str(tmp_path / "probe.c"),
                        str(NATIVE_FMI / "native_start.c"), "-o", str(exe), "-ldl", "-lm"], capture_output=True,
                       text=True)
    if r.returncode != 0:
        pytest.skip(f"no compiler with the sanitizers here: {r.stderr[-300:]}")
    res = tmp_path / "resources"
    shutil.copytree(os.path.join(d, "resources"), res, ignore=shutil.ignore_patterns("python*"))
    rnd = random.Random(44)
    body0, files = data[:-8], []
    for k in range(300):
        b = bytearray(body0)
        pick = rnd.random()
        if pick < 0.4:
            for _ in range(rnd.randint(1, 4)):
                b[rnd.randrange(8, len(b))] = rnd.randrange(256)
        elif pick < 0.8:
            x = rnd.choice([0, 1, 2, 3, 31, 32, 33, 0x7FFFFFFF, 0x80000000, 0xFFFFFFFF, rnd.randrange(1 << 32)])
            struct.pack_into("<I", b, rnd.randrange(8, len(b) - 4) & ~3, x)
        else:
            b = b[:rnd.randrange(8, len(b))]
        f = tmp_path / f"m{k}.bin"
        f.write_bytes(bytes(b) + struct.pack("<Q", digest(bytes(b))))
        files.append(str(f))
    L = _layout(data)
    for k, (at, x) in enumerate((at, x) for at in (L["n_vars"], L["n_msgs"], L["nv"])
                                for x in (0xFFFFFFFF, 0x10000000, 0x01000000)):
        f = tmp_path / f"count{k}.bin"
        f.write_bytes(_redigested(data, {at: x}))
        files.append(str(f))
    files.append(str(tmp_path / "pristine.bin"))
    (tmp_path / "pristine.bin").write_bytes(data)
    r = subprocess.run([str(exe), str(res), *files], capture_output=True, text=True, errors="replace", timeout=600,
                       env={**os.environ, "ASAN_OPTIONS": "detect_leaks=1:allocator_may_return_null=0"})
    assert r.returncode == 0 and "runtime error" not in r.stderr, r.stderr[-3000:]
    assert int(r.stdout.split()[-1]) >= 1, "the file as built opens (the probe works)"
