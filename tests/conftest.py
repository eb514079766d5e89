"""Shared fixtures: the project's FMUs are built once per test session (skipped when current)."""
from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def fmu_files():
    from harness.build import FMUS, build

    paths = build(list(FMUS), quiet=True)
    return dict(zip(FMUS, paths))


@pytest.fixture(scope="session")
def differential_fmu(fmu_files):
    return fmu_files["SpurDifferential"]
