"""Cycle identification on the real D3 files (skips when the shared data is absent).

Expected cycles come from the datasets' SOURCE.txt (the D3 master summary for the Cruze, the
duration/distance/top-speed inference for the Camry subset). Measured RMS errors on these
files are 0.10-0.23 m/s except the Cruze WLTP run (0.83 m/s: its high phase departs from the
package WLTC 3b by up to ~19 km/h for about 2 min, probably an older WLTC version); the D3
clock puts the cycle start within 0.6 s of t = 0 (0.5 s on the NEDC run).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from helpers.data import CRUZE, REAL
from vehval.cycles_match import identify_cycle
from vehval.io.readers import read_raw

pytestmark = pytest.mark.realdata

REPO = Path(__file__).resolve().parents[2]
CAMRY = REAL / "d3_2018_toyota_camry_1hz_subset"

if not (CRUZE.is_dir() and CAMRY.is_dir()):
    pytest.skip(f"real D3 data not found under {REAL}", allow_module_level=True)

EXPECTED = {  # test id -> (identified name, largest RMS error [m/s] accepted here)
    "61410012": ("udds", 0.3), "61410013": ("udds", 0.3), "61410021": ("udds", 0.3),
    "61410028": ("udds", 0.3), "61410015": ("hwfet_x2", 0.3), "61410016": ("us06_x2", 0.3),
    "61410005": ("nedc", 0.3), "61410004": ("wltc3b", 0.95), "61410026": ("sc03_x2", 0.3),
    "61410007": (None, None),  # wide-open-throttle runs: no cycle
    "61811011": ("udds_x2", 0.3), "61811012": ("udds", 0.3), "61811013": ("hwfet_x2", 0.3),
    "61811014": ("us06_x2", 0.3),
}


@pytest.mark.parametrize("test_id", sorted(EXPECTED))
def test_real_d3_cycles(test_id):
    d = CRUZE if test_id.startswith("614") else CAMRY
    raw = read_raw(d / f"{test_id} Test Data.txt")
    speed = next(n for n in raw.names if n.lower().startswith("dyno_sp"))
    name, score, details = identify_cycle(raw.data[raw.time_name], raw.data[speed] * 0.44704)
    want, max_rms = EXPECTED[test_id]
    assert name == want, details
    if want is None:
        assert score == 0.0
        return
    assert details["rms_mps"] < max_rms and details["explained"] > 0.99
    assert abs(details["offset_s"]) <= 0.6
    if details["repeats"] == 2:  # second run after the first one and a pause
        cyc = name.removesuffix("_x2")
        assert np.diff(details["offsets_s"])[0] > {"udds": 1369, "hwfet": 765, "us06": 600,
                                                   "sc03": 600}[cyc]
