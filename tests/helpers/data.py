"""Where the shared real-data directory is: the one place the tests spell it.

``VEHVAL_SHARED_DATA`` names the shared ``data`` directory, else ``<repo>/../shared/data``;
its ``real/`` folder holds the real test files (Cruze D3 10 Hz, Camry, Prius c OBD, Insight,
EPA Test Car Lists under ``epa_test_car_list/``). Tests on real files skip cleanly when a file
is absent (the ``real_data`` fixture of ``tests/conftest.py`` or :func:`require`).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

#: The repository root.
REPO = Path(__file__).resolve().parents[2]
#: The shared data directory.
SHARED_DATA = Path(os.environ.get("VEHVAL_SHARED_DATA") or REPO / ".." / "shared" / "data")
#: Its real test files (``VEHVAL_SHARED_DATA`` naming the ``real/`` folder itself is accepted).
REAL = SHARED_DATA / "real" if (SHARED_DATA / "real").is_dir() else SHARED_DATA
#: The Cruze D3 10 Hz tests.
CRUZE = REAL / "d3_2014_chevrolet_cruze_diesel"
#: The template of the Cruze D3 files (kept in the repository).
CRUZE_TEMPLATE = REPO / "tests" / "qa" / "templates" / "cruze.yaml"
#: EPA Test Car Lists.
EPA_LISTS = REAL / "epa_test_car_list"


def require(path: Path) -> Path:
    """``path`` when it exists, else skip the calling test naming what is missing."""
    if not path.exists():
        pytest.skip(f"real data not present: {path} (set VEHVAL_SHARED_DATA)")
    return path
