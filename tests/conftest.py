"""Shared fixtures: the project's FMUs are built once per test session (skipped when current)."""
from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def fmu_files():
    from harness.build.fmu import FMUS, build

    paths = build(list(FMUS), quiet=True)
    return dict(zip(FMUS, paths))


@pytest.fixture(scope="session")
def differential_fmu(fmu_files):
    return fmu_files["SpurDifferential"]


@pytest.fixture(autouse=True)
def _fmpy_logger_proxy_restored():
    """A test that ran simulate_fmu(logger=...) leaves fmpy's process-wide logger proxy pointing
    at a callback freed after it: the next FMU logging through fmpy's defaults would crash the
    worker (harness/fmi/fmpy_logging.py)."""
    yield
    from harness.fmi import fmpy_logging
    fmpy_logging.restore_default()


# CI runs the property tests with a fixed seed (reproducible); locally they explore at random.
import os  # noqa: E402

from hypothesis import settings  # noqa: E402

settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
settings.register_profile("dev", deadline=None)
settings.load_profile("ci" if os.environ.get("CI") else "dev")
