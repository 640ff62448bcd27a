"""Fixtures for every test folder: the shared real-data directory.

The path itself is spelled once, in :mod:`helpers.data` (``VEHVAL_SHARED_DATA`` or
``<repo>/../shared/data``); module-level uses (``skipif``, ``parametrize``) import its
constants, fixtures below skip the test cleanly when the data is absent.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from helpers.data import CRUZE, REAL, SHARED_DATA, require


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The shared data directory (skips when absent)."""
    return require(SHARED_DATA)


@pytest.fixture(scope="session")
def real_data() -> Path:
    """The folder of real test files, ``<shared data>/real`` (skips when absent)."""
    return require(REAL)


@pytest.fixture(scope="session")
def cruze_data() -> Path:
    """The folder of the Cruze D3 10 Hz tests (skips when absent)."""
    return require(CRUZE)
