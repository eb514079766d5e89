"""Shared fixtures: the project's FMUs are built once per test session (skipped when current); the
temporary folders of the processes the tests start are made inside pytest's own folders."""
from __future__ import annotations

import os
import tempfile

import pytest


@pytest.fixture(scope="session")
def fmu_files():
    from harness.build.fmu import FMUS, build

    paths = build(list(FMUS), quiet=True)
    return dict(zip(FMUS, paths))


@pytest.fixture(scope="session")
def differential_fmu(fmu_files):
    return fmu_files["SpurDifferential"]


@pytest.fixture(scope="session", autouse=True)
def _children_scratch_in_basetemp(tmp_path_factory):
    """Processes the tests start (hosts, checkers, builds) make their temporary folders under this
    session's pytest folder, which pytest prunes after three sessions, instead of in the machine's
    temporary folder: a host killed by its test, or one that never removes its extraction of an FMU
    (tens of MB each), leaves nothing behind there. This process's own temporary folder is pinned
    first, unchanged."""
    tempfile.gettempdir()
    old = os.environ.get("TMPDIR")
    os.environ["TMPDIR"] = str(tmp_path_factory.mktemp("children-tmp"))
    yield
    if old is None:
        os.environ.pop("TMPDIR", None)
    else:
        os.environ["TMPDIR"] = old


@pytest.fixture(scope="session", autouse=True)
def _start_cache_in_basetemp(tmp_path_factory):
    """The FMUs' start cache (fmu_src/native/fmi/fmi2_loader.c: the native starts of parameters set to other
    values, kept for the next instance) of this session's instances, in this process and the ones it
    starts: a folder of this session's, never the user's cache (tests/fmus/test_start_cache.py sets its
    own)."""
    old = os.environ.get("SPURDIFF_FMU_START_CACHE_DIR")
    os.environ["SPURDIFF_FMU_START_CACHE_DIR"] = str(tmp_path_factory.mktemp("start-cache") / "starts")
    yield
    if old is None:
        os.environ.pop("SPURDIFF_FMU_START_CACHE_DIR", None)
    else:
        os.environ["SPURDIFF_FMU_START_CACHE_DIR"] = old


@pytest.fixture
def children_scratch_in_tmp_path(tmp_path, monkeypatch):
    """For a test whose hosts unpack their FMU (fmpy's extract()) into a new temporary folder and
    may never remove it (some are killed): their TMPDIR is the test's own folder."""
    tempfile.gettempdir()
    monkeypatch.setenv("TMPDIR", str(tmp_path))


@pytest.fixture(autouse=True)
def _fmpy_logger_proxy_restored():
    """A test that ran simulate_fmu(logger=...) leaves fmpy's process-wide logger proxy pointing
    at a callback freed after it: the next FMU logging through fmpy's defaults would crash the
    worker (harness/fmi/fmpy_logging.py)."""
    yield
    from harness.fmi import fmpy_logging
    fmpy_logging.restore_default()


# CI runs the property tests with a fixed seed (reproducible); locally they explore at random.
from hypothesis import settings  # noqa: E402

settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
settings.register_profile("dev", deadline=None)
settings.load_profile("ci" if os.environ.get("CI") else "dev")
