"""What an FMU carries, platform by platform (issue 44 item 1), for :mod:`harness.build.fmu`: the platforms
chosen (``spurdiff build --platforms``) and each one's size in an archive; the runtimes' files as
stored archives; the default gear set's form radii computed at build time, so that the FMU's
default configuration starts without generating its gears.
"""
from __future__ import annotations

import hashlib
import io
import json
import os
import zipfile
from pathlib import Path

from harness.build import runtime_bundle, runtime_win64


class BuildError(RuntimeError):
    """An FMU cannot be built (harness.build.fmu raises and exports it)."""


def _entry(name: str, mode: int = 0o644) -> zipfile.ZipInfo:
    """A deflated archive entry ``name`` with the unix permissions ``mode`` (0o755: executable)."""
    info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
    info.compress_type = zipfile.ZIP_DEFLATED
    info.external_attr = (0o100000 | mode) << 16
    return info


# the package's files an FMU carries beside its package archive, not in it: its compiled kernels (a
# shared library cannot be loaded from inside an archive; spurdiff.native_library.shipped_folder)
KERNEL_SUFFIXES = (".so", ".dll")


def package_archive(pkg: Path) -> bytes:
    """The staged, byte-compiled package folder ``pkg`` as the archive an FMU carries
    (``resources/<pkg.name>.zip``, which the bridge imports with zipimport): its sources, data and
    pycs, each pyc beside its source (``m.pyc``, where zipimport looks), in name order with a fixed
    date: the same bytes for the same package. The pycs are unchecked (hash-based: an import never
    reads their source) and stored, as are the data files an import reads; the sources, read only for a
    traceback's lines, are deflated: a host's unzip writes 0.5 MB less (the FMU deflates the archive
    as one member; docs/performance.md, start-up). Its compiled kernels stay out
    (:func:`package_kernels`)."""
    members = {}
    for f in pkg.rglob("*"):
        if not f.is_file() or f.suffix in KERNEL_SUFFIXES:
            continue
        rel = f.relative_to(pkg.parent)
        if f.parent.name == "__pycache__":          # m.cpython-311.pyc -> m.pyc beside m.py
            rel = rel.parent.parent / (f.name.split(".", 1)[0] + ".pyc")
        members[rel.as_posix()] = f.read_bytes()
    return _package_zip(members)


def _package_zip(members: dict[str, bytes]) -> bytes:
    """The package archive of ``members`` (name -> bytes): sources deflated, everything else stored."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as z:
        for name in sorted(members):
            info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
            info.external_attr = 0o100644 << 16
            info.compress_type = zipfile.ZIP_DEFLATED if name.endswith(".py") else zipfile.ZIP_STORED
            z.writestr(info, members[name], compresslevel=9 if name.endswith(".py") else None)
    return buf.getvalue()


def edit_package(fmu: Path, out: Path, edit, rest=None) -> Path:
    """``fmu`` written to ``out`` with each member of its package archive passed through
    ``edit(name, data) -> data`` (names inside the archive: ``spurdiff/_fmu_entry.py``) and each other
    member through ``rest(name, data) -> data`` (unchanged without one); every member of the FMU
    stored. For the tests: another build of the package, a planted model. A source the edit changed
    loses its pyc (the pycs are unchecked: the import would run the old code), so the import compiles
    the edited source."""
    with zipfile.ZipFile(fmu) as zin, zipfile.ZipFile(out, "w", zipfile.ZIP_STORED) as zout:
        for item in zin.infolist():
            data = zin.read(item)
            # the package archive: resources/<package>.zip (the runtimes' lie deeper)
            if item.filename.startswith("resources/") and item.filename.count("/") == 1 and item.filename.endswith(".zip"):
                data = _edited_archive(data, edit)
            elif rest is not None:
                data = rest(item.filename, data)
            item.compress_type = zipfile.ZIP_STORED
            zout.writestr(item, data)
    return out


def _edited_archive(data: bytes, edit) -> bytes:
    with zipfile.ZipFile(io.BytesIO(data)) as zin:
        members = {i.filename: zin.read(i) for i in zin.infolist()}
    edited = {name: edit(name, body) for name, body in members.items()}
    stale = {name[:-3] + ".pyc" for name in members if name.endswith(".py") and edited[name] != members[name]}
    return _package_zip({name: body for name, body in edited.items() if name not in stale})


def package_kernels(pkg: Path) -> list[Path]:
    """The compiled kernels of the staged package ``pkg``: the files an FMU carries under
    ``resources/<pkg.name>/`` beside its package archive."""
    return sorted(f for f in pkg.rglob("*") if f.is_file() and f.suffix in KERNEL_SUFFIXES)


PLATFORMS = ("linux64", "win64")
PLATFORMS_ENV = "SPURDIFF_BUILD_PLATFORMS"    # what ``spurdiff build --platforms`` sets (a build in a subprocess too)


def platforms() -> tuple[str, ...]:
    """The platforms the FMUs are built for: ``$SPURDIFF_BUILD_PLATFORMS`` (comma-separated), else both.
    linux64 is always among them (the build machine's: the runtime is traced there); BuildError for
    an unknown name or a list without linux64."""
    raw = os.environ.get(PLATFORMS_ENV, "").strip()
    if not raw:
        return PLATFORMS
    want = tuple(p.strip() for p in raw.split(",") if p.strip())
    bad = [p for p in want if p not in PLATFORMS]
    if bad or not want:
        raise BuildError(f"--platforms {raw}: allowed a comma-separated list of {', '.join(PLATFORMS)}")
    if "linux64" not in want:
        raise BuildError(f"--platforms {raw}: linux64 is always built (the FMU's Python runtime is traced and "
                         "checked on the build machine's platform); allowed: linux64 or linux64,win64")
    return tuple(p for p in PLATFORMS if p in want)


def platform_sizes(fmu: Path) -> dict[str, tuple[int, int]]:
    """Compressed bytes and files of an FMU archive per platform: linux64 (binaries/linux64, the
    linux64 runtime and the .so kernels), win64 (binaries/win64, the win64 runtime, the .dll
    kernels), common (the description, the model's package, the rest)."""
    out = {"linux64": [0, 0], "win64": [0, 0], "common": [0, 0]}
    with zipfile.ZipFile(fmu) as z:
        for i in z.infolist():
            n = i.filename
            if (n.startswith(("binaries/win64/", "binaries/x86_64-windows/", "resources/python-win64/"))
                    or n.endswith(".dll") or n in (f"resources/{runtime_win64.CFG}", RUNTIME_ARCHIVES["win64"])):
                key = "win64"
            elif (n.startswith(("binaries/linux64/", "binaries/x86_64-linux/", "resources/python/"))
                  or n.endswith(".so") or n in ("resources/python_runtime.cfg", RUNTIME_ARCHIVES["linux64"])):
                key = "linux64"
            else:
                key = "common"
            out[key][0] += i.compress_size + 30 + len(n)   # the entry's data and its local header
            out[key][1] += 0 if n.endswith("/") else 1
    return {k: (v[0], v[1]) for k, v in out.items()}


def form_radius_table(pkg: Path) -> Path:
    """``gears/form_radius_table.json`` in the package copy ``pkg``: the form radii (undercut gears:
    the generation simulated, spurdiff.gears.generating) of SpurDifferential's default gear set,
    computed here by the same function, so that the FMU's default configuration builds its model
    without simulating the generation (measured: docs/performance.md, start-up)."""
    from spurdiff.fmi import differential_fmu
    from spurdiff.gears import generating, geometry

    found = {}
    orig = geometry.form_radius

    def recording(*args):
        r = orig(*args)
        found[repr(args)] = [r[0], r[1]]
        return r
    geometry.form_radius = recording
    try:
        differential_fmu.build_model({v.name: v.start for v in differential_fmu.VARIABLES})
    finally:
        geometry.form_radius = orig
    out = pkg / "gears" / generating.TABLE_FILE.name
    out.write_text(json.dumps(found, indent=0, sort_keys=True))
    return out


# The runtimes' files as archives (fmu_src/native/fmi/runtime_unpack.h unpacks them once per user and
# runtime): a host's unzip copies three stored members instead of inflating some 300 files
RUNTIME_ARCHIVES = {"common": "resources/runtime/common.zip",     # the standard library zip both runtimes use
                    "linux64": "resources/runtime/linux64.zip",   # the rest of resources/python/
                    "win64": "resources/runtime/win64.zip"}       # resources/python-win64/
RUNTIME_PACK_FORMAT = "4"   # in the packed file's name: a change of packing makes a new one (4: no numpy)


def _archive_part(name: str) -> str | None:
    """Which of :data:`RUNTIME_ARCHIVES` the runtime entry ``name`` goes into (None: not a runtime file)."""
    if name == f"resources/{runtime_bundle.STDLIB_ZIP}":
        return "common"
    if name.startswith(f"resources/{runtime_bundle.HOME}/"):
        return "linux64"
    if name.startswith(f"resources/{runtime_win64.HOME}/"):
        return "win64"
    return None


def packed_runtimes(base: Path) -> Path:
    """The runtimes' entries of ``base`` (:func:`harness.build.fmu._runtime_entries`) as the stored archives
    of :data:`RUNTIME_ARCHIVES`. Each inner archive's members LZMA-compressed (zipfile's LZMA1
    with its end marker, which ``runtime_unpack.h: ru_unlzma`` decodes: a quarter fewer bytes than
    deflate at level 9 for every host's unzip to copy, 7.8 against 10.3 MB; the unpack, once per user,
    decodes at about 47 MB/s instead of inflating at 230), in ``base``'s order with their times and
    modes: the same bytes for the same runtime. Made once per ``base``,
    beside it, written aside and renamed into place."""
    out = base.with_name(f"packed{RUNTIME_PACK_FORMAT}-{base.stem}.zip")
    if out.is_file():
        return out
    buffers: dict[str, io.BytesIO] = {}
    inner: dict[str, zipfile.ZipFile] = {}
    with zipfile.ZipFile(base) as zin:
        for item in zin.infolist():
            part = _archive_part(item.filename)
            if part is None:
                raise BuildError(f"{base.name}: {item.filename} is not a runtime file")
            if part not in inner:
                buffers[part] = io.BytesIO()
                inner[part] = zipfile.ZipFile(buffers[part], "w", zipfile.ZIP_LZMA)
            info = zipfile.ZipInfo(item.filename[len("resources/"):], date_time=item.date_time)
            info.external_attr = item.external_attr
            info.compress_type = zipfile.ZIP_STORED if item.is_dir() else zipfile.ZIP_LZMA
            inner[part].writestr(info, zin.read(item.filename))
    staged = out.with_name(f".{out.name}.{os.getpid()}")
    try:
        with zipfile.ZipFile(staged, "w") as z:
            for part in RUNTIME_ARCHIVES:
                if part in inner:
                    inner[part].close()
                    info = _entry(RUNTIME_ARCHIVES[part])
                    info.compress_type = zipfile.ZIP_STORED     # a host's unzip copies it
                    z.writestr(info, buffers[part].getvalue())
        os.replace(staged, out)
    finally:
        staged.unlink(missing_ok=True)
    return out


def archive_lines(fmu: zipfile.ZipFile, platform: str) -> str:
    """The runtime description's ``archive=`` lines of ``platform`` (linux64, win64) for the FMU being
    written in ``fmu``: the common archive, then the platform's, each with its SHA-256."""
    have = set(fmu.namelist())
    lines = []
    for part in ("common", platform):
        name = RUNTIME_ARCHIVES[part]
        if name in have:
            lines.append(f"archive={hashlib.sha256(fmu.read(name)).hexdigest()} {name[len('resources/'):]}\n")
    return "".join(lines)


def unpack_runtime_archives(resources: Path, into: Path | None = None, cfg: str = "python_runtime.cfg") -> list[str]:
    """The runtime archives the description ``resources/<cfg>`` lists, each checked against its SHA-256,
    unpacked into ``into`` (default: ``resources`` itself, the layout of an FMU before the archives)
    as the loader does (fmu_src/native/fmi/runtime_unpack.h); the names unpacked. For the tests and
    tools that read the runtime's files of an extracted FMU."""
    resources = Path(resources)
    into = Path(into) if into else resources
    names = []
    for line in (resources / cfg).read_text().splitlines():
        if not line.startswith("archive="):
            continue
        digest, _, rel = line[len("archive="):].partition(" ")
        data = (resources / rel).read_bytes()
        if hashlib.sha256(data).hexdigest() != digest:
            raise BuildError(f"{resources / rel}: its SHA-256 is not the description's")
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            for n in z.namelist():
                if n.startswith("/") or ".." in n.split("/"):
                    raise BuildError(f"{resources / rel}: member {n} leaves the folder")
            z.extractall(into)
            names += z.namelist()
    return names
