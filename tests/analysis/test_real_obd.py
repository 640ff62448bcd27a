"""Real data: 2014 Prius c OBD logs (skipped when the shared data set is absent)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from helpers.data import REAL
from vehval.analysis import analyze
from vehval.io.importer import import_test

ROOT = Path(__file__).resolve().parents[2]
OBD = REAL / "obd_2014_toyota_prius_c"
TEMPLATE = Path(__file__).parent / "templates" / "prius_c_obd.yaml"

pytestmark = pytest.mark.skipif(not OBD.is_dir(), reason="real Prius c OBD data not available")


def test_prius_c_engine_switching_log():
    """output3 has the engine switching on and off in traffic: detection, the rule fit and the
    SOC window must give a sensible summary; sentinel currents are excluded with a finding."""
    test = import_test([OBD / "output3.csv"], TEMPLATE)
    res = analyze(test)
    d = json.loads(json.dumps(res.to_dict()))
    assert d["engine"]["starts"] >= 5                      # stop-and-go with EV phases
    assert 0.2 < d["engine"]["on_share"] < 0.9
    assert d["rule_agreement"] is not None and d["rule_agreement"] > 0.7
    soc = d["soc_regulation"]
    assert 0.3 < soc["soc_min"] < soc["soc_mean"] < soc["soc_max"] < 0.9   # SOC window [-]
    # the PID has 20/255 steps (7.8 % of SOC): reported, and coulomb counting against it
    # (current at ~1 Hz) does not fit within its quantisation noise, so it is not used
    assert 0.05 < soc["soc_resolution"] < 0.1
    assert d["inputs"]["soc"]["method"].startswith("measured")
    assert any("coulomb counting rejected" in f["message"] for f in d["findings"])
    assert any("-327.68" in f["message"] and f["kind"] == "excluded" for f in d["findings"])
    starts = [e for e in d["events"] if e["type"] == "on"]
    assert starts and all(e["speed_mps"] is None or 0 <= e["speed_mps"] < 40 for e in starts)


def test_prius_c_engine_always_on_log():
    """output5: the engine runs throughout (warm-up drive): no rule is estimated, and the
    analysis says why instead of inventing thresholds."""
    res = analyze(import_test([OBD / "output5.csv"], TEMPLATE))
    assert res.engine["starts"] == 0
    assert not any(k.startswith(("engine_", "min_")) for k in res.controller)
    assert any("not estimated" in f["message"] for f in res.findings)
    assert np.isfinite(res.modes["shares"]["engine_drive"]["share"])
