"""Where things are read from and written to: one place for every folder the commands use.

* **Read** (shipped in the package, found beside the modules; in a wheel install they are in
  site-packages, and nothing is ever written there): the C sources of the FMUs'
  binary (:func:`fmu_sources`), the physics package bundled into each FMU (:func:`physics_package`),
  scenes, sweeps, the accuracy grid and its stored data (beside their harness modules).
* **Results** go under the current folder: ``./results/<scene>/`` (or the command's ``--out``).
* **Built FMUs** go to a per-user cache keyed by the package version and the digest of the FMU
  sources (:func:`fmu_cache_dir`: the platform's cache folder, e.g. ``~/.cache/spurdiff/``;
  ``SPURDIFF_FMU_DIR`` overrides it). In a source checkout they stay in ``build/fmus/`` as before.
"""
from __future__ import annotations

import hashlib
import os
from functools import lru_cache
from pathlib import Path

HARNESS = Path(__file__).resolve().parents[1]


def package_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("spurdiff")
    except PackageNotFoundError:   # run from a checkout without installing
        import spurdiff
        return spurdiff.__version__


def physics_package() -> Path:
    """The ``spurdiff`` package folder (bundled into every FMU)."""
    import spurdiff
    return Path(spurdiff.__file__).resolve().parent


def fmu_sources() -> Path:
    """The folder with ``native/`` (the C sources of the FMUs' binary) of the code that runs:
    ``fmu_src/`` beside this harness in a checkout (installed editable or not, a clone or a
    worktree), else the installed package ``spurdiff_fmus`` (a wheel). Never through the import
    system first: an editable install of another checkout would hand over that checkout's sources,
    and a C file changed here would silently not be what this checkout builds and tests."""
    own = HARNESS.parent / "fmu_src"
    if (own / "native").is_dir():
        return own
    import spurdiff_fmus
    return Path(spurdiff_fmus.__file__).resolve().parent


def checkout_root() -> Path | None:
    """The source checkout this package runs from (editable install or plain checkout), or None
    for an installed wheel."""
    root = HARNESS.parent
    if (root / "pyproject.toml").is_file() and (root / "fmu_src").is_dir() and (root / ".git").exists():
        return root
    return None


def results_dir(*parts: str) -> Path:
    """``./results/...`` under the current working folder."""
    return Path.cwd().joinpath("results", *parts)


@lru_cache(maxsize=1)
def sources_digest() -> str:
    """Digest of everything an FMU is built from (scripts, C sources, physics package, the
    build and modelDescription code), so a changed source never reuses a cached FMU."""
    h = hashlib.sha256()
    roots = [fmu_sources(), physics_package()]
    files = [HARNESS / "build" / "fmu.py", HARNESS / "build" / "modeldescription.py"]
    for root in roots:   # in a checkout the physics package lies inside fmu_src/: each file once
        files += sorted(p for p in root.rglob("*") if p.is_file() and "__pycache__" not in p.parts
                        and p.suffix in (".py", ".c", ".h", ".toml") and p not in files)
    for p in files:
        h.update(p.name.encode())
        h.update(p.read_bytes())
    return h.hexdigest()


def fmu_cache_dir() -> Path:
    """Where built FMUs go: ``$SPURDIFF_FMU_DIR``; in a checkout ``build/fmus``; otherwise the
    per-user cache folder ``<cache>/spurdiff/<version>-<digest>/fmus``."""
    env = os.environ.get("SPURDIFF_FMU_DIR")
    if env:
        return Path(env).expanduser().resolve()
    root = checkout_root()
    if root is not None:
        return root / "build" / "fmus"
    from platformdirs import user_cache_dir
    return Path(user_cache_dir("spurdiff")) / f"{package_version()}-{sources_digest()[:12]}" / "fmus"


def docs_dir() -> Path:
    """Where generated documentation goes: the checkout's docs/, or ./results/docs installed."""
    root = checkout_root()
    return root / "docs" if root is not None else results_dir("docs")
