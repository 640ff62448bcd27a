"""Fixtures of the hardening (fuzz) tests: a small valid MDF4 file (helpers.py holds the rest)."""

from __future__ import annotations

import numpy as np
import pytest

# ------------------------------------------------------------------ valid file builders


@pytest.fixture(scope="session")
def mdf_bytes(tmp_path_factory) -> bytes:
    """A small valid MDF4 file (two channels at 10 Hz, one at 1 Hz)."""
    from asammdf import MDF
    from asammdf import Signal as MSig

    t10 = np.arange(50) * 0.1
    t1 = np.arange(5) * 1.0
    mdf = MDF(version="4.10")
    mdf.append([MSig(samples=3.0 * t10, timestamps=t10, name="Dyno_Speed", unit="mph"),
                MSig(samples=1000 + t10, timestamps=t10, name="Engine_Speed", unit="rpm")])
    mdf.append([MSig(samples=0.6 + 0 * t1, timestamps=t1, name="SOC", unit="%")])
    path = tmp_path_factory.mktemp("mdf") / "valid.mf4"
    mdf.save(path, overwrite=True)
    mdf.close()
    return path.read_bytes()
