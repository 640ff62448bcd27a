"""Synthetic EPA Test Car List files (the real lists are not needed by these tests)."""

from __future__ import annotations

from pathlib import Path

import pytest

from helpers.epa_lists import HEADER, camry_rows, row, write_list
from vehval.epa import read_test_car_list
from vehval.epa.specs import specs_from_tests


@pytest.fixture
def prius_list(tmp_path) -> Path:
    """A small 2016 list: EPA and manufacturer Prius tests, an SC03, a Camry, a Prius c."""
    rows = [
        row(number="T1", code=3, desc="HWFE", fe=71.2),
        row(number="T2", code=90, desc="US06", fe=48.6, bags=(35.4, 54.4, "", "")),
        row(number="T3", code=21, desc="Federal fuel 2-day exhaust (w/can load)", fe=78.0,
            bags=(50.7, 126.3, 62.7, 114.4)),
        row(number="T4", orig="MFR", cfg="1", code=3, desc="HWFE", fe=66.0,
            target=(24.153, 0.33502, 0.014096)),
        row(number="T5", orig="MFR", code=95, desc="SC03", fe=58.8),
        row(number="T6", orig="MFR", code=11, desc="Cold CO", fuel=("26", "Cold CO Regular (Tier 2)"),
            fe=56.3, bags=(33.8, 70.8, 49.0, "")),
        row(model="CAMRY HYBRID LE", vid="16-CH1H", number="T7", weight=3625, fe=60.1),
        row(model="PRIUS c", vid="12-NP1H", number="T8", weight=2750, fe=72.0),
    ]
    return write_list(tmp_path / "16tstcar.csv", rows)


@pytest.fixture
def specs(tmp_path):
    path = write_list(tmp_path / "19tstcar.csv", camry_rows(), header=HEADER)
    return specs_from_tests(read_test_car_list(path))
