"""The real EPA Test Car Lists (2016, 2017, 2019): every file reads; values match the raw text.

Skips cleanly when the shared data directory is absent (env VEHVAL_SHARED_DATA or
``<repo>/../shared/data/real``).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from vehval.constants import LBF_N
from vehval.epa import apply_selector, plan_for, read_lists, read_test_car_list

pytestmark = pytest.mark.realdata

REPO = Path(__file__).resolve().parents[2]
REAL = Path(os.environ.get("VEHVAL_SHARED_DATA") or REPO / ".." / "shared" / "data" / "real")
EPA = REAL / "epa_test_car_list"

if not EPA.is_dir():
    pytest.skip(f"EPA Test Car List not found at {EPA}", allow_module_level=True)


def test_every_year_reads():
    n = {f.name: len(read_test_car_list(f)) for f in sorted(EPA.glob("*tstcar.csv"))}
    assert set(n) == {"16tstcar.csv", "17tstcar.csv", "19tstcar.csv"}
    assert all(v > 1000 for v in n.values())


def test_prius_2016_epa_tests():
    tests = apply_selector(read_lists([EPA]), "model=PRIUS,year=2016,originator=EPA")
    assert len(tests) == 6
    ftp = next(t for t in tests if t.test_number == "GTYX91002968")
    # raw text: 18.272 lbf, bags 50.7069485 / 126.2907815 / 62.7224963 / 114.3515914 mpg
    assert ftp.target_a_n == pytest.approx(18.272 * LBF_N, rel=1e-12)
    assert ftp.bags[1] == pytest.approx(126.2907815, rel=1e-12)
    assert all(plan_for(t)[0] is not None for t in tests)
